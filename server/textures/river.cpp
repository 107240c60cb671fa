#include "textures/river.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <tuple>

#include "common/error.h"
#include "common/validate.h"
#include "runtime/slices.h"
#include "runtime/upload.h"
#include "textures/bake_costs.h"

namespace squall::textures {
namespace {

using namespace squall::validate;

constexpr int kMaxChannels = 256, kMaxJunctions = 256, kMaxObstacles = 256;
// Q, du^2/s: psi and the velocities (Q over distances down to the grid's) stay finite in float32 (3e38 made
// them infinite).
constexpr double kMaxFlowRate = 1e9;
constexpr int kMaxPoints = 4096;     // per polyline
constexpr int kMaxJunctionSide = 8;  // channels on one side of a junction
constexpr int64_t kMaxBins = int64_t(1) << 20;
constexpr int64_t kMaxBinItems = int64_t(1) << 24;  // segment entries over all bins: 64 MiB

void polyline(const std::vector<Point2>& points, int min_points, const std::string& path) {
  in(path + ".points size", int64_t(points.size()), min_points, kMaxPoints);
  for (size_t k = 0; k < points.size(); ++k) {
    in(at(path + ".points", k) + ".x", points[k].x, closed(-kMaxCoordinate, kMaxCoordinate));
    in(at(path + ".points", k) + ".y", points[k].y, closed(-kMaxCoordinate, kMaxCoordinate));
    const Point2& next = points[(k + 1) % points.size()];
    if (k + 1 < points.size() && points[k].x == next.x && points[k].y == next.y)
      fail(Code::InvalidArgument, at(path + ".points", k + 1) + " repeats the point before it");
  }
}

void junction(const RiverJunctionSpec& j, size_t channels, std::vector<int>& ends, std::vector<int>& starts,
              const std::string& path) {
  in(path + ".upstream size", int64_t(j.upstream.size()), 1, kMaxJunctionSide);
  in(path + ".downstream size", int64_t(j.downstream.size()), 1, kMaxJunctionSide);
  if (j.upstream.size() + j.downstream.size() < 3)
    fail(Code::InvalidArgument, path + " joins " + std::to_string(j.upstream.size()) + " channel to " +
                                    std::to_string(j.downstream.size()) +
                                    ": a junction has 2 or more channels on one side (draw one channel instead)");
  auto check = [&](const std::vector<uint32_t>& side, std::vector<int>& seen, const std::string& name) {
    for (size_t k = 0; k < side.size(); ++k) {
      const std::string field = at(path + "." + name, k);
      in(field, int64_t(side[k]), 0, int64_t(channels) - 1);
      if (seen[side[k]]++)
        fail(Code::InvalidArgument, field + " = " + std::to_string(side[k]) + ": the channel is already " +
                                        (name == "upstream" ? "ending" : "starting") + " at a junction");
    }
  };
  check(j.upstream, ends, "upstream");
  check(j.downstream, starts, "downstream");
}

}  // namespace

// The river's walls and polygons on the device.
struct RiverEngine::Geometry {
  RiverGeometry geo{};
  RiverNetwork network;
  std::vector<double> obstacle_psi;
  std::vector<float> boundary_psi, boundary_s;
  std::vector<cl_int> bin_offsets;        // bin_start on the host, for bake_tile_costs
  Slot walls_memory;                      // the walls' and polygons' bytes in the memory budget
  Slot bins_memory;                       // the bins' bytes in the memory budget
  std::vector<PolygonBox> polygon_boxes;  // the channels' and obstacles' polygons, likewise
  cl::Buffer segments, segment_boundary, bin_start, bin_items, psi, s, polygon_start, polygon_points;
};

RiverEngine::RiverEngine(Runtime& runtime, LimitGate& gate)
    : runtime_(runtime),
      gate_(gate),
      points_(runtime, "textures/river.cl", "river_points"),
      bake_(runtime, "textures/river.cl", "river_bake") {}

void RiverEngine::validate(const RiverSpec& river, const std::string& path) const { validate_river(river, path); }

void RiverEngine::validate(const BakeGrid& grid, const std::string& path, const std::string& prefix,
                           const std::string& region_note) const {
  validate_bake_grid(grid, gate_, path, prefix, region_note);
}

void validate_river(const RiverSpec& river, const std::string& path) {
  in(path + ".channels size", int64_t(river.channels.size()), 1, kMaxChannels);
  in(path + ".junctions size", int64_t(river.junctions.size()), 0, kMaxJunctions);
  in(path + ".obstacles size", int64_t(river.obstacles.size()), 0, kMaxObstacles);
  for (size_t c = 0; c < river.channels.size(); ++c) {
    const RiverChannelSpec& channel = river.channels[c];
    const std::string cpath = at(path + ".channels", c);
    polyline(channel.left, 2, cpath + ".left_bank");
    polyline(channel.right, 2, cpath + ".right_bank");
    if (channel.flow_rate) positive(cpath + ".flow_rate", *channel.flow_rate, kMaxFlowRate);
    // Lengths of at least kMinVelocityDivisor: a river's speeds scale with Q / s, and stay finite in float.
    if (channel.cross_section)
      in(cpath + ".cross_section", *channel.cross_section, closed(kMinVelocityDivisor, kMaxCoordinate));
    else if (!(cross_section(channel) >= kMinVelocityDivisor))
      fail(Code::InvalidArgument, cpath + ": the banks start less than " + validate::number(kMinVelocityDivisor) +
                                      " du apart; give cross_section");
  }
  std::vector<int> ends(river.channels.size()), starts(river.channels.size());
  for (size_t j = 0; j < river.junctions.size(); ++j)
    junction(river.junctions[j], river.channels.size(), ends, starts, at(path + ".junctions", j));
  for (size_t o = 0; o < river.obstacles.size(); ++o) {
    const std::string opath = at(path + ".obstacles", o);
    polyline(river.obstacles[o].outline, 3, opath + ".outline");
    if (river.obstacles[o].search_radius)
      in(opath + ".search_radius", *river.obstacles[o].search_radius, closed(kMinVelocityDivisor, kMaxCoordinate));
  }
  in(path + ".p", river.p, open_closed(0, 8));
  if (river.search_radius)
    in(path + ".search_radius", *river.search_radius, closed(kMinVelocityDivisor, kMaxCoordinate));
  solve_network(river, path);  // its flow rates and bank values: a river they fail for is refused now
}

void validate_bake_grid(const BakeGrid& grid, const LimitGate& gate, const std::string& path, const std::string& prefix,
                        const std::string& region_note) {
  const std::string p = path + "." + prefix;
  in(p + "nx", grid.nx, 2, 4096);
  in(p + "ny", grid.ny, 2, 4096);
  gate.check_grid(p + "nx", p + "ny", grid.nx, grid.ny);
  in(p + "region.x0", grid.x0, closed(-kMaxCoordinate, kMaxCoordinate));
  in(p + "region.y0", grid.y0, closed(-kMaxCoordinate, kMaxCoordinate));
  in(p + "region.x1", grid.x1, open_closed(grid.x0, kMaxCoordinate));
  in(p + "region.y1", grid.y1, open_closed(grid.y0, kMaxCoordinate));
  // The baked grid's node spacing is a velocity grid's, at least kMinVelocityDivisor; and the kernel places
  // nodes in float32, as output pixels are placed: a spacing of many float32 steps at the region's
  // coordinates (otherwise blocks of nodes bake at one point).
  for (const auto& [axis, lo, hi, nodes] :
       {std::tuple{"x", grid.x0, grid.x1, grid.nx}, std::tuple{"y", grid.y0, grid.y1, grid.ny}}) {
    const double extent = hi - lo, spacing = extent / (nodes - 1);
    const double finest = std::max(std::abs(lo), std::abs(hi)) * kMinPixelPerCoordinate;
    if (spacing < kMinVelocityDivisor || spacing < finest)
      fail(Code::InvalidArgument,
           p + "region spans " + validate::number(extent) + " du along " + axis + " over " + std::to_string(nodes) +
               " nodes: their spacing must be at least " + validate::number(std::max(kMinVelocityDivisor, finest)) +
               " du there (fewer nodes, a wider region, or one nearer the origin)" + region_note);
  }
}

namespace {

struct Walls {
  std::vector<cl_float4> segments;  // (a.x, a.y, b.x, b.y)
  std::vector<cl_int> boundary;     // per segment
  std::vector<cl_int> polygon_start{0};
  std::vector<cl_float2> polygon_points;
};

void add_polyline(Walls& walls, const std::vector<Point2>& points, int boundary, bool closed) {
  const size_t n = points.size(), segments = closed ? n : n - 1;
  for (size_t k = 0; k < segments; ++k) {
    const Point2 &a = points[k], &b = points[(k + 1) % n];
    walls.segments.push_back({{float(a.x), float(a.y), float(b.x), float(b.y)}});
    walls.boundary.push_back(boundary);
  }
}

// The polygon's bounding box, then its points (river_geometry.h).
void add_polygon(Walls& walls, const std::vector<Point2>& points) {
  cl_float2 lo{{INFINITY, INFINITY}}, hi{{-INFINITY, -INFINITY}};
  for (const Point2& p : points) {
    lo = {{std::min(lo.s[0], float(p.x)), std::min(lo.s[1], float(p.y))}};
    hi = {{std::max(hi.s[0], float(p.x)), std::max(hi.s[1], float(p.y))}};
  }
  walls.polygon_points.push_back(lo);
  walls.polygon_points.push_back(hi);
  for (const Point2& p : points) walls.polygon_points.push_back({{float(p.x), float(p.y)}});
  walls.polygon_start.push_back(cl_int(walls.polygon_points.size()));
}

// The box and point count of each polygon of `walls` (its first two points are its box: add_polygon).
std::vector<PolygonBox> polygon_boxes(const Walls& walls) {
  std::vector<PolygonBox> boxes;
  for (size_t k = 0; k + 1 < walls.polygon_start.size(); ++k) {
    const cl_float2 &lo = walls.polygon_points[size_t(walls.polygon_start[k])],
                    &hi = walls.polygon_points[size_t(walls.polygon_start[k]) + 1];
    boxes.push_back(
        {lo.s[0], lo.s[1], hi.s[0], hi.s[1], double(walls.polygon_start[k + 1] - walls.polygon_start[k] - 2)});
  }
  return boxes;
}

// The water of a channel: its left bank, then its right bank backwards.
std::vector<Point2> channel_polygon(const RiverChannelSpec& c) {
  std::vector<Point2> polygon = c.left;
  polygon.insert(polygon.end(), c.right.rbegin(), c.right.rend());
  return polygon;
}

// The bins segment `s` passes through, column by column: in each column of bins it crosses, the rows its
// stretch over that column's x interval spans (every bin the segment touches, and no other: a point within
// the search radius of the segment lies in the bins around one of them).
template <typename F>
void for_each_bin_crossed(const cl_float4& s, const RiverGeometry& geo, F&& visit) {
  const double ax = s.s[0], ay = s.s[1], bx = s.s[2], by = s.s[3];
  auto column = [&](double x) { return std::clamp(int((x - geo.bin_x0) / geo.bin_size), 0, geo.bins_x - 1); };
  auto row = [&](double y) { return std::clamp(int((y - geo.bin_y0) / geo.bin_size), 0, geo.bins_y - 1); };
  auto y_at = [&](double x) { return ax == bx ? ay : ay + (by - ay) * (x - ax) / (bx - ax); };
  const double x_lo = std::min(ax, bx), x_hi = std::max(ax, bx);
  const int c0 = column(x_lo), c1 = column(x_hi);
  for (int c = c0; c <= c1; ++c) {  // the end columns to the segment's ends: a clamped column holds them
    const double left = c == c0 ? x_lo : std::max(x_lo, geo.bin_x0 + double(c) * geo.bin_size);
    const double right = c == c1 ? x_hi : std::min(x_hi, geo.bin_x0 + double(c + 1) * geo.bin_size);
    double y0 = ax == bx ? std::min(ay, by) : y_at(left), y1 = ax == bx ? std::max(ay, by) : y_at(right);
    if (y0 > y1) std::swap(y0, y1);
    y0 -= 1e-4 * geo.bin_size, y1 += 1e-4 * geo.bin_size;  // a segment through a bin's corner: both rows
    for (int r = row(y0), r1 = row(y1); r <= r1; ++r) visit(size_t(r) * size_t(geo.bins_x) + size_t(c));
  }
}

// Bins of about s_max / 2 over the segments' bounding box (fewer, larger bins past kMaxBins), each listing
// the segments that pass through it (CSR). RESOURCE_EXHAUSTED, naming `path`, past kMaxBinItems entries
// (walls that cross the region many times over), counted before any is stored; the entries are then held in
// `gate`'s memory budget, host and device copies, in `memory`.
void bin_segments(const Walls& walls, RiverGeometry& geo, std::vector<cl_int>& start, std::vector<cl_int>& items,
                  LimitGate& gate, Slot& memory, const std::string& path) {
  float x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
  for (const cl_float4& s : walls.segments) {
    x0 = std::min({x0, s.s[0], s.s[2]});
    y0 = std::min({y0, s.s[1], s.s[3]});
    x1 = std::max({x1, s.s[0], s.s[2]});
    y1 = std::max({y1, s.s[1], s.s[3]});
  }
  const double width = double(x1 - x0), height = double(y1 - y0);
  double size = std::max({0.5 * geo.s_max, std::sqrt(width * height / double(kMaxBins)) * 1.01, 1e-6});
  while ((width / size + 1) * (height / size + 1) > double(kMaxBins)) size *= 1.5;  // a long, thin box
  geo.bin_size = float(size);
  geo.bin_x0 = x0;
  geo.bin_y0 = y0;
  geo.bins_x = int((x1 - x0) / geo.bin_size) + 1;
  geo.bins_y = int((y1 - y0) / geo.bin_size) + 1;
  start.assign(size_t(geo.bins_x) * geo.bins_y + 1, 0);  // each bin's count, then its first entry
  int64_t entries = 0;
  for (const cl_float4& segment : walls.segments)
    for_each_bin_crossed(segment, geo, [&](size_t bin) {
      if (++entries > kMaxBinItems)
        fail(Code::ResourceExhausted, path + ": its walls cross more than " + std::to_string(kMaxBinItems) +
                                          " bins of " + number(geo.bin_size) +
                                          " du (the search radius / 2): fewer or shorter segments, or a smaller "
                                          "search_radius");
      ++start[bin + 1];
    });
  std::partial_sum(start.begin(), start.end(), start.begin());
  // The bins on the host and the device, for the bake's length.
  memory = gate.acquire_memory(path + "'s wall bins", 2 * sizeof(cl_int) * (uint64_t(entries) + start.size()));
  items.resize(size_t(entries));
  std::vector<cl_int> next(start.begin(), start.end() - 1);
  for (size_t k = 0; k < walls.segments.size(); ++k)
    for_each_bin_crossed(walls.segments[k], geo, [&](size_t bin) { items[size_t(next[bin]++)] = cl_int(k); });
}

// The walls and polygons of `river` on the host and the device: a segment (16 bytes and its boundary's 4)
// and a polygon point (8 bytes) per point at most, and two points a polygon for its box.
uint64_t walls_bytes(const RiverSpec& river) {
  uint64_t points = 0, polygons = river.obstacles.size();
  for (const RiverChannelSpec& c : river.channels) points += c.left.size() + c.right.size(), ++polygons;
  for (const RiverObstacleSpec& o : river.obstacles) points += o.outline.size();
  return 2 * ((16 + 4 + 8) * points + 2 * 8 * polygons);
}

Point2 vertex_centroid(const std::vector<Point2>& points) {
  Point2 c;
  for (const Point2& p : points) {
    c.x += p.x / double(points.size());
    c.y += p.y / double(points.size());
  }
  return c;
}

}  // namespace

RiverEngine::Geometry RiverEngine::upload(const RiverSpec& river, const std::string& path) {
  Geometry g;
  g.network = solve_network(river, path);
  double widest = 0;
  for (const RiverChannelSpec& c : river.channels) widest = std::max(widest, cross_section(c));
  const double s = river.search_radius.value_or(2 * widest);
  g.walls_memory = gate_.acquire_memory(path + "'s walls and polygons", walls_bytes(river));
  Walls walls;
  for (size_t c = 0; c < river.channels.size(); ++c) {
    add_polyline(walls, river.channels[c].left, g.network.boundary_of[2 * c], false);
    add_polyline(walls, river.channels[c].right, g.network.boundary_of[2 * c + 1], false);
    add_polygon(walls, channel_polygon(river.channels[c]));
  }
  const int banks = int(g.network.boundary_psi.size());
  for (double psi : g.network.boundary_psi) {
    g.boundary_psi.push_back(float(psi));
    g.boundary_s.push_back(float(s));
  }
  for (size_t o = 0; o < river.obstacles.size(); ++o) {
    add_polyline(walls, river.obstacles[o].outline, banks + int(o), true);
    add_polygon(walls, river.obstacles[o].outline);
    g.boundary_psi.push_back(0);  // set below, from the banks
    g.boundary_s.push_back(float(river.obstacles[o].search_radius.value_or(s)));
  }
  g.geo.segments = cl_int(walls.segments.size());
  g.geo.boundaries = cl_int(g.boundary_psi.size());
  g.geo.channel_polygons = cl_int(river.channels.size());
  g.geo.obstacle_polygons = cl_int(river.obstacles.size());
  g.geo.p = float(river.p);
  g.geo.s_max = *std::max_element(g.boundary_s.begin(), g.boundary_s.end());
  std::vector<cl_int> bin_items;
  bin_segments(walls, g.geo, g.bin_offsets, bin_items, gate_, g.bins_memory, path);
  g.polygon_boxes = polygon_boxes(walls);
  g.segments = squall::upload(runtime_, walls.segments);
  g.segment_boundary = squall::upload(runtime_, walls.boundary);
  g.bin_start = squall::upload(runtime_, g.bin_offsets);
  g.bin_items = squall::upload(runtime_, bin_items);
  g.s = squall::upload(runtime_, g.boundary_s);
  g.polygon_start = squall::upload(runtime_, walls.polygon_start);
  g.polygon_points = squall::upload(runtime_, walls.polygon_points);
  g.psi = squall::upload(runtime_, g.boundary_psi);
  if (river.obstacles.empty()) return g;
  // RIV09 sec. 4.3: an obstacle's psi is the banks' psi (eq. 1 without the obstacles) at its centre.
  std::vector<Point2> centres;
  for (const RiverObstacleSpec& o : river.obstacles) centres.push_back(vertex_centroid(o.outline));
  const std::vector<double> costs = point_costs(g.geo, g.bin_offsets, g.polygon_boxes, centres);
  gate_.check_bake_work(path + ": the pass over the obstacles' centres",
                        std::accumulate(costs.begin(), costs.end(), 0.0));
  const std::vector<RiverSample> at_centres = run_points(g, centres, banks);
  for (size_t o = 0; o < centres.size(); ++o) {
    if (at_centres[o].undefined)
      fail(Code::InvalidArgument,
           at(path + ".obstacles", o) + ": no bank lies within the search radius of its centre (grow search_radius)");
    g.obstacle_psi.push_back(at_centres[o].psi);
    g.boundary_psi[banks + o] = float(at_centres[o].psi);
  }
  g.psi = squall::upload(runtime_, g.boundary_psi);
  return g;
}

std::vector<RiverSample> RiverEngine::run_points(const Geometry& g, const std::vector<Point2>& points, int limit) {
  std::vector<cl_float2> xy;
  for (const Point2& p : points) xy.push_back({{float(p.x), float(p.y)}});
  std::vector<cl_float4> out(points.size());
  if (points.empty()) return {};
  const cl::Buffer in = squall::upload(runtime_, xy);
  cl::Buffer result(runtime_.context(), CL_MEM_WRITE_ONLY, out.size() * sizeof(cl_float4));
  {
    auto lock = runtime_.exclusive();
    points_.launch(cl::NDRange(round_up(points.size(), 64)), cl::NullRange, result, in, cl_int(points.size()), g.geo,
                   g.segments, g.segment_boundary, g.bin_start, g.bin_items, g.psi, g.s, g.polygon_start,
                   g.polygon_points, cl_int(limit));
    runtime_.queue().enqueueReadBuffer(result, CL_TRUE, 0, out.size() * sizeof(cl_float4), out.data());
  }
  std::vector<RiverSample> samples;
  for (const cl_float4& o : out) {
    const int flags = int(o.s[3]);
    samples.push_back(
        {o.s[0], o.s[1], o.s[2], (flags & SQUALL_RIVER_FLUID) != 0, (flags & SQUALL_RIVER_UNDEFINED) != 0});
  }
  return samples;
}

std::vector<RiverSample> RiverEngine::sample(const RiverSpec& river, const std::vector<Point2>& points,
                                             const std::string& path) {
  const Geometry g = upload(river, path);
  return run_points(g, points, g.geo.boundaries);
}

RiverBake RiverEngine::bake(const RiverSpec& river, const BakeGrid& grid, const std::string& path,
                            const Cancellation& cancel) {
  Geometry g = upload(river, path);
  const size_t nodes = size_t(grid.nx) * grid.ny;
  std::vector<cl_float4> out(nodes);
  cl::Buffer result(runtime_.context(), CL_MEM_WRITE_ONLY, nodes * sizeof(cl_float4));
  const float hx = float((grid.x1 - grid.x0) / (grid.nx - 1)), hy = float((grid.y1 - grid.y0) / (grid.ny - 1));
  // A node's cost grows with the walls and polygon points near it, up to millions: the bake runs in slices
  // of 8 x 8 tiles, each slice timed, so that a cancelled call stops within about one slice.
  const TileGrid tiles{round_up(grid.nx, 8) / 8, round_up(grid.ny, 8) / 8};
  const std::vector<double> costs = bake_tile_costs(g.geo, g.bin_offsets, g.polygon_boxes, grid, tiles);
  const double total = std::accumulate(costs.begin(), costs.end(), 0.0);
  gate_.check_bake_work(path + ": the bake of " + std::to_string(grid.nx) + " x " + std::to_string(grid.ny) + " nodes",
                        64 * total);  // a tile's cost is per node
  const double first = std::accumulate(costs.begin(), costs.begin() + std::min<size_t>(costs.size(), 4), 0.0);
  const WorkKind kind{"textures.river_bake", size_t(total)};
  const SlicePlan plan{costs.size(), 1, [&](size_t t) { return costs[t]; }, first, kind};
  QueueLease lease;
  run_sliced(runtime_, lease, plan, cancel, path + ": the bake", [&](size_t first, size_t count) {
    for (const auto& r : tiles.rectangles(first, count))
      bake_.launch_region(cl::NDRange(8 * r.x, 8 * r.y), cl::NDRange(8 * r.width, 8 * r.height), cl::NDRange(8, 8),
                          result, cl_int(grid.nx), cl_int(grid.ny), float(grid.x0), float(grid.y0), hx, hy, g.geo,
                          g.segments, g.segment_boundary, g.bin_start, g.bin_items, g.psi, g.s, g.polygon_start,
                          g.polygon_points);
  });
  runtime_.queue().enqueueReadBuffer(result, CL_TRUE, 0, nodes * sizeof(cl_float4), out.data());
  lease.unlock();
  RiverBake b;
  b.grid = grid;
  for (const cl_float4& o : out) {
    const int flags = int(o.s[3]);
    b.u.push_back(o.s[0]);
    b.v.push_back(o.s[1]);
    b.psi.push_back(o.s[2]);
    b.fluid.push_back(flags & SQUALL_RIVER_FLUID ? 1.0f : 0.0f);
    b.undefined += (flags & SQUALL_RIVER_FLUID) && (flags & SQUALL_RIVER_UNDEFINED);
  }
  b.network = std::move(g.network);
  b.obstacle_psi = std::move(g.obstacle_psi);
  return b;
}

VelocitySpec velocity_grid(const RiverBake& bake, const std::string& path) {
  float fastest = 0;
  for (const std::vector<float>* plane : {&bake.u, &bake.v})
    for (float c : *plane) fastest = std::max(fastest, std::isfinite(c) ? std::abs(c) : INFINITY);
  if (fastest > kMaxVelocityParam)
    fail(Code::InvalidArgument, path + " bakes speeds up to " + validate::number(fastest) + " du/s, past the " +
                                    validate::number(kMaxVelocityParam) +
                                    " an advection takes: a wider channel, a smaller flow_rate or a larger p");
  VelocitySpec v;
  v.kind = SQUALL_VELOCITY_GRID;
  v.nx = bake.grid.nx;
  v.ny = bake.grid.ny;
  v.origin_x = bake.grid.x0;
  v.origin_y = bake.grid.y0;
  v.hx = (bake.grid.x1 - bake.grid.x0) / (bake.grid.nx - 1);
  v.hy = (bake.grid.y1 - bake.grid.y0) / (bake.grid.ny - 1);
  v.frames.push_back({0.0, bake.u, bake.v});
  v.extrapolation = Extrapolation::PushPull;
  for (float f : bake.fluid) v.mask.push_back(f != 0);
  return v;
}

}  // namespace squall::textures
