// Cloud modeling on the host (OpenVDB): shapes, pyroclastic displacement, advection maps, sparsity,
// .vdb output and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <random>
#include <utility>

#include "clouds/advection.h"
#include "clouds/noise.h"
#include "clouds/volume.h"
#include "common/error.h"

#include "support/expect_error.h"

namespace squall::clouds {
namespace {

Particle particle(const Vec3d& center, double radius) {
  Particle p;
  p.center = center;
  p.radius = radius;
  return p;
}

double radius_of(const openvdb::FloatGrid& g, const openvdb::Coord& ijk, const Vec3d& c) {
  openvdb::Vec3d x = g.transform().indexToWorld(ijk);
  return (x - openvdb::Vec3d(c[0], c[1], c[2])).length();
}

// Perlin's permutation repeats every 256 lattice cells, so the noise does: at any distance, also past int's
// range, where the cell was converted to int before it was reduced (2.6e12 cells became INT_MIN's cell).
TEST(Noise, PerlinRepeatsEvery256CellsAtAnyDistance) {
  const Vec3d p{3.375, -7.25, 0.625};
  const double here = perlin(p);
  EXPECT_GT(std::abs(here), 1e-3);
  for (double periods : {1.0, -3.0, 1e6, 1e10, -1e10, 1e12})
    for (int axis = 0; axis < 3; ++axis) {
      Vec3d q = p;
      q[axis] += 256 * periods;
      EXPECT_EQ(perlin(q), here) << periods << " periods along axis " << axis;
    }
}

TEST(Model, PyroclasticSphereStaysInsideTheRadialBandItsAmplitudeAllows) {
  CloudModel m;
  m.voxel_size = 0.25;
  m.skin = 0.5;
  const Vec3d c{1, 2, 3};
  const double R = 8;
  m.spheres.push_back({c, R});
  m.pyroclastic.layers = 2;
  m.pyroclastic.amplitude = 2;
  m.pyroclastic.gamma = 1;
  m.pyroclastic.noise.frequency = 0.3;
  m.pyroclastic.noise.roughness = 0.5;
  const double bound = pyroclastic_bound(m.pyroclastic);  // 2 + 2 * 0.5 = 3 m
  EXPECT_DOUBLE_EQ(bound, 3.0);
  CloudVolume v = build_cloud(m);
  const auto& g = *v.density;
  double r_max = 0;
  for (auto it = g.cbeginValueOn(); it; ++it) {
    if (!it.isVoxelValue()) continue;
    r_max = std::max(r_max, radius_of(g, it.getCoord(), c));
  }
  // l1 = l + displacement > 0 needs l > -bound, i.e. |x - c| < R + bound (up to the SDF's voxel error).
  EXPECT_LT(r_max, R + bound + m.voxel_size);
  EXPECT_GT(r_max, R + 0.4 * bound);  // the displacement did move the surface out
  // Inside R - skin the density is 1 (displacement only adds), including interior tiles.
  auto acc = g.getConstAccessor();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  int inside = 0;
  for (int i = 0; i < 20000; ++i) {
    openvdb::Vec3d x(u(rng) * R, u(rng) * R, u(rng) * R);
    if (x.length() > R - m.skin - m.voxel_size) continue;
    ++inside;
    openvdb::Coord ijk = g.transform().worldToIndexNodeCentered(x + openvdb::Vec3d(c[0], c[1], c[2]));
    ASSERT_EQ(acc.getValue(ijk), 1.0f) << x;
  }
  EXPECT_GT(inside, 5000);
}

TEST(Model, MeshLevelSetIsPositiveInside) {
  CloudModel m;
  m.voxel_size = 0.1;
  m.skin = 0.2;
  TriangleMesh cube;
  cube.vertices = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1}, {-1, -1, 1}, {1, -1, 1}, {1, 1, 1}, {-1, 1, 1}};
  cube.triangles = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                    2, 3, 7, 2, 7, 6, 1, 2, 6, 1, 6, 5, 0, 4, 7, 0, 7, 3};
  m.meshes.push_back(cube);
  auto ls = base_level_set(m, 0.5, 0.5);
  ASSERT_TRUE(ls);
  auto acc = ls->getConstAccessor();
  EXPECT_GE(acc.getValue(openvdb::Coord(0, 0, 0)), 0.5f);             // beyond the band: >= +interior
  EXPECT_NEAR(acc.getValue(openvdb::Coord(8, 0, 0)), 0.2f, 0.01f);    // 0.2 m inside the face x = 1
  EXPECT_NEAR(acc.getValue(openvdb::Coord(12, 0, 0)), -0.2f, 0.01f);  // 0.2 m outside
  CloudVolume v = build_cloud(m);
  // The density of the cube: 1 deeper than the skin, the ramp over the skin, active: the voxel centres
  // inside the 2 m cube (19^3), plus at most the layer on its faces (21^3).
  auto d = v.density->getConstAccessor();
  EXPECT_EQ(d.getValue(openvdb::Coord(0, 0, 0)), 1.0f);
  EXPECT_NEAR(d.getValue(openvdb::Coord(9, 0, 0)), 0.5f, 0.05f);
  EXPECT_GE(v.stats.active_voxels, 19u * 19 * 19);
  EXPECT_LE(v.stats.active_voxels, 21u * 21 * 21);
}

