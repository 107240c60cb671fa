// Cloud benchmark: build time of a reference cumulus at N^3 effective resolution (OpenVDB on the
// host), render time and rays per second of squall's OpenCL ray marcher on the device, beside OpenVDB's own
// CPU volume renderer (tools::VolumeRender, what vdb_render uses) on the same grid, image and step.
// Usage: clouds_bench [N ...]   (default: 256 512). Image 256x256, step = 1 voxel, one directional light.
#include <openvdb/tools/RayIntersector.h>
#include <openvdb/tools/RayTracer.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bench_util.h"
#include "clouds/renderer.h"
#include "clouds/volume.h"
#include "runtime/runtime.h"

namespace squall::clouds {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// A cumulus about 1 km across: a flattened ellipsoid body, three turrets, two pyroclastic layers.
CloudModel reference_cumulus(int n) {
  CloudModel m;
  m.voxel_size = 1000.0 / n;
  m.skin = 3 * m.voxel_size;
  m.ellipsoids.push_back({{0, 0, 0}, {380, 300, 180}});
  m.spheres.push_back({{-120, 40, 150}, 170});
  m.spheres.push_back({{110, -30, 170}, 150});
  m.spheres.push_back({{20, 60, 260}, 120});
  m.pyroclastic.layers = 2;
  m.pyroclastic.amplitude = 45;
  m.pyroclastic.gamma = 0.8;
  m.pyroclastic.noise.frequency = 1.0 / 180;
  m.pyroclastic.noise.octaves = 4;
  m.max_active_voxels = 1ull << 32;
  return m;
}

constexpr int kImage = 256;
constexpr double kExtinction = 0.01, kAlbedo = 0.9;  // 1/m per unit density
const Vec3d kLight{0.5, -0.3, 0.8};

RenderSettings squall_settings(double dx, ShadowMode shadow, int shadow_map_nodes) {
  RenderSettings s;
  s.camera.eye = {0, -2000, 100};
  s.camera.look_at = {0, 0, 100};
  s.camera.up = {0, 0, 1};
  s.camera.vertical_fov_deg = 2 * std::atan(0.5 * 41.2136 / 50.0) * 180 / M_PI;  // OpenVDB's default camera
  s.camera.width = s.camera.height = kImage;
  s.step = dx;
  s.trilinear = true;
  s.min_transmittance = 1e-3;
  s.extinction = {kExtinction};
  s.albedo = {kAlbedo};
  s.phase.kind = PhaseKind::Uniform;
  Light sun;
  sun.direction = kLight;
  sun.intensity = {1.0};
  s.lights = {sun};
  s.shadow = shadow;
  s.shadow_map_size = {shadow_map_nodes, shadow_map_nodes, shadow_map_nodes};
  return s;
}

double openvdb_render_seconds(const openvdb::FloatGrid& grid, double dx) {
  using Intersector = openvdb::tools::VolumeRayIntersector<openvdb::FloatGrid>;
  openvdb::tools::Film film(kImage, kImage);
  // Looks along +y from (0, -2000, 100): rotate -z onto +y (90 degrees about x).
  openvdb::tools::PerspectiveCamera camera(film, openvdb::Vec3R(90, 0, 0), openvdb::Vec3R(0, -2000, 100));
  Intersector intersector(grid);
  openvdb::tools::VolumeRender<Intersector, openvdb::tools::BoxSampler> renderer(intersector, camera);
  renderer.setLightDir(kLight[0], kLight[1], kLight[2]);
  renderer.setLightColor(1, 1, 1);
  renderer.setPrimaryStep(1.0);  // voxels
  renderer.setShadowStep(1.0);
  const double sigma = kExtinction * dx;  // per voxel of path
  renderer.setScattering(kAlbedo * sigma, kAlbedo * sigma, kAlbedo * sigma);
  renderer.setAbsorption((1 - kAlbedo) * sigma, (1 - kAlbedo) * sigma, (1 - kAlbedo) * sigma);
  renderer.setLightGain(0);
  renderer.setCutOff(0.005);
  return bench::median_seconds([&] { renderer.render(true); }, 1);
}

void run(Runtime& runtime, int n) {
  auto start = std::chrono::steady_clock::now();
  CloudVolume volume = build_cloud(reference_cumulus(n));
  double build = seconds_since(start);
  const auto& s = volume.stats;
  std::printf("N=%d: voxel %.2f m, build %.2f s, %llu active voxels, %.1f MB sparse vs %.1f MB dense (%.2f%%)\n", n,
              1000.0 / n, build, (unsigned long long)s.active_voxels, s.bytes / 1e6, s.dense_bytes / 1e6,
              100 * s.fill_ratio());
  start = std::chrono::steady_clock::now();
  DeviceVolume device = upload_volume(runtime, volume);
  double upload = seconds_since(start);
  std::printf("  NanoVDB conversion + upload %.2f s, %.1f MB on the device\n", upload, device.device_bytes / 1e6);
  CloudRenderer renderer(runtime);
  const double dx = volume.density->voxelSize()[0];
  const double rays = double(kImage) * kImage;
  for (int nodes : {64, 128, 0}) {  // 0: direct shadow rays
    RenderSettings settings =
        squall_settings(dx, nodes ? ShadowMode::DeepShadowMap : ShadowMode::Direct, nodes ? nodes : 2);
    double t = bench::median_seconds([&] { renderer.render(device, settings); }, 3);
    std::string mode = nodes ? "sparse DSM " + std::to_string(nodes) + "^3" : std::string("direct");
    std::printf("  squall OpenCL render (%s shadows): %.3f s, %.3g rays/s\n", mode.c_str(), t, rays / t);
  }
  double vdb = openvdb_render_seconds(*volume.density, dx);
  std::printf("  openvdb::tools::VolumeRender (direct shadows, CPU, TBB): %.3f s, %.3g rays/s\n", vdb, rays / vdb);
}

}  // namespace
}  // namespace squall::clouds

int main(int argc, char** argv) {
  using namespace squall;
  configure_kernel_cache();
  clouds::initialize_openvdb();
  RuntimeOptions options;
  options.program_prefixes = {"clouds/"};
  Runtime runtime(options);
  runtime.build_programs();
  std::vector<int> sizes;
  for (int i = 1; i < argc; ++i) sizes.push_back(std::atoi(argv[i]));
  if (sizes.empty()) sizes = {256, 512};
  std::printf("device: %s; image %dx%d, step 1 voxel\n", runtime.device_info().name.c_str(), clouds::kImage,
              clouds::kImage);
  for (int n : sizes) clouds::run(runtime, n);
  return 0;
}
