// Bad input: each gets squall::Error with the right code and a message naming the field.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <functional>
#include <limits>

#include "clouds/build_memory.h"
#include "clouds/renderer.h"
#include "clouds/volume.h"
#include "common/error.h"

#include "support/expect_error.h"

namespace squall::clouds {
namespace {

void expect_error(const std::function<void()>& f, Code code, const std::string& needle) {
  test::expect_error(code, needle, f);
}

CloudModel sphere_model() {
  CloudModel m;
  m.voxel_size = 0.5;
  m.skin = 1;
  m.spheres.push_back({{0, 0, 0}, 4});
  return m;
}

TEST(Errors, NanRadiusNamesTheField) {
  CloudModel m = sphere_model();
  m.spheres[0].radius = std::nan("");
  expect_error([&] { build_cloud(m); }, Code::InvalidArgument, "model.spheres[0].radius = nan");
}

TEST(Errors, NanNoiseAndCentreNameTheirFields) {
  CloudModel m = sphere_model();
  m.pyroclastic.noise.frequency = std::numeric_limits<double>::infinity();
  expect_error([&] { build_cloud(m); }, Code::InvalidArgument, "model.pyroclastic.noise.frequency = inf");
  m = sphere_model();
  m.spheres[0].center[2] = std::nan("");
  expect_error([&] { build_cloud(m); }, Code::InvalidArgument, "model.spheres[0].center.z = nan");
}

// Voxel sizes from 1e-4 m (OpenVDB refuses a transform whose voxel volume is below 3e-15 m^3: a 1e-40 m
// voxel was INTERNAL) to 1e6 m (a 1e300 m voxel estimated "nan active voxels"); noise frequencies up to 1e9
// per m and offsets within 1e9 m, whose lattice coordinates stay finite.
TEST(Errors, VoxelSizesAndNoisesPastTheirRangesAreRefusedByName) {
  CloudModel m = sphere_model();
  for (double voxel : {1e-40, 9e-5, 1.1e6, 1e300}) {
    m.voxel_size = voxel;
    expect_error([&] { validate(m); }, Code::InvalidArgument, "model.voxel_size = ");
  }
  m = sphere_model();
  m.pyroclastic.noise.frequency = 2e9;
  expect_error([&] { validate(m); }, Code::InvalidArgument, "model.pyroclastic.noise.frequency = ");
  m = sphere_model();
  m.advection.noise.offset[1] = -2e9;
  expect_error([&] { validate(m); }, Code::InvalidArgument, "model.advection.noise.offset.y = ");
  m = sphere_model();  // the ends of the ranges are built
  m.voxel_size = 1e-4;
  m.skin = 2e-4;
  m.spheres[0].radius = 1e-3;
  m.pyroclastic.layers = 2;
  m.pyroclastic.amplitude = 1e-4;
  m.pyroclastic.noise.frequency = 1e9;
  m.pyroclastic.noise.offset = {1e9, -1e9, 1e9};
  EXPECT_GT(build_cloud(m).stats.active_voxels, 1000u);
}

TEST(Errors, DegenerateMeshIsRejected) {
  CloudModel m = sphere_model();
  TriangleMesh flat;  // four triangles, all in the plane z = 0: no volume
  flat.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  flat.triangles = {0, 1, 2, 0, 2, 3, 0, 2, 1, 0, 3, 2};
  m.meshes.push_back(flat);
  expect_error([&] { build_cloud(m); }, Code::InvalidArgument, "model.meshes[0] is degenerate");
  m.meshes[0].triangles[4] = 9;
  expect_error([&] { build_cloud(m); }, Code::InvalidArgument, "model.meshes[0].triangles[4] = 9 is out of range");
}

// A mesh with a hole (a cube without its top's two triangles) would give part of a cloud, as OpenVDB fills
// what it can tell is inside: refused naming an edge of the hole, the same one each time; closed, it builds,
// also where a seam splits vertices at the same positions.
TEST(Errors, AnOpenMeshIsRefusedNamingAnEdgeOfItsHole) {
  CloudModel m = sphere_model();
  TriangleMesh cube;
  cube.vertices = {{-2, -2, -2}, {2, -2, -2}, {2, 2, -2}, {-2, 2, -2}, {-2, -2, 2}, {2, -2, 2}, {2, 2, 2}, {-2, 2, 2}};
  cube.triangles = {0, 2, 1, 0, 3, 2, 0, 1, 5, 0, 5, 4, 1, 2, 6, 1, 6, 5,
                    2, 3, 7, 2, 7, 6, 3, 0, 4, 3, 4, 7, 4, 5, 6, 4, 6, 7};  // the last two: the top, z = 2
  m.meshes.push_back(cube);
  EXPECT_GT(build_cloud(m).stats.active_voxels, 0u);
  // The top with corners of its own at the same positions (a seam, as exporters split vertices): closed.
  m.meshes[0].vertices.insert(m.meshes[0].vertices.end(), {{-2, -2, 2}, {2, -2, 2}, {2, 2, 2}, {-2, 2, 2}});
  for (size_t k = 30; k < 36; ++k) m.meshes[0].triangles[k] += 4;
  EXPECT_GT(build_cloud(m).stats.active_voxels, 0u);
  m.meshes[0] = cube;
  m.meshes[0].triangles.resize(30);
  expect_error([&] { build_cloud(m); }, Code::InvalidArgument,
               "model.meshes[0] is not closed: the edge from model.meshes[0].vertices[12..14] to "
               "model.meshes[0].vertices[15..17] borders an odd number of triangles");
}

// The advection dilates the density by twice the field's top speed (sqrt(3) speed) times the time, along
// each axis: a 1 m sphere carried at 100 m/s for 1 s becomes a working grid some 690 voxels across
// (3e8 voxels), which the estimate refuses up front rather than after building it (it counted 2.4e7).
TEST(Errors, TheAdvectionsDilationCountsInTheVoxelEstimate) {
  CloudModel m;
  m.voxel_size = 1;
  m.skin = 1;
  m.spheres.push_back({{0, 0, 0}, 1});
  m.advection.speed = 100;
  m.advection.time = 1;
  expect_error([&] { validate(m); }, Code::ResourceExhausted, "model.max_active_voxels");
}

// A build asks its Cancellation within each stage: before each base shape and each slab of a particle, not
// only when the stage is done. Cancelled after its first answers, a build of five spheres stops among
// them, and one of a particle 100 voxels across within the particle.
TEST(Errors, ABuildStopsWithinTheStageItWasCancelledIn) {
  CloudModel m = sphere_model();
  for (int k = 1; k < 5; ++k) m.spheres.push_back({{3.0 * k, 0, 0}, 4});
  int asked = 0;
  const Cancellation after_two([&] { return ++asked > 2; });
  expect_error([&] { build_cloud(m, "model", after_two); }, Code::Cancelled, "model: the base shapes cancelled");
  m = sphere_model();
  m.spheres.clear();
  Particle p;
  p.center = {0, 0, 0};
  p.radius = 25;  // 100 voxels across
  m.particles.push_back(p);
  asked = 0;
  expect_error([&] { build_cloud(m, "model", after_two); }, Code::Cancelled, "model: the particles cancelled");
  // The temperature's fractal noise is a stage of its own: cancelled after every question the build without
  // it asks, the build stops there.
  m = sphere_model();
  m.temperature.enabled = false;
  m.temperature.fluctuation = 10;
  std::atomic<int> questions{0};
  build_cloud(m, "model", Cancellation([&] { return ++questions < 0; }));
  const int before_temperature = questions;
  m.temperature.enabled = true;
  questions = 0;
  expect_error([&] { build_cloud(m, "model", Cancellation([&] { return ++questions > before_temperature; })); },
               Code::Cancelled, "model: the temperature cancelled");
}

// A mesh's estimate counts its surface: a tetrahedron 10 km wide and 1 cm high encloses 1.7e5 m^3, but its
// level set's band covers its 1e8 m^2 on both sides (some 7e8 voxels at 1 m), refused up front.
TEST(Errors, AThinMeshsSurfaceCountsInTheVoxelEstimate) {
  CloudModel m;
  m.voxel_size = 1;
  m.skin = 1;
  TriangleMesh sliver;
  sliver.vertices = {{0, 0, 0}, {1e4, 0, 0}, {0, 1e4, 0}, {0, 0, 0.01}};
  sliver.triangles = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  m.meshes.push_back(sliver);
  expect_error([&] { validate(m); }, Code::ResourceExhausted, "model.max_active_voxels");
}

// A long thin mesh grown by its skin and displacement is a tube: pi g^2 per metre of its length, which its
// area alone (4 m^2 a metre) misses. The estimate holds the voxels a build makes: a 1000 x 1 x 1 m box grown
// by 10 m of pyroclastic displacement.
TEST(Errors, ANeedleMeshsGrownTubeCountsInTheVoxelEstimate) {
  CloudModel m;
  m.voxel_size = 1;
  m.skin = 1;
  m.pyroclastic.layers = 1;
  m.pyroclastic.amplitude = 10;
  m.pyroclastic.gamma = 1e-6;
  TriangleMesh needle;
  needle.vertices = {{0, 0, 0}, {1000, 0, 0}, {1000, 1, 0}, {0, 1, 0},
                     {0, 0, 1}, {1000, 0, 1}, {1000, 1, 1}, {0, 1, 1}};
  needle.triangles = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                      2, 3, 7, 2, 7, 6, 1, 2, 6, 1, 6, 5, 3, 0, 4, 3, 4, 7};
  m.meshes.push_back(needle);
  const double estimated = validate(m);
  const double built = double(build_cloud(m).stats.active_voxels);
  std::printf("needle: %.0f voxels built, %.0f estimated\n", built, estimated);
  EXPECT_GE(estimated, built);
}

// The march's float32 index coordinates resolve an eighth of a voxel up to 2^20 voxels from the origin: a
// shape farther out is refused by name.
TEST(Errors, AShapeFarFromTheOriginIsRefusedByName) {
  CloudModel m = sphere_model();  // 0.5 m voxels: 2^20 of them are 524288 m
  m.spheres[0].center[0] = 6e5;
  expect_error([&] { validate(m); }, Code::InvalidArgument, "model.spheres[0].center = ");
  m.spheres[0].center[0] = 5e5;
  validate(m);
}

// What grows every shape past that reach is named, not the first shape's centre.
TEST(Errors, GrowthPastTheReachNamesItsCause) {
  CloudModel skin = sphere_model(), displaced = sphere_model(), advected = sphere_model();
  skin.skin = 1e6;
  displaced.pyroclastic.layers = 1;
  displaced.pyroclastic.amplitude = 1e6;
  advected.advection.speed = 1e3;  // reaches sqrt(3) 2 sqrt(3) speed time = 6e6 m
  advected.advection.time = 1e3;
  expect_error([&] { validate(skin); }, Code::InvalidArgument, "model.skin = 1000000 grows every shape by 1000001.5 m");
  expect_error([&] { validate(displaced); }, Code::InvalidArgument, "model.pyroclastic.amplitude = 1000000 grows");
  expect_error([&] { validate(advected); }, Code::InvalidArgument, "model.advection.speed = 1000 grows");
}

// Inputs each inside its range can still make a temperature field that no gas has: +-6.5e297 K (a base altitude
// of 1e300 m), below 0 K (a lapse over a cloud 5 km above its base, or a fluctuation larger than the surface
// temperature) or past kMaxTemperature (an inversion). Each is refused; a cold cloud above 0 K is not.
TEST(Errors, ATemperatureFieldOutsideZeroToTheCapIsRefused) {
  auto with = [](double z, double surface, double base_altitude, double lapse_rate, double fluctuation) {
    CloudModel m = sphere_model();
    m.spheres[0].center[2] = z;
    m.temperature = {true, surface, base_altitude, lapse_rate, fluctuation, {}};
    return m;
  };
  const std::string needle = "model.temperature makes temperatures from ";
  expect_error([&] { build_cloud(with(0, 288.15, 1e300, 0.0065, 0)); }, Code::InvalidArgument, needle + "6.5e+297 K");
  expect_error([&] { build_cloud(with(0, 288.15, -1e300, 0.0065, 0)); }, Code::InvalidArgument, needle + "-6.5e+297 K");
  expect_error([&] { build_cloud(with(5000, 288.15, 0, 0.1, 0)); }, Code::InvalidArgument, needle + "-2");
  expect_error([&] { build_cloud(with(0, 1e-3, 0, 0, 1000)); }, Code::InvalidArgument, needle + "-");
  expect_error([&] { build_cloud(with(0, 1e4, -1e6, -0.1, 0)); }, Code::InvalidArgument, "] K: mind surface");
  const CloudVolume cold = build_cloud(with(2800, 288.15, 0, 0.1, 0));  // 288.15 - 0.1 (2800 +- 4.5) K
  auto T = cold.temperature->getConstAccessor();
  EXPECT_NEAR(T.getValue(openvdb::Coord(0, 0, 5600)), 8.15, 1e-3);
}

TEST(Errors, VoxelBudgetIsEnforced) {
  CloudModel m = sphere_model();
  m.max_active_voxels = 1000;  // a radius-8-voxel sphere has ~2000+
  expect_error([&] { build_cloud(m); }, Code::ResourceExhausted, "model.max_active_voxels = 1000");
}

// A grain of a mesh in a band of 9e5 m: its band is a ball (3e18 voxels), not its area times the band's
// width (6 voxels); refused by the voxel budget, and its memory charge saturates rather than wraps.
TEST(Errors, ASmallMeshInAWideBandIsEstimatedAsABall) {
  CloudModel m;
  m.voxel_size = 1;
  m.skin = 9e5;
  TriangleMesh grain;
  grain.vertices = {{0.001, 0.001, 0.001}, {0.001, -0.001, -0.001}, {-0.001, 0.001, -0.001}, {-0.001, -0.001, 0.001}};
  grain.triangles = {0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2};
  m.meshes.push_back(grain);
  expect_error([&] { validate(m); }, Code::ResourceExhausted, "active voxels exceed model.max_active_voxels");
  EXPECT_EQ(build_bytes(m), std::numeric_limits<uint64_t>::max());
}

TEST(Errors, RenderSettingsNameTheirFields) {
  RenderSettings s;
  s.step = std::nan("");
  expect_error([&] { validate(s); }, Code::InvalidArgument, "render.step = nan");
  s.step = 1e-40;  // a float32 subnormal
  expect_error([&] { validate(s); }, Code::InvalidArgument,
               "render.step = 1e-40 must be finite and in [1.17549435e-38, 100000000]");
  s = RenderSettings{};
  s.shadow_step = 1e-45;
  expect_error([&] { validate(s); }, Code::InvalidArgument, "render.shadow_step = 1e-45");
  s.shadow_step = -1;
  expect_error([&] { validate(s); }, Code::InvalidArgument, "render.shadow_step = -1");
  s = RenderSettings{};
  // The caption of Fig A.2 of J. Tessendorf and M. Kowalski, "Resolution Independent Volumes" (SIGGRAPH
  // course notes 2010/2011) misprints the Junge slope 3.5..5 as 0.35..0.5; a value from that range is refused.
  s.phase.ff_mu = 0.4;
  expect_error([&] { validate(s); }, Code::InvalidArgument, "render.phase.ff_mu = 0.4");
  s = RenderSettings{};
  s.lights.push_back(Light{});
  expect_error([&] { validate(s); }, Code::InvalidArgument, "render.lights[0].intensity");
  s = RenderSettings{};
  s.camera.look_at = s.camera.eye;
  expect_error([&] { validate(s); }, Code::InvalidArgument, "render.camera.look_at");
}

// Finite values that float32 on the device would turn into inf (and the image into NaN), or an asymmetry
// that rounds to g = 1 (0/0 at mu = 1), are refused naming the field.
TEST(Errors, RenderSettingsPastFloat32AreRefusedByName) {
  auto refused = [](const std::function<void(RenderSettings&)>& change, const std::string& field) {
    RenderSettings s;
    change(s);
    expect_error([&] { validate(s); }, Code::InvalidArgument, field);
  };
  refused([](RenderSettings& s) { s.extinction[0] = 1e39; }, "render.extinction[0] = 1e+39");
  refused([](RenderSettings& s) { s.wavelengths[0] = 1e-50; }, "render.wavelengths[0]");
  refused([](RenderSettings& s) { s.phase.g1 = 0.99999999; }, "render.phase.g1");
  refused([](RenderSettings& s) { s.phase.ff_n = 1 + 1e-8; }, "render.phase.ff_n");
  refused([](RenderSettings& s) { s.camera.eye[0] = 1e39; }, "render.camera.eye.x");
  refused(
      [](RenderSettings& s) {
        Light light;
        light.kind = LightKind::Point;
        light.position = {1e39, 0, 0};
        light.intensity = {1};
        s.lights.push_back(light);
      },
      "render.lights[0].position.x");
  refused(
      [](RenderSettings& s) {
        s.lights.push_back(Light{});
        s.lights[0].intensity = {1e39};
      },
      "render.lights[0].intensity[0]");
}

}  // namespace
}  // namespace squall::clouds