// Inside a sphere the level set is the distance to its surface, so the density at its centre is
// radius / skin (eq 103), and the active voxels are those whose centres lie inside it; also for spheres
// finer than OpenVDB's sphere resolves (1.5 voxels in radius), down to the half voxel validation allows.
TEST(Model, SpheresOfAFewVoxelsHaveTheDensityOfTheirRadius) {
  // (radius, voxel size), m: r^2 / dx^2 away from the integers (no centre on the surface); 1.5 voxels that
  // OpenVDB's float test finds just under 1.5 (0.45 / 0.3, 1.8 / 1.2).
  for (auto [radius, dx] : std::initializer_list<std::pair<double, double>>{
           {0.6, 1}, {1.2, 1}, {1.3, 1}, {0.45, 0.3}, {1.8, 1.2}, {1.6, 1}, {2.9, 1}}) {
    CloudModel m;
    m.voxel_size = dx;
    m.skin = 4;
    m.spheres.push_back({{0, 0, 0}, radius});
    CloudVolume v = build_cloud(m);
    EXPECT_NEAR(v.density->getConstAccessor().getValue(openvdb::Coord(0, 0, 0)), radius / 4, 0.01) << radius;
    uint64_t inside = 0;
    for (int i = -3; i <= 3; ++i)
      for (int j = -3; j <= 3; ++j)
        for (int k = -3; k <= 3; ++k) inside += (i * i + j * j + k * k) * dx * dx < radius * radius;
    EXPECT_EQ(v.stats.active_voxels, inside) << radius << " m in voxels of " << dx << " m";
  }
}

// A dense grid over two spheres at opposite corners of the reach, 1.7e6 voxels apart on each axis, would take
// 2e19 bytes, past 2^64: its size saturates (it wrapped to 1.2e18, and the fill ratio came out 16 times high).
TEST(Model, ADenseGridPastTwoToTheSixtyFourBytesSaturates) {
  CloudModel m;
  m.voxel_size = 1;
  m.skin = 1;
  m.spheres = {{{-8.5e5, -8.5e5, -8.5e5}, 2}, {{8.5e5, 8.5e5, 8.5e5}, 2}};
  const CloudVolume v = build_cloud(m);
  EXPECT_GT(v.stats.dense_voxels, UINT64_MAX / 4);
  EXPECT_EQ(v.stats.dense_bytes, UINT64_MAX);
}

// A closed cube, 2 m on a side, its corner 0 at `at`, its vertices from `first` on; `flip` reverses one
// face's winding.
void add_cube(TriangleMesh& mesh, const Vec3d& at, uint32_t first, bool flip = false) {
  for (int v = 0; v < 8; ++v)
    mesh.vertices.push_back({at[0] + 2 * (v & 1), at[1] + 2 * (v >> 1 & 1), at[2] + 2 * (v >> 2)});
  std::vector<uint32_t> faces = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                                 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
  if (flip) std::swap(faces[1], faces[2]), std::swap(faces[4], faces[5]);
  for (uint32_t index : faces) mesh.triangles.push_back(first + index);
}

