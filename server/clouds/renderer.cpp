#include "clouds/renderer.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <numeric>
#include <utility>

#include "clouds/interior_tiles.h"
#include "clouds/nanovdb_volume.h"
#include "clouds/occupancy.h"
#include "clouds/render_params.h"
#include "common/error.h"
#include "common/validate.h"
#include "runtime/host_transfer.h"

namespace squall::clouds {
namespace {

// The first slice of a render holds about this many estimated density samples: a tenth of a second on a
// 2-core CPU device; the slices after it are sized by the rate it ran at.
constexpr double kFirstSliceSamples = 2e7;

Vec3d sub(const Vec3d& a, const Vec3d& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3d cross(const Vec3d& a, const Vec3d& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double norm(const Vec3d& a) { return std::hypot(a[0], a[1], a[2]); }  // neither underflows nor overflows
Vec3d unit(const Vec3d& a) {
  double n = norm(a);
  return {a[0] / n, a[1] / n, a[2] / n};
}
void put(float* dst, const Vec3d& v) {
  for (int i = 0; i < 3; ++i) dst[i] = float(v[i]);
}

// The step of the marches toward the lights: its own, or 3 primary steps (vdb_render's default of 3 voxels
// at a one-voxel step).
double shadow_step(const RenderSettings& s) { return s.shadow_step > 0 ? s.shadow_step : 3 * s.step; }

CloudRenderParams device_params(const RenderSettings& s) {
  CloudRenderParams p{};
  const Camera& c = s.camera;
  Vec3d forward = unit(sub(c.look_at, c.eye));
  Vec3d right = unit(cross(forward, c.up));
  Vec3d up = cross(right, forward);
  put(p.eye, c.eye);
  put(p.forward, forward);
  put(p.right, right);
  put(p.up, up);
  p.tan_half_fov_y = float(std::tan(c.vertical_fov_deg * M_PI / 360));
  p.width = c.width;
  p.height = c.height;
  p.step = float(s.step);
  p.substeps = s.substeps;
  p.interpolation = s.trilinear ? 1 : 0;
  p.seed = int(s.seed);
  p.min_transmittance = float(s.min_transmittance);
  p.phase = int(s.phase.kind);
  p.g1 = float(s.phase.g1);
  p.g2 = float(s.phase.g2);
  p.weight = float(s.phase.weight);
  p.ff_n = float(s.phase.ff_n);
  p.ff_mu = float(s.phase.ff_mu);
  p.n_wavelengths = int(s.wavelengths.size());
  for (size_t w = 0; w < s.wavelengths.size(); ++w) {
    p.wavelength[w] = float(s.wavelengths[w]);
    p.extinction[w] = float(s.extinction[w]);
    p.albedo[w] = float(s.albedo[w]);
  }
  p.n_lights = int(s.lights.size());
  for (size_t i = 0; i < s.lights.size(); ++i) {
    const Light& l = s.lights[i];
    p.lights[i].kind = int(l.kind);
    put(p.lights[i].position, l.position);
    put(p.lights[i].direction, unit(l.direction));
    for (size_t w = 0; w < l.intensity.size(); ++w) p.lights[i].intensity[w] = float(l.intensity[w]);
  }
  p.shadow = int(s.shadow);
  for (int a = 0; a < 3; ++a) p.dsm_n[a] = s.shadow_map_size[a];
  p.shadow_step = float(shadow_step(s));
  p.shadow_interpolation = s.shadow_trilinear ? 1 : 0;
  double kappa_min = INFINITY;
  for (double kappa : s.extinction)
    if (kappa > 0) kappa_min = std::min(kappa_min, kappa);
  const bool stops = s.min_transmittance > 0 && kappa_min < INFINITY;
  const double column_max = stops ? -std::log(s.min_transmittance) / kappa_min : INFINITY;
  p.shadow_column_max = column_max < FLT_MAX ? float(column_max) : FLT_MAX;
  return p;
}

// 1 for the deep-shadow-map nodes within one map cell of an occupied box, 0 elsewhere (never read).
std::vector<cl_uchar> shadow_map_mask(const DeviceVolume& volume, const CloudRenderParams& p) {
  const int n[3] = {p.dsm_n[0], p.dsm_n[1], p.dsm_n[2]};
  std::vector<cl_uchar> mask(size_t(n[0]) * n[1] * n[2], 0);
  double cell[3];
  for (int a = 0; a < 3; ++a) cell[a] = (p.dsm_max[a] - p.dsm_min[a]) / (n[a] - 1);
  for (const auto& b : volume.occupied) {
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::max(0, int(std::floor((b[a] - p.dsm_min[a]) / cell[a])) - 1);
      hi[a] = std::min(n[a] - 1, int(std::ceil((b[a + 3] - p.dsm_min[a]) / cell[a])) + 1);
    }
    for (int k = lo[2]; k <= hi[2]; ++k)
      for (int j = lo[1]; j <= hi[1]; ++j)
        for (int i = lo[0]; i <= hi[0]; ++i) mask[(size_t(k) * n[1] + j) * n[0] + i] = 1;
  }
  return mask;
}

// Steps of a march of `length` (m) in steps of `step`, each also cut at the faces of the tree's nodes: the
// steps in a node are at most its chord over `step`, plus one. A segment crosses at most sqrt(3) length /
// side + 4 cells of a grid of cubes of that side (one, plus a plane crossing per side along each axis),
// and the smallest nodes, the leaves, are 8 voxels a side.
double march_steps(double length, double step, double voxel_size) {
  return std::ceil(length / step + std::sqrt(3.0) * length / (8 * voxel_size)) + 4;
}

// Density samples taken per primary sample: the sample itself and, with direct shadows, a march toward
// each light across at most the box diagonal; with a deep shadow map, one lookup per light.
double samples_per_primary_sample(const RenderSettings& s, double diagonal, double voxel_size) {
  const double lights = double(s.lights.size());
  if (s.shadow == ShadowMode::Direct) return 1 + lights * march_steps(diagonal, shadow_step(s), voxel_size);
  if (s.shadow == ShadowMode::DeepShadowMap) return 1 + lights;
  return 1;
}

// Density samples (or map lookups) a ray takes of its point lights beyond one a sub-step (render.cl's
// sq_point_light_inscatter): per light, strata of pi / SQUALL_CLOUD_POINT_LIGHT_STRATA in max(b, r) G, whose
// sum along a ray (b the light's distance from it, G the integral of its capped inverse square) is at most pi
// where b >= r and at most 4 where b < r; with direct shadows each a march toward the light.
double point_light_samples(const RenderSettings& s, double diagonal, double voxel_size) {
  const auto points =
      std::count_if(s.lights.begin(), s.lights.end(), [](const Light& l) { return l.kind == LightKind::Point; });
  const double per_sample = s.shadow == ShadowMode::Direct ? march_steps(diagonal, shadow_step(s), voxel_size) : 1;
  return double(points) * std::ceil(4 * SQUALL_CLOUD_POINT_LIGHT_STRATA / M_PI) * per_sample;
}

// The direction of the primary ray through image point (u, v), in pixels from the top-left corner: the
// camera of cloud_render.
Vec3d camera_ray(const CloudRenderParams& p, double u, double v) {
  const double aspect = double(p.width) / p.height;
  const double sx = (2 * u / p.width - 1) * p.tan_half_fov_y * aspect, sy = (1 - 2 * v / p.height) * p.tan_half_fov_y;
  Vec3d d;
  for (int a = 0; a < 3; ++a) d[a] = p.forward[a] + sx * p.right[a] + sy * p.up[a];
  return unit(d);
}

// Each 8x8 tile's estimated density samples, in row order: the length of its rays inside density (the
// mean over the corners and centre of its block, from the coarse occupancy; empty space is skipped by
// the march) in steps, times the samples per step, plus one per pixel for the ray itself and, where the ray
// meets density, its point lights' samples (point_light_samples). A block is one tile, or several a side in
// images of over kBlocks tiles a side (an 8192^2 image would otherwise trace 2 M rays on the host). They size
// the render's slices (the first at kFirstSliceSamples) and, summed, its place in the device's line.
std::vector<double> tile_costs(const DeviceVolume& volume, const RenderSettings& s, const CloudRenderParams& p,
                               const TileGrid& tiles) {
  constexpr size_t kBlocks = 256;
  const size_t block = (std::max(tiles.x, tiles.y) + kBlocks - 1) / kBlocks, side = 8 * block;  // tiles, pixels
  const size_t bx = (tiles.x + block - 1) / block, by = (tiles.y + block - 1) / block;
  const double diagonal = norm(sub(volume.world_max, volume.world_min));
  const double per_metre = s.substeps / s.step * samples_per_primary_sample(s, diagonal, volume.voxel_size);
  const double per_lit_ray = point_light_samples(s, diagonal, volume.voxel_size);
  auto length = [&](size_t u, size_t v) {
    return volume.coarse.marked_length(
        s.camera.eye, camera_ray(p, double(std::min<size_t>(u, p.width)), double(std::min<size_t>(v, p.height))));
  };
  std::vector<double> corners((bx + 1) * (by + 1));
  for (size_t j = 0; j <= by; ++j)
    for (size_t i = 0; i <= bx; ++i) corners[j * (bx + 1) + i] = length(side * i, side * j);
  std::vector<double> block_cost(bx * by);
  for (size_t bj = 0; bj < by; ++bj)
    for (size_t bi = 0; bi < bx; ++bi) {
      const size_t c = bj * (bx + 1) + bi;
      const double mean = (corners[c] + corners[c + 1] + corners[c + bx + 1] + corners[c + bx + 2] +
                           length(side * bi + side / 2, side * bj + side / 2)) /
                          5;
      block_cost[bj * bx + bi] = 64 * (1 + mean * per_metre + (mean > 0 ? per_lit_ray : 0));
    }
  std::vector<double> costs(tiles.x * tiles.y);
  for (size_t j = 0; j < tiles.y; ++j)
    for (size_t i = 0; i < tiles.x; ++i) costs[j * tiles.x + i] = block_cost[(j / block) * bx + i / block];
  return costs;
}

// The kernels work in float32: a point or direction of the scene has components within +-kMaxWorld (m).
constexpr double kMaxWorld = 1e7;

// A march's step (m): a normal float32 (a subnormal one is 0 or imprecise on the device, and makes an empty
// volume's cost estimates 0 / 0), and no longer than ten times the world is wide.
const validate::Interval kStepRange = validate::closed(FLT_MIN, 10 * kMaxWorld);

void world_xyz(const std::string& path, const Vec3d& v) {
  validate::in_xyz(path, v, validate::closed(-kMaxWorld, kMaxWorld));
}

}  // namespace

void validate(const RenderSettings& s, const std::string& f) {
  const Camera& c = s.camera;
  world_xyz(f + ".camera.eye", c.eye);
  world_xyz(f + ".camera.look_at", c.look_at);
  world_xyz(f + ".camera.up", c.up);
  Vec3d view = sub(c.look_at, c.eye);
  if (!(norm(view) > 0)) fail(Code::InvalidArgument, f + ".camera.look_at equals " + f + ".camera.eye");
  if (!(norm(cross(unit(view), c.up)) > 1e-6))
    fail(Code::InvalidArgument, f + ".camera.up is zero or parallel to the view direction");
  validate::in(f + ".camera.vertical_fov_deg", c.vertical_fov_deg, validate::open(0, 170));
  validate::in(f + ".camera.width", c.width, 1, 8192);
  validate::in(f + ".camera.height", c.height, 1, 8192);
  validate::in(f + ".step", s.step, kStepRange);
  validate::in(f + ".substeps", s.substeps, 1, SQUALL_CLOUD_MAX_SUBSTEPS);
  validate::in(f + ".min_transmittance", s.min_transmittance, validate::closed_open(0, 1));
  if (s.shadow_step != 0) validate::in(f + ".shadow_step", s.shadow_step, kStepRange);  // 0: three steps
  const Phase& ph = s.phase;
  // |g| and n - 1 at least 1e-4 from their poles in float32 (g = 0.99999999 is 1.0f: 0/0 at mu = 1)
  validate::in(f + ".phase.g1", ph.g1, validate::closed(-0.9999, 0.9999));
  validate::in(f + ".phase.g2", ph.g2, validate::closed(-0.9999, 0.9999));
  validate::in(f + ".phase.weight", ph.weight, validate::closed(0, 1));
  validate::in(f + ".phase.ff_n", ph.ff_n, validate::closed(1.0001, 2));
  validate::in(f + ".phase.ff_mu", ph.ff_mu, validate::closed(3.5, 5));  // the Junge slope
  size_t nw = s.wavelengths.size();
  if (nw < 1 || nw > SQUALL_CLOUD_MAX_WAVELENGTHS)
    fail(Code::InvalidArgument, f + ".wavelengths has " + std::to_string(nw) + " entries: must be 1 to " +
                                    std::to_string(SQUALL_CLOUD_MAX_WAVELENGTHS));
  if (s.extinction.size() != nw || s.albedo.size() != nw)
    fail(Code::InvalidArgument,
         f + ".extinction and " + f + ".albedo need one entry per wavelength (" + std::to_string(nw) + ")");
  for (size_t w = 0; w < nw; ++w) {
    validate::in(validate::at(f + ".wavelengths", w), s.wavelengths[w], validate::closed(1e-8, 1e-3));  // m
    validate::non_negative(validate::at(f + ".extinction", w), s.extinction[w], 1e6);                   // 1/m
    validate::in(validate::at(f + ".albedo", w), s.albedo[w], validate::closed(0, 1));
  }
  if (s.lights.size() > SQUALL_CLOUD_MAX_LIGHTS)
    fail(Code::InvalidArgument, f + ".lights has " + std::to_string(s.lights.size()) + " entries: at most " +
                                    std::to_string(SQUALL_CLOUD_MAX_LIGHTS));
  for (size_t i = 0; i < s.lights.size(); ++i) {
    std::string l = validate::at(f + ".lights", i);
    world_xyz(l + ".position", s.lights[i].position);
    world_xyz(l + ".direction", s.lights[i].direction);
    if (s.lights[i].kind == LightKind::Directional && !(norm(s.lights[i].direction) > 0))
      fail(Code::InvalidArgument, l + ".direction must not be zero");
    if (s.lights[i].intensity.size() != nw)
      fail(Code::InvalidArgument, l + ".intensity needs one entry per wavelength (" + std::to_string(nw) + ")");
    for (size_t w = 0; w < nw; ++w)
      validate::non_negative(validate::at(l + ".intensity", w), s.lights[i].intensity[w], 1e20);
  }
  for (size_t a = 0; a < 3; ++a) validate::in(validate::at(f + ".shadow_map_size", a), s.shadow_map_size[a], 2, 512);
}

NanoGrids to_nanovdb(const CloudVolume& volume) {
  NanoGrids grids;
  grids.density = to_nanovdb(*volume.density);
  grids.interior = interior_tiles(*grids.density.grid<float>());
  if (volume.temperature) grids.temperature = to_nanovdb(*volume.temperature);
  return grids;
}

DeviceVolume upload_volume(Runtime& runtime, const CloudVolume& volume, const NanoGrids& grids) {
  DeviceVolume d;
  {
    auto lock = runtime.exclusive();  // a queue of its own, not one another request holds
    d.density = upload_nanovdb(runtime, grids.density);
    d.temperature = volume.temperature ? upload_nanovdb(runtime, grids.temperature) : d.density;
    d.interior = upload_words(runtime, grids.interior);
  }
  d.has_temperature = bool(volume.temperature);
  d.device_bytes = grids.bytes();
  const auto& b = volume.stats.bounds;
  const double dx = volume.density->voxelSize()[0];
  d.voxel_size = dx;
  auto box = [&](const openvdb::CoordBBox& c) {  // grown by a voxel: trilinear density spills that far
    d.occupied.push_back({(c.min().x() - 1.5) * dx, (c.min().y() - 1.5) * dx, (c.min().z() - 1.5) * dx,
                          (c.max().x() + 1.5) * dx, (c.max().y() + 1.5) * dx, (c.max().z() + 1.5) * dx});
  };
  for (auto leaf = volume.density->tree().cbeginLeaf(); leaf; ++leaf) box(leaf->getNodeBoundingBox());
  for (auto it = volume.density->tree().cbeginValueOn(); it; ++it)
    if (!it.isVoxelValue()) box(it.getBoundingBox());
  if (!b.empty())  // an empty tree's box runs from INT_MAX to INT_MIN; its volume is the point at the origin
    for (int a = 0; a < 3; ++a) {
      d.world_min[a] = (b.min()[a] - 0.5) * dx;
      d.world_max[a] = (b.max()[a] + 0.5) * dx;
    }
  d.coarse = CoarseOccupancy::of(d.world_min, d.world_max, d.occupied);
  return d;
}

namespace {
Limits kept_maps_limits(size_t max_bytes) {
  Limits l;
  l.memory_budget = max_bytes;
  return l;
}
}  // namespace

CloudRenderer::CloudRenderer(Runtime& runtime, LimitGate* gate, size_t max_kept_maps_bytes)
    : runtime_(runtime),
      gate_(gate),
      kept_maps_(kept_maps_limits(max_kept_maps_bytes)),
      shadow_map_(runtime, "clouds/render.cl", "cloud_shadow_map"),
      shadow_map_shared_(runtime, "clouds/render.cl", "cloud_shadow_map_shared"),
      render_(runtime, "clouds/render.cl", "cloud_render"),
      render_shared_(runtime, "clouds/render.cl", "cloud_render_shared") {
  if (gate_) gate_->add_reclaimer(this);
}

CloudRenderer::~CloudRenderer() {
  if (gate_) gate_->remove_reclaimer(this);
}

SampleEstimate estimate_samples(const DeviceVolume& volume, const RenderSettings& s) {
  const double diagonal = norm(sub(volume.world_max, volume.world_min)), lights = double(s.lights.size());
  const double steps = march_steps(diagonal, s.step, volume.voxel_size);
  SampleEstimate e;
  e.per_pixel = steps * s.substeps * samples_per_primary_sample(s, diagonal, volume.voxel_size) +
                point_light_samples(s, diagonal, volume.voxel_size);
  if (s.shadow == ShadowMode::DeepShadowMap && lights > 0) {  // no light, no map
    e.per_map_node = march_steps(diagonal, shadow_step(s), volume.voxel_size);
    e.map_nodes = double(s.shadow_map_size[0]) * s.shadow_map_size[1] * s.shadow_map_size[2] * lights;
  }
  e.total = e.per_pixel * s.camera.width * s.camera.height + e.per_map_node * e.map_nodes;
  return e;
}

void check_march_resolution(const DeviceVolume& volume, const RenderSettings& s, const std::string& prefix) {
  const double across = norm(sub(volume.world_max, volume.world_min));
  auto check = [&](const char* field, double step, const char* march) {
    const double least = kMinStepOfDistance * across;
    if (step < least)
      fail(Code::InvalidArgument, prefix + field + " = " + validate::number(step) +
                                      " is below the float resolution of a march across the volume" + march + " (" +
                                      validate::number(across) + " m): it must be at least " + validate::number(least));
  };
  check(".step", s.step, "");
  const bool shadows = s.shadow != ShadowMode::None && !s.lights.empty();
  if (shadows) check(s.shadow_step > 0 ? ".shadow_step" : ".step", shadow_step(s), " toward a light");
}

uint64_t shadow_map_bytes(const RenderSettings& s) {
  if (s.shadow != ShadowMode::DeepShadowMap || s.lights.empty()) return 0;
  const uint64_t nodes =
      uint64_t(s.shadow_map_size[0]) * uint64_t(s.shadow_map_size[1]) * uint64_t(s.shadow_map_size[2]);
  return nodes * s.lights.size() * sizeof(float) + 2 * nodes;
}

namespace {

// The parameters a deep shadow map depends on: all of a render's but the camera's.
CloudRenderParams without_camera(CloudRenderParams p) {
  std::fill(p.eye, p.eye + 3, 0.0f), std::fill(p.forward, p.forward + 3, 0.0f);
  std::fill(p.right, p.right + 3, 0.0f), std::fill(p.up, p.up + 3, 0.0f);
  p.tan_half_fov_y = 0, p.width = p.height = 0;
  return p;
}

// CloudRenderParams holds 4-byte fields only (render_params.h): no padding, so bytes compare as values.
bool same_params(const CloudRenderParams& a, const CloudRenderParams& b) { return !std::memcmp(&a, &b, sizeof a); }

}  // namespace

// The map of a render, with what must outlive the render's commands: the mask its nodes read, and the
// pool's buffer when the map is not kept.
struct CloudRenderer::ShadowMap {
  Slot memory;                        // its bytes in the budget while made and read (first: released last)
  std::shared_ptr<Slot> kept_memory;  // a kept map's bytes in the budget, while this render reads it
  cl::Buffer buffer;
  BufferLease pooled;
  std::vector<cl_uchar> needed;
  BufferLease mask;
  bool to_keep = false;  // made now, to be kept once the render has waited for its queue
  CloudRenderParams made_with{};
};

Image CloudRenderer::render(const DeviceVolume& volume, const RenderSettings& settings, const std::string& field,
                            const Cancellation& cancel, const Slot* map_memory) {
  validate(settings, field);
  CloudRenderParams p = device_params(settings);
  p.has_temperature = volume.has_temperature ? 1 : 0;
  put(p.dsm_min, volume.world_min);
  put(p.dsm_max, volume.world_max);
  p.point_light_radius = float(0.5 * volume.voxel_size);
  const int nw = p.n_wavelengths;
  Image image;
  image.width = p.width;
  image.height = p.height;
  for (int w = 0; w < nw; ++w) image.channels.push_back("radiance_" + std::to_string(w));
  for (int w = 0; w < nw; ++w) image.channels.push_back("transmittance_" + std::to_string(w));
  image.channels.push_back("depth");
  const size_t pixels = size_t(p.width) * p.height;
  image.data.resize(pixels * image.channels.size());

  auto out = runtime_.buffers().acquire(image.data.size() * sizeof(float));
  // Slices of 8x8 tiles in row order (a slice is up to three rectangles: a row's end, whole rows, a row's
  // start), so that even a costly pixel's tile can be a slice of its own.
  const TileGrid tiles{round_up(size_t(p.width), 8) / 8, round_up(size_t(p.height), 8) / 8};
  const std::vector<double> costs = tile_costs(volume, settings, p, tiles);
  ShadowMap map;     // before the lease: its mask's host bytes outlive the lease's wait for the queue
  QueueLease lease;  // one device queue from the first slice to the read-back, but for long renders
  make_shadow_map(map, volume, settings, p, lease, cancel, field, map_memory);
  // Renders of about the same estimated number of samples take about as long: a small one goes ahead of
  // much larger work waiting for a queue.
  const WorkKind kind{"clouds.render", size_t(std::accumulate(costs.begin(), costs.end(), 0.0))};
  SlicePlan plan{costs.size(), 1, [&](size_t t) { return costs[t]; }, kFirstSliceSamples, kind};
  run_sliced(runtime_, lease, plan, cancel, field + ": the render", [&](size_t first, size_t count) {
    launch_tiles(volume, map.buffer, p, out.buffer(), tiles, first, count);
  });
  read_back(runtime_, out.buffer(), image.data.size() * sizeof(float), image.data.data());
  if (map.to_keep) keep(volume, map);
  return image;
}

bool CloudRenderer::shares_work() const {
  const WorkSchedule schedule = schedule_;
  return schedule == WorkSchedule::Auto ? runtime_.device_info().type == "cpu"
                                        : schedule == WorkSchedule::SharedCounter;
}

cl::NDRange CloudRenderer::sharing_items() const {
  return cl::NDRange(std::max(1u, runtime_.device_info().compute_units));
}

BufferLease CloudRenderer::shared_counter() {
  BufferLease next = runtime_.buffers().acquire(sizeof(cl_uint));
  runtime_.queue().enqueueFillBuffer(next.buffer(), cl_uint(0), 0, sizeof(cl_uint));
  return next;
}

void CloudRenderer::launch_tiles(const DeviceVolume& volume, const cl::Buffer& map, const CloudRenderParams& p,
                                 const cl::Buffer& out, const TileGrid& tiles, size_t first, size_t count) {
  if (!shares_work()) {
    for (const auto& r : tiles.rectangles(first, count))
      render_.launch_region(cl::NDRange(8 * r.x, 8 * r.y), cl::NDRange(8 * r.width, 8 * r.height), cl::NDRange(8, 8),
                            volume.density, volume.interior, volume.temperature, map, p, out);
    return;
  }
  const BufferLease next = shared_counter();
  render_shared_.launch(sharing_items(), cl::NDRange(1), volume.density, volume.interior, volume.temperature, map, p,
                        out, cl_uint(first), cl_uint(count), cl_uint(tiles.x), next.buffer());
}

void CloudRenderer::launch_map_entries(const DeviceVolume& volume, const CloudRenderParams& p, const cl::Buffer& needed,
                                       const cl::Buffer& map, size_t first, size_t count) {
  if (!shares_work()) {
    shadow_map_.launch_region(cl::NDRange(first), cl::NDRange(count), cl::NDRange(64), volume.density, volume.interior,
                              p, needed, map);
    return;
  }
  const BufferLease next = shared_counter();
  shadow_map_shared_.launch(sharing_items(), cl::NDRange(1), volume.density, volume.interior, p, needed, map,
                            cl_uint(first), cl_uint(count), next.buffer());
}

void CloudRenderer::make_shadow_map(ShadowMap& map, const DeviceVolume& volume, const RenderSettings& settings,
                                    const CloudRenderParams& p, QueueLease& lease, const Cancellation& cancel,
                                    const std::string& field, const Slot* map_memory) {
  if (settings.shadow != ShadowMode::DeepShadowMap || p.n_lights == 0) {
    map.pooled = runtime_.buffers().acquire(sizeof(float));
    map.buffer = map.pooled.buffer();
    return;
  }
  map.made_with = without_camera(p);
  const size_t dsm_floats = size_t(p.dsm_n[0]) * p.dsm_n[1] * p.dsm_n[2] * p.n_lights;
  KeptShadowMap* kept = volume.kept_shadow_map.get();
  if (kept) {
    std::lock_guard<std::mutex> guard(kept->mutex);
    if (kept->map() && same_params(kept->made_with, map.made_with)) {
      map.buffer = kept->map;
      map.kept_memory = kept->memory;
      kept->used = ++uses_;
      return;
    }
  }
  // A map made now holds its bytes (and its mask's) in the budget from here, unless the caller holds them;
  // a kept one takes them over. Taken with no map's lock held: where the budget has no room, kept maps give
  // theirs back (reclaim()).
  const uint64_t map_bytes = shadow_map_bytes(settings);
  if (gate_ && !(map_memory && map_memory->amount() >= map_bytes))
    map.memory = gate_->acquire_memory("Render's deep shadow map", map_bytes);
  if (kept) {
    std::lock_guard<std::mutex> guard(kept->mutex);
    ++kept->made;
    map.to_keep = may_keep(*kept, dsm_floats * sizeof(float));
  }
  if (map.to_keep) {
    map.buffer = cl::Buffer(runtime_.context(), CL_MEM_READ_WRITE, dsm_floats * sizeof(float));  // not the pool's
  } else {
    map.pooled = runtime_.buffers().acquire(dsm_floats * sizeof(float));
    map.buffer = map.pooled.buffer();
  }
  map.needed = shadow_map_mask(volume, p);
  map.mask = runtime_.buffers().acquire(map.needed.size());
  // A deep shadow map is a kind of work of its own, by its map's size.
  const WorkKind map_kind{"clouds.shadow_map", dsm_floats};
  lease = runtime_.exclusive(map_kind);
  runtime_.queue().enqueueWriteBuffer(map.mask.buffer(), CL_FALSE, 0, map.needed.size(), map.needed.data());
  // A needed node marches toward its light; a skipped one reads its mask byte and writes 1, priced at a
  // tenth of a density sample: priced higher, a run of skipped nodes would promise a rate the needed
  // nodes after them do not reach, and their slice would overrun.
  constexpr double kSkippedNodeSamples = 0.1;
  const double per_node = estimate_samples(volume, settings).per_map_node;
  auto node_cost = [&](size_t g) {
    double c = 0;
    for (size_t id = 64 * g; id < std::min(64 * (g + 1), dsm_floats); ++id)
      c += map.needed[id % map.needed.size()] ? per_node : kSkippedNodeSamples;
    return std::max(c, 1.0);
  };
  const SlicePlan nodes{round_up(dsm_floats, 64) / 64, 64, node_cost, kFirstSliceSamples, map_kind};
  run_sliced(runtime_, lease, nodes, cancel, field + ": the deep shadow map", [&](size_t first, size_t count) {
    launch_map_entries(volume, p, map.mask.buffer(), map.buffer, first, count);
  });
  // Its last slice is not waited for: the render's first slice, timed with it, may size the second
  // smaller than it could be (by at most 4x, once). A render of one slice waits once in all.
}

// Whether a map of `bytes` could replace the volume's kept one: at most kMaxKeptShadowMapBytes, with room
// in the kept maps' share once the kept one's bytes go back (in the memory budget the map's own bytes are
// held already). A map that could not is made in the pool's buffers, as a volume that keeps none makes its
// maps.
bool CloudRenderer::may_keep(const KeptShadowMap& kept, size_t bytes) const {
  const size_t held = kept.map() ? kept.map.getInfo<CL_MEM_SIZE>() : 0;
  return bytes <= kMaxKeptShadowMapBytes && kept_maps_.memory_room(bytes, held);
}

void CloudRenderer::keep(const DeviceVolume& volume, ShadowMap& map) {
  const size_t bytes = map.buffer.getInfo<CL_MEM_SIZE>();
  KeptShadowMap& kept = *volume.kept_shadow_map;
  std::lock_guard<std::mutex> guard(kept.mutex);
  kept.map = cl::Buffer();  // the map it replaces gives its budgets back first
  kept.memory.reset(), kept.share = Slot();
  try {
    Slot share = kept_maps_.acquire_memory("the deep shadow maps kept", bytes);
    Slot memory = gate_ ? gate_->cache_from(map.memory, bytes) : Slot();  // the map's bytes, now cached memory
    if (gate_ && !memory.amount())  // the caller's memory held them: not taken from it
      memory = gate_->acquire_cache_memory("a deep shadow map kept for the volume's next render", bytes);
    kept.memory = std::make_shared<Slot>(std::move(memory));
    kept.share = std::move(share);
  } catch (const Error&) {
    return;  // past a budget: the next render makes its own
  }
  kept.made_with = map.made_with;
  kept.map = map.buffer;
  kept.used = ++uses_;
  if (std::exchange(kept.listed, true)) return;
  std::lock_guard<std::mutex> list(kept_mutex_);
  std::erase_if(kept_, [](const std::weak_ptr<KeptShadowMap>& m) { return m.expired(); });
  kept_.push_back(volume.kept_shadow_map);
}

std::vector<std::shared_ptr<KeptShadowMap>> CloudRenderer::kept_maps() {
  std::vector<std::pair<uint64_t, std::shared_ptr<KeptShadowMap>>> by_use;  // `used` read once: renders move it
  {
    std::lock_guard<std::mutex> list(kept_mutex_);
    for (const auto& m : kept_)
      if (auto held = m.lock()) by_use.emplace_back(held->used.load(), std::move(held));
  }
  std::sort(by_use.begin(), by_use.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<std::shared_ptr<KeptShadowMap>> maps;
  for (auto& [used, map] : by_use) maps.push_back(std::move(map));
  return maps;
}

uint64_t CloudRenderer::reclaim(uint64_t bytes) {
  uint64_t freed = 0;
  for (const auto& kept : kept_maps()) {
    if (freed >= bytes) break;
    std::lock_guard<std::mutex> guard(kept->mutex);
    // A map a render is reading gives nothing back until that render is done: left kept.
    if (!kept->map() || kept->memory.use_count() > 1) continue;
    freed += kept->map.getInfo<CL_MEM_SIZE>();
    kept->map = cl::Buffer();
    kept->memory.reset(), kept->share = Slot();
  }
  return 0;  // given back at once
}

}  // namespace squall::clouds
