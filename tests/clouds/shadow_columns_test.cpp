// Shadow rays' column densities through the tree's tiles and leaves, read from a deep shadow map's nodes,
// against exact line integrals of the same fields: nearest-voxel density (a sum of value x length over the
// 8^3 blocks a line crosses) and trilinear density (a cubic between the planes of voxel centres a line
// crosses, integrated exactly by two Gauss-Legendre points a piece). And the tiles a trilinear march takes
// as one value throughout (interior_tiles) against their definition, read through OpenVDB.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <vector>

#include "clouds/interior_tiles.h"
#include "clouds/nanovdb_volume.h"
#include "clouds/renderer.h"
#include "clouds/volume.h"
#include "support/test_runtime.h"
#include "support/worst.h"
#include <openvdb/tools/Interpolation.h>

namespace squall::clouds {
namespace {

constexpr double kDx = 0.5;  // m, the test volumes' voxel

// A grid of voxel kDx, empty.
CloudVolume empty_volume() {
  initialize_openvdb();
  CloudVolume v;
  v.density = openvdb::FloatGrid::create(0.0f);
  v.density->setTransform(openvdb::math::Transform::createLinearTransform(kDx));
  v.density->setName("density");
  return v;
}

// Numerical Recipes' LCG: the test volumes' choices.
uint32_t next(uint32_t& h) { return h = h * 1664525u + 1013904223u; }

// Sets the 8^3 voxels from lo active, each value(i, j, k): a leaf.
void set_leaf(openvdb::FloatTree& tree, const openvdb::Coord& lo, const std::function<float(int, int, int)>& value) {
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 8; ++j)
      for (int k = 0; k < 8; ++k) tree.setValueOn(lo.offsetBy(i, j, k), value(i, j, k));
}

// Blocks of 8^3 voxels of one value each in [-96, 96)^3, most active tiles of the lower nodes, some leaves
// of one value, some empty, an upper node's tile over [0, 128)^3 and three layers of blocks of its value
// beside it: a field whose nearest-voxel column along any line is a sum of value x length over the blocks
// it crosses.
CloudVolume blocks() {
  CloudVolume v = empty_volume();
  auto& tree = v.density->tree();
  uint32_t h = 12345;
  for (int bx = -12; bx < 12; ++bx)
    for (int by = -12; by < 12; ++by)
      for (int bz = -12; bz < 12; ++bz) {
        const int kind = int(next(h) >> 28) % 5;  // 0: empty, 1: a leaf, else a tile
        const float value = 0.2f + float((h >> 8) & 0xffff) / 65536.0f * 1.8f;
        const openvdb::Coord lo(8 * bx, 8 * by, 8 * bz);
        if (kind == 1) set_leaf(tree, lo, [&](int, int, int) { return value; });
        if (kind >= 2) tree.fill(openvdb::CoordBBox(lo, lo.offsetBy(7)), value, true);
      }
  tree.fill(openvdb::CoordBBox(openvdb::Coord(0), openvdb::Coord(127)), 0.7f, true);
  // Lower nodes' tiles of the upper tile's value beside it: tiles inside uniform density across levels.
  tree.fill(openvdb::CoordBBox(openvdb::Coord(-24, 0, 0), openvdb::Coord(-1, 127, 127)), 0.7f, true);
  v.stats = volume_stats(*v.density);
  return v;
}

// A block of density 1 over [-96, 96)^3 (lower nodes' tiles) dotted, one 8^3 block in about 21, with
// leaves whose voxels vary, tiles of other values and holes: tiles inside uniform density, and tiles
// whose trilinear density meets their neighbours' over a half-voxel shell.
CloudVolume dotted_block() {
  CloudVolume v = empty_volume();
  auto& tree = v.density->tree();
  tree.fill(openvdb::CoordBBox(openvdb::Coord(-96), openvdb::Coord(95)), 1.0f, true);
  uint32_t h = 4321;
  for (int bx = -12; bx < 12; ++bx)
    for (int by = -12; by < 12; ++by)
      for (int bz = -12; bz < 12; ++bz) {
        const int kind = int(next(h) >> 26);  // 0: a leaf, 1: a tile of another value, 2: a hole, else as is
        const openvdb::Coord lo(8 * bx, 8 * by, 8 * bz);
        const openvdb::CoordBBox block(lo, lo.offsetBy(7));
        if (kind == 0)
          set_leaf(tree, lo, [&](int, int, int) { return 0.2f + float(next(h) >> 8) / 16777216.0f * 1.8f; });
        if (kind == 1) tree.fill(block, 0.2f + float((h >> 8) & 0xffff) / 65536.0f * 1.8f, true);
        if (kind == 2) tree.fill(block, 0.0f, false);
      }
  v.stats = volume_stats(*v.density);
  return v;
}

// The ray parameters (m) in (0, end) where the line from index-space point p0 (direction dp a metre) crosses
// the planes offset + k spacing of each axis, with 0 and end, sorted.
std::vector<double> line_cuts(const Vec3d& p0, const Vec3d& dp, double end, double offset, double spacing) {
  std::vector<double> cuts{0, end};
  for (int a = 0; a < 3; ++a) {
    if (dp[a] == 0) continue;
    const double first = std::ceil((std::min(p0[a], p0[a] + end * dp[a]) - offset) / spacing);
    for (double k = first; offset + k * spacing <= std::max(p0[a], p0[a] + end * dp[a]); ++k)
      if (const double t = (offset + k * spacing - p0[a]) / dp[a]; t > 0 && t < end) cuts.push_back(t);
  }
  std::sort(cuts.begin(), cuts.end());
  return cuts;
}

// Where the line from index-space point p0 (direction dp a metre) leaves the cell-space box [lo, hi)^3.
double line_end(const Vec3d& p0, const Vec3d& dp, double lo, double hi) {
  double end = 1e300;
  for (int a = 0; a < 3; ++a)
    if (dp[a] != 0) end = std::min(end, ((dp[a] > 0 ? hi : lo) - 0.5 - p0[a]) / dp[a]);
  return end;
}

// The nearest-voxel column (m) of `grid` from world point x along unit direction u to the box's end: the
// field is constant between the blocks' faces (cell-space planes at multiples of 8).
double exact_column(const openvdb::FloatGrid& grid, const Vec3d& x, const Vec3d& u, double box_lo, double box_hi) {
  const Vec3d p0{x[0] / kDx, x[1] / kDx, x[2] / kDx}, dp{u[0] / kDx, u[1] / kDx, u[2] / kDx};
  const std::vector<double> cuts = line_cuts(p0, dp, line_end(p0, dp, box_lo, box_hi), -0.5, 8);
  auto acc = grid.getConstAccessor();
  double column = 0;
  for (size_t i = 0; i + 1 < cuts.size(); ++i) {
    const double mid = (cuts[i] + cuts[i + 1]) / 2;
    const openvdb::Coord ijk(int(std::floor(p0[0] + mid * dp[0] + 0.5)), int(std::floor(p0[1] + mid * dp[1] + 0.5)),
                             int(std::floor(p0[2] + mid * dp[2] + 0.5)));
    column += acc.getValue(ijk) * (cuts[i + 1] - cuts[i]);
  }
  return column;
}

// The trilinear column (m), where the marches take density: not in empty tiles, which they skip with the
// density trilinear interpolation spills into them. Between the planes of voxel centres and of the
// tiles' faces that the line crosses, that density along it is a cubic in t (or 0), which two
// Gauss-Legendre points integrate exactly.
double exact_trilinear_column(const openvdb::FloatGrid& grid, const Vec3d& x, const Vec3d& u, double box_lo,
                              double box_hi) {
  const Vec3d p0{x[0] / kDx, x[1] / kDx, x[2] / kDx}, dp{u[0] / kDx, u[1] / kDx, u[2] / kDx};
  const double end = line_end(p0, dp, box_lo, box_hi);
  std::vector<double> cuts = line_cuts(p0, dp, end, 0, 1), faces = line_cuts(p0, dp, end, -0.5, 8);
  cuts.insert(cuts.end(), faces.begin(), faces.end());
  std::sort(cuts.begin(), cuts.end());
  auto acc = grid.getConstAccessor();
  auto density = [&](double t) {
    const openvdb::Vec3d p(p0[0] + t * dp[0], p0[1] + t * dp[1], p0[2] + t * dp[2]);
    const openvdb::Coord voxel = openvdb::Coord::floor(p + openvdb::Vec3d(0.5));
    if (!acc.probeConstLeaf(voxel) && acc.getValue(voxel) == 0) return 0.0;  // an empty tile
    return double(openvdb::tools::BoxSampler::sample(acc, p));
  };
  double column = 0;
  for (size_t i = 0; i + 1 < cuts.size(); ++i) {
    const double mid = (cuts[i] + cuts[i + 1]) / 2, half = (cuts[i + 1] - cuts[i]) / 2, r = half / std::sqrt(3.0);
    column += half * (density(mid - r) + density(mid + r));
  }
  return column;
}

// Settings whose deep shadow map of `nodes`^3 over the volume's box holds the columns toward each of the
// directions (suns), marched in shadow steps of `shadow_step` m; an 8x8 image.
RenderSettings map_toward(const std::vector<Vec3d>& toward, int nodes, double shadow_step, bool trilinear) {
  RenderSettings s;
  s.camera.eye = {0, -150, 2};
  s.camera.look_at = {0, 0, 0};
  s.camera.up = {0, 0, 1};
  s.camera.width = s.camera.height = 8;
  s.step = 0.5;
  s.min_transmittance = 0;
  s.extinction = {0.4};
  s.albedo = {0.9};
  s.shadow = ShadowMode::DeepShadowMap;
  s.shadow_map_size = {nodes, nodes, nodes};
  s.shadow_step = shadow_step;
  s.shadow_trilinear = trilinear;
  for (const Vec3d& u : toward) {
    Light sun;
    sun.direction = u;
    sun.intensity = {1000};
    s.lights.push_back(sun);
  }
  return s;
}

// The lights' directions: oblique, in an axis plane, along an axis.
const std::vector<Vec3d> kToward = {{0.6, 0.0, 0.8}, {-0.36, 0.8, -0.48}, {0.0, 0.0, -1.0}};

// The volume on the device, keeping its deep shadow map for the test to read.
DeviceVolume keeping_maps(const CloudVolume& volume) {
  DeviceVolume dv = upload_volume(test::runtime(), volume);
  dv.kept_shadow_map = std::make_shared<KeptShadowMap>();
  return dv;
}

// Whether the line from world point x along u lies in a plane of the tiles' faces (cell space, multiples of
// 8): which side of it a march takes, and which node's value, is float's choice.
bool in_a_tile_face(const Vec3d& x, const Vec3d& u) {
  for (int a = 0; a < 3; ++a) {
    const double c = x[a] / kDx + 0.5;
    if (u[a] == 0 && std::abs(c - 8 * std::round(c / 8)) < 1e-3) return true;
  }
  return false;
}

// Renders s over dv, which keeps its map, then calls check(the map's column, the node's world point, the
// light's index) at each node of the map.
void each_map_node(CloudRenderer& renderer, const DeviceVolume& dv, const RenderSettings& s,
                   const std::function<void(double column, const Vec3d& x, size_t light)>& check) {
  const uint64_t made = dv.kept_shadow_map->made;
  renderer.render(dv, s);
  ASSERT_EQ(dv.kept_shadow_map->made, made + 1) << "the render made no map";
  const auto& n = s.shadow_map_size;
  const size_t per_light = size_t(n[0]) * n[1] * n[2];
  std::vector<float> map(per_light * s.lights.size());
  test::runtime().queue().enqueueReadBuffer(dv.kept_shadow_map->map, true, 0, map.size() * sizeof(float), map.data());
  for (size_t light = 0; light < s.lights.size(); ++light)
    for (int k = 0; k < n[2]; ++k)
      for (int j = 0; j < n[1]; ++j)
        for (int i = 0; i < n[0]; ++i) {
          const int node[3] = {i, j, k};
          Vec3d x;
          for (int a = 0; a < 3; ++a)
            x[a] = dv.world_min[a] + (dv.world_max[a] - dv.world_min[a]) * node[a] / (n[a] - 1);
          check(map[light * per_light + (size_t(k) * n[1] + j) * n[0] + i], x, light);
        }
}

// A deep shadow map's nodes hold the column toward each light, here through tiles of lower and upper nodes,
// leaves and empty blocks, across the nodes' edges, toward a light along a face's plane too: nearest-voxel
// marches of such blocks are exact whatever their steps, so every node matches the blocks' exact column.
TEST(ShadowColumns, NearestVoxelColumnsThroughTilesAndLeavesAreExact) {
  CloudRenderer renderer(test::runtime());
  const CloudVolume volume = blocks();
  const DeviceVolume dv = keeping_maps(volume);
  const std::vector<Vec3d>& toward = kToward;
  RenderSettings s = map_toward(toward, 23, 0, false);  // shadow steps of 3 steps
  const auto acc = volume.density->getConstAccessor();
  // Calls check(the map's column, the exact one) at each node in density (a map skips those far from any)
  // and not on a block's face along the light (which block's value the line takes there is float's
  // choice); returns how many.
  auto each_node = [&](const std::function<void(double got, double want)>& check) {
    size_t compared = 0;
    each_map_node(renderer, dv, s, [&](double got, const Vec3d& x, size_t light) {
      if (acc.getValue(openvdb::Coord::round(volume.density->worldToIndex({x[0], x[1], x[2]}))) == 0 ||
          in_a_tile_face(x, toward[light]))
        return;
      ++compared;
      check(got, exact_column(*volume.density, x, toward[light], -96, 128));
    });
    return compared;
  };
  double worst = 0;
  const size_t compared = each_node(
      [&](double got, double want) { worst = test::worse(worst, std::abs(got - want) / std::max(want, 1.0)); });
  std::printf("deep shadow map of 8^3 blocks: worst |column - exact| / max(exact, 1 m) %.2e over %zu nodes\n", worst,
              compared);
  EXPECT_GT(compared, toward.size() * 23 * 23 * 23 / 3);
  EXPECT_LT(worst, 1e-4);
  // Marches that stop once the light is below min_transmittance, past the column -ln(0.05) / 0.4 m^-1 = 7.5 m:
  // each column lies between the smaller of that and the exact column, and the exact column.
  s.min_transmittance = 0.05;
  const double column_max = -std::log(0.05) / s.extinction[0];
  size_t stopped = 0, outside = 0;
  each_node([&](double got, double want) {
    outside += got < std::min(want, column_max) * (1 - 1e-4) || got > want * (1 + 1e-4) + 1e-4;
    stopped += want > column_max && got < want * (1 - 1e-3);
  });
  EXPECT_EQ(outside, 0u) << "columns below the exact one and the limit, or above the exact one";
  EXPECT_GT(stopped, compared / 4);
}

// Trilinear shadow rays take a tile's value x length over its core and over tiles inside uniform density,
// and sample the rest: the columns through the dotted block match the exact integral of trilinear density,
// to the sampling of the shells and leaves in steps of 1/40 voxel (worst 1.9e-4 relative).
TEST(ShadowColumns, TrilinearColumnsThroughTilesAndLeavesMatchTheExactIntegral) {
  CloudRenderer renderer(test::runtime());
  const CloudVolume volume = dotted_block();
  const DeviceVolume dv = keeping_maps(volume);
  const std::vector<Vec3d>& toward = kToward;
  double worst = 0;
  size_t compared = 0;
  each_map_node(renderer, dv, map_toward(toward, 11, kDx / 40, true), [&](double got, const Vec3d& x, size_t light) {
    if (in_a_tile_face(x, toward[light])) return;
    const double want = exact_trilinear_column(*volume.density, x, toward[light], -96, 96);
    worst = test::worse(worst, std::abs(got - want) / std::max(want, 1.0));
    ++compared;
  });
  std::printf(
      "trilinear columns through the dotted block: worst |column - exact| / max(exact, 1 m) %.2e over %zu "
      "nodes\n",
      worst, compared);
  EXPECT_GT(compared, toward.size() * 11 * 11 * 11 * 2 / 3);  // 3003 of the 3 x 11^3 nodes: off the tiles' faces
  EXPECT_LT(worst, 4e-4);
}

// Each tile of a lower node is interior where it and its 26 neighbours (leaves, tiles of any level, the
// background) are tiles of one value, read here through OpenVDB's accessor.
TEST(ShadowColumns, InteriorTilesAreThoseAmongTilesOfTheirValue) {
  for (const CloudVolume& volume : {blocks(), dotted_block()}) {
    const NanoHandle handle = to_nanovdb(*volume.density);
    const auto* grid = handle.grid<float>();
    const std::vector<uint32_t> bits = interior_tiles(*grid);
    ASSERT_EQ(bits.size(), size_t(grid->tree().nodeCount(1)) * kInteriorWordsPerLowerNode);
    const auto* first = grid->tree().getFirstNode<1>();
    auto nano = grid->getAccessor();
    const auto acc = volume.density->getConstAccessor();
    size_t interior = 0, other = 0, wrong = 0;
    for (auto it = volume.density->tree().cbeginValueAll(); it; ++it) {
      if (it.getLevel() != 1) continue;
      const openvdb::Coord lo = it.getCoord();
      bool expected = true;
      for (int dx = -8; dx <= 8; dx += 8)
        for (int dy = -8; dy <= 8; dy += 8)
          for (int dz = -8; dz <= 8; dz += 8) {
            const openvdb::Coord n = lo.offsetBy(dx, dy, dz);
            expected &= !acc.probeConstLeaf(n) && acc.getValue(n) == *it;
          }
      nano.getValue(nanovdb::Coord(lo.x(), lo.y(), lo.z()));  // caches the tile's lower node
      const size_t node = size_t(nano.getNode<nanovdb::NanoLower<float>>() - first);
      const uint32_t n =
          uint32_t(lo.x() & 127) >> 3 << 8 | uint32_t(lo.y() & 127) >> 3 << 4 | uint32_t(lo.z() & 127) >> 3;
      const bool got = (bits[node * kInteriorWordsPerLowerNode + n / 32] >> (n % 32)) & 1;
      wrong += got != expected;
      (expected ? interior : other) += 1;
    }
    std::printf("interior tiles: %zu of %zu, %zu marked wrongly\n", interior, interior + other, wrong);
    EXPECT_EQ(wrong, 0u);
    EXPECT_GT(interior, 1000u);
    EXPECT_GT(other, 1000u);
  }
}

}  // namespace
}  // namespace squall::clouds