// A mesh falls into its connected pieces, each with its volume and area, and convex when it bounds a convex
// body: not an L of two cubes, two cubes joined at a corner, an open box or a box wound inconsistently.
TEST(Model, AMeshFallsIntoPiecesThatKnowWhetherTheyAreConvex) {
  TriangleMesh apart;
  add_cube(apart, {0, 0, 0}, 0);
  add_cube(apart, {10, 0, 0}, 8);
  const auto pieces = mesh_pieces(apart);
  ASSERT_EQ(pieces.size(), 2u);
  for (const MeshPiece& piece : pieces) {
    EXPECT_NEAR(piece.volume, 8, 1e-12);
    EXPECT_NEAR(piece.area, 24, 1e-12);
    EXPECT_TRUE(piece.convex);
  }
  EXPECT_EQ(pieces[1].lo, (Vec3d{10, 0, 0}));
  EXPECT_EQ(pieces[1].hi, (Vec3d{12, 2, 2}));

  TriangleMesh joined;  // the second cube's corner 0 is the first's corner 7, (2, 2, 2)
  add_cube(joined, {0, 0, 0}, 0);
  add_cube(joined, {2, 2, 2}, 8);
  for (uint32_t& index : joined.triangles) index = index == 8 ? 7 : index;
  ASSERT_EQ(mesh_pieces(joined).size(), 1u);
  EXPECT_FALSE(mesh_pieces(joined)[0].convex) << "two convex parts joined at a vertex";

  TriangleMesh open;
  add_cube(open, {0, 0, 0}, 0);
  open.triangles.resize(30);  // the last face gone
  EXPECT_FALSE(mesh_pieces(open)[0].convex);

  TriangleMesh flipped;
  add_cube(flipped, {0, 0, 0}, 0, true);
  EXPECT_FALSE(mesh_pieces(flipped)[0].convex);

  // An L: a 4 x 2 x 2 block with a 2 x 2 x 2 block on one end, one closed surface with a concave edge.
  TriangleMesh ell;
  ell.vertices = {{0, 0, 0}, {4, 0, 0}, {4, 2, 0}, {2, 2, 0}, {2, 4, 0}, {0, 4, 0},
                  {0, 0, 2}, {4, 0, 2}, {4, 2, 2}, {2, 2, 2}, {2, 4, 2}, {0, 4, 2}};
  ell.triangles = {0, 2, 1,  0, 3,  2,  0, 5, 3,  5,  4,  3,    // bottom (z = 0), outward -z
                   6, 7, 8,  6, 8,  9,  6, 9, 11, 11, 9,  10,   // top (z = 2), outward +z
                   0, 1, 7,  0, 7,  6,  1, 2, 8,  1,  8,  7,    // y = 0, x = 4
                   2, 3, 9,  2, 9,  8,  3, 4, 10, 3,  10, 9,    // y = 2 (x 2..4), x = 2 (y 2..4)
                   4, 5, 11, 4, 11, 10, 5, 0, 6,  5,  6,  11};  // y = 4, x = 0
  const auto l = mesh_pieces(ell);
  ASSERT_EQ(l.size(), 1u);
  EXPECT_NEAR(l[0].volume, 24, 1e-12);
  EXPECT_FALSE(l[0].convex);
}

// The order a client lists a mesh's triangles in does not change the cloud (squalld sorts them by region for
// OpenVDB's threads): two cubes apart, their triangles listed in turn and in reverse.
TEST(Model, AMeshsCloudDoesNotDependOnTheOrderOfItsTriangles) {
  CloudModel listed, reversed;
  for (CloudModel* m : {&listed, &reversed}) {
    m->voxel_size = 0.25;
    m->skin = 0.5;
    m->meshes.emplace_back();
    add_cube(m->meshes[0], {0, 0, 0}, 0);
    add_cube(m->meshes[0], {5, 1, 0}, 8);
  }
  auto& t = reversed.meshes[0].triangles;
  for (size_t i = 0, j = t.size() - 3; i < j; i += 3, j -= 3)
    std::swap_ranges(t.begin() + i, t.begin() + i + 3, t.begin() + j);
  const CloudVolume a = build_cloud(listed), b = build_cloud(reversed);
  ASSERT_EQ(a.stats.active_voxels, b.stats.active_voxels);
  auto other = b.density->getConstAccessor();
  for (auto it = a.density->cbeginValueOn(); it; ++it) ASSERT_EQ(other.getValue(it.getCoord()), *it) << it.getCoord();
}

// A mesh's estimated voxels do not depend on where it is (its enclosed volume is summed from one of its
// vertices, not from the origin, where a mesh far out loses it to cancellation), and a mesh beyond the
// device's reach is refused for that, not taken for a degenerate one.
TEST(Model, AMeshIsEstimatedAlikeAnywhereAndRefusedBeyondReach) {
  auto cube_at = [](double x) {  // 1 m on a side, voxels of 1 m
    CloudModel m;
    m.voxel_size = 1;
    TriangleMesh cube;
    for (int v = 0; v < 8; ++v) cube.vertices.push_back({x + (v & 1), x + (v >> 1 & 1), x + (v >> 2)});
    cube.triangles = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                      2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
    m.meshes.push_back(cube);
    return m;
  };
  const double near = validate(cube_at(0.3), "model");
  EXPECT_NEAR(validate(cube_at(9e5 + 0.3), "model"), near, 1e-9 * near);  // from the origin: 166 m^3, not 1
  test::expect_error(Code::InvalidArgument, "model.meshes[0].vertices[0..2] = (1e+30, 1e+30, 1e+30) plus",
                     [&] { validate(cube_at(1e30), "model"); });
}

TEST(Model, TemperatureFollowsTheLapseRate) {
  CloudModel m;
  m.voxel_size = 0.5;
  m.skin = 1;
  m.spheres.push_back({{0, 0, 1000}, 5});
  m.temperature.enabled = true;
  m.temperature.surface = 288.15;
  m.temperature.lapse_rate = 0.0065;
  CloudVolume v = build_cloud(m);
  ASSERT_TRUE(v.temperature);
  EXPECT_EQ(v.temperature->activeVoxelCount(), v.density->activeVoxelCount());
  auto t = v.temperature->getConstAccessor();
  openvdb::Coord top(0, 0, 2000 + 8), bottom(0, 0, 2000 - 8);
  EXPECT_NEAR(t.getValue(top), 288.15 - 0.0065 * 1004, 1e-3);
  EXPECT_NEAR(t.getValue(bottom), 288.15 - 0.0065 * 996, 1e-3);
}

TEST(Model, CloudsCombineByMaximumDensity) {
  CloudModel a, b;
  for (auto* m : {&a, &b}) {
    m->voxel_size = 0.5;
    m->skin = 2;
  }
  a.spheres.push_back({{0, 0, 0}, 4});
  b.spheres.push_back({{3, 0, 0}, 4});
  CloudVolume va = build_cloud(a), vb = build_cloud(b);
  CloudVolume both = combine_max(va, vb);
  auto ga = va.density->getConstAccessor(), gb = vb.density->getConstAccessor(), g = both.density->getConstAccessor();
  for (int i = -20; i <= 26; ++i)
    for (int j = -12; j <= 12; j += 3) {
      openvdb::Coord ijk(i, j, 1);
      ASSERT_EQ(g.getValue(ijk), std::max(ga.getValue(ijk), gb.getValue(ijk))) << ijk;
    }
}

TEST(Model, ThousandCubedBoundsStaySparse) {
  CloudModel m;
  m.voxel_size = 1;
  m.skin = 2;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(30, 970);
  m.particles.push_back(particle({20, 20, 20}, 20));
  m.particles.push_back(particle({980, 980, 980}, 20));
  for (int i = 0; i < 18; ++i) m.particles.push_back(particle({u(rng), u(rng), u(rng)}, 20));
  for (auto& p : m.particles) p.noise.frequency = 0.05;
  CloudVolume v = build_cloud(m);
  const auto& s = v.stats;
  EXPECT_GE(s.bounds.dim().x(), 990);
  EXPECT_GE(s.bounds.dim().z(), 990);
  EXPECT_GT(s.dense_bytes, 3.8e9);  // 4 bytes x ~1000^3
  EXPECT_GT(s.active_voxels, 100000u);
  std::printf("1000^3 cloud: %llu active voxels, %llu bytes sparse vs %llu dense: ratio %.2e\n",
              (unsigned long long)s.active_voxels, (unsigned long long)s.bytes, (unsigned long long)s.dense_bytes,
              s.fill_ratio());
  EXPECT_LT(s.fill_ratio(), 2e-3);
}

// write_vdb writes the same bytes for the same volume; read_vdb gives its grids back, refuses damaged
// bytes, and leaves no temporary file either way (OpenVDB's delayed loading copies a stream to one first).
TEST(Model, VdbBytesReadBackWithNoTemporaryFile) {
  auto temporary_files = [] {
    size_t n = 0;
    for (const auto& entry : std::filesystem::directory_iterator(std::filesystem::temp_directory_path()))
      n += entry.path().filename().string().rfind("openvdb_temp_", 0) == 0;
    return n;
  };
  CloudModel m;
  m.voxel_size = 0.5;
  m.spheres.push_back({{0, 0, 0}, 3});
  const CloudVolume v = build_cloud(m);
  const std::string bytes = write_vdb(v);
  EXPECT_EQ(write_vdb(build_cloud(m)), bytes) << "the same volume is the same bytes, its header's UUID too";
  const size_t before = temporary_files();
  EXPECT_EQ(read_vdb(bytes, "payload").density->activeVoxelCount(), v.density->activeVoxelCount());
  for (const std::string& damaged : {bytes.substr(0, bytes.size() / 2), std::string(), std::string(100, 'x')}) {
    test::expect_error(Code::InvalidArgument, "payload is not a .vdb stream", [&] { read_vdb(damaged, "payload"); });
  }
  EXPECT_EQ(temporary_files(), before);
}

// A .vdb whose density is negative or not finite anywhere (a voxel, active or not, a tile, the background) is
// refused naming where: the marches read every value, and take a negative one for a leaf's mark.
TEST(Model, VdbWithNegativeOrNonFiniteDensityIsRefused) {
  CloudModel m;
  m.voxel_size = 0.5;
  m.spheres.push_back({{0, 0, 0}, 3});
  const CloudVolume v = build_cloud(m);
  EXPECT_NO_THROW(read_vdb(write_vdb(v), "payload"));
  auto refused = [&](auto damage, const std::string& message) {
    CloudVolume bad = v;
    bad.density = v.density->deepCopy();
    damage(*bad.density);
    test::expect_error(Code::InvalidArgument, "payload: its density grid holds " + message,
                       [&] { read_vdb(write_vdb(bad), "payload"); });
  };
  refused([](openvdb::FloatGrid& g) { g.tree().addTile(1, openvdb::Coord(64, 0, 0), -0.5f, true); },
          "-0.5 at the tile at (64, 0, 0)");
  refused([](openvdb::FloatGrid& g) { g.tree().setValueOff(openvdb::Coord(1, 2, 3), NAN); }, "nan at voxel (1, 2, 3)");
  refused([](openvdb::FloatGrid& g) { g.tree().setValueOn(openvdb::Coord(-1, 0, 2), INFINITY); },
          "inf at voxel (-1, 0, 2)");
  refused([](openvdb::FloatGrid& g) { g.tree().root().setBackground(-1.0f, true); }, "-1 at the background");
}

TEST(Model, VdbFileOpensInVdbPrintWithGridNamesAndVoxelCounts) {
  CloudModel m;
  m.voxel_size = 0.5;
  m.skin = 1;
  m.spheres.push_back({{0, 0, 0}, 6});
  m.temperature.enabled = true;
  CloudVolume v = build_cloud(m);
  auto path = std::filesystem::temp_directory_path() / ("squall_clouds_" + std::to_string(::getpid()) + ".vdb");
  {
    std::ofstream out(path, std::ios::binary);
    out << write_vdb(v);
  }
  std::string cmd = "vdb_print " + path.string() + " 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string text;
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof buf, pipe)) text.append(buf, n);
  int rc = pclose(pipe);
  std::filesystem::remove(path);
  ASSERT_EQ(rc, 0) << text;
  EXPECT_NE(text.find("density"), std::string::npos) << text;
  EXPECT_NE(text.find("temperature"), std::string::npos) << text;
  // vdb_print shows each grid's active voxel count in thousands, e.g. "7.12KVox", on the grid's line.
  for (const auto& grid : {v.density, v.temperature}) {
    uint64_t n = grid->activeVoxelCount();
    char count[32];
    std::snprintf(count, sizeof count, "%.2fKVox", n / 1000.0);
    size_t line = text.find(grid->getName() + " ");
    ASSERT_NE(line, std::string::npos) << text;
    std::string row = text.substr(line, text.find('\n', line) - line);
    EXPECT_NE(row.find(count), std::string::npos) << "expected " << count << " in: " << row;
  }
}

}  // namespace
}  // namespace squall::clouds
