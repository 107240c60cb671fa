// Cloud benchmark, in one run on the same machine:
// (1) the reference fog volume a user would try first: four unioned spheres (radii 100, 70, 60, 50 m,
//     voxel 1 m) built by squall and written as .vdb, rendered at 512x512 with step 1 voxel and shadow step 3
//     voxels by squall (direct shadows, and a 64^3 deep shadow map) and by OpenVDB's `vdb_render`
//     executable on that .vdb (same camera, image, steps, light, coefficients and rays' end), squall's
//     direct shadows with its own default end too, each against the exact march (shadow step 1 voxel);
// (2) build time of a reference cumulus at N^3 effective resolution (OpenVDB on the host), render time and
//     rays per second of squall's OpenCL ray marcher on the device, beside OpenVDB's own CPU volume
//     renderer (tools::VolumeRender, what vdb_render uses) linked in, on the same grid, image, step and
//     rays' end.
// Usage: clouds_bench [--device auto|cpu|gpu|NAME] [--image WxH] [--kernel-dir DIR] [N ...]
//   N: the cumuli of (2) (default: 256 512; 0: part (1) alone); --image: the image of (2) (default 256x256;
//   1920x1080 for the goal on a GPU, whose frames/s it prints); DIR: kernels from DIR, e.g. another commit's,
//   not the embedded ones. (2): step = 1 voxel, one directional light.
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <openvdb/tools/RayIntersector.h>
#include <openvdb/tools/RayTracer.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
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

// The image of (2): --image. OpenVDB's camera spans the film's width with its aperture and squall's the
// height with its field of view, so only square images frame the same view (the timings compare either way).
struct ImageSize {
  int width = 256, height = 256;
};
ImageSize g_image;
constexpr double kExtinction = 0.01, kAlbedo = 0.9;  // 1/m per unit density
// OpenVDB's cut-off (VolumeRender::setCutOff, vdb_render's -cutoff, 0.005 by default) ends a ray where the
// squared length of its RGB transmittance falls below it, and skips samples of lower density: with equal RGB
// coefficients (a grey medium) at T = sqrt(cut-off / 3) = 0.041, not at 0.005. squall's rays end at that transmittance
// (min_transmittance) where they are compared with OpenVDB's, so that both march as far.
constexpr double kCutOff = 0.005;
const double kCutOffTransmittance = std::sqrt(kCutOff / 3);
constexpr double kSquallMinTransmittance = 1e-4;  // squall's default, for its cost and the exact march
const Vec3d kLight{0.5, -0.3, 0.8};

RenderSettings squall_settings(double dx, ShadowMode shadow, int shadow_map_nodes) {
  RenderSettings s;
  s.camera.eye = {0, -2000, 100};
  s.camera.look_at = {0, 0, 100};
  s.camera.up = {0, 0, 1};
  s.camera.vertical_fov_deg = 2 * std::atan(0.5 * 41.2136 / 50.0) * 180 / M_PI;  // OpenVDB's default camera
  s.camera.width = g_image.width;
  s.camera.height = g_image.height;
  s.step = dx;
  s.trilinear = true;
  s.min_transmittance = kCutOffTransmittance;
  s.extinction = {kExtinction};
  s.albedo = {kAlbedo};
  s.phase.kind = PhaseKind::Uniform;
  Light sun;
  sun.direction = kLight;
  sun.intensity = {1.0};
  s.lights = {sun};
  s.shadow = shadow;
  s.shadow_map_size = {shadow_map_nodes, shadow_map_nodes, shadow_map_nodes};
  s.shadow_step = dx;  // as VolumeRender below: shadow rays of one-voxel steps, trilinear
  s.shadow_trilinear = true;
  return s;
}

double openvdb_render_seconds(const openvdb::FloatGrid& grid, double dx) {
  using Intersector = openvdb::tools::VolumeRayIntersector<openvdb::FloatGrid>;
  openvdb::tools::Film film(g_image.width, g_image.height);
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
  renderer.setCutOff(kCutOff);
  return bench::median_seconds([&] { renderer.render(true); }, 1);
}

// ---- (1) the four-sphere fog volume against the vdb_render executable ----

constexpr int kFogImage = 512;
const Vec3d kFogEye{0, -700, 60}, kFogCenter{0, 0, 20};

CloudModel four_spheres() {
  CloudModel m;
  m.voxel_size = 1;
  m.skin = 3;
  m.spheres = {{{0, 0, 0}, 100}, {{120, 10, 30}, 70}, {{-110, -20, 20}, 60}, {{20, 30, 110}, 50}};
  m.max_active_voxels = 1ull << 32;
  return m;
}

RenderSettings fog_settings(ShadowMode shadow, double shadow_step, double extinction, double min_transmittance) {
  RenderSettings s = squall_settings(1.0, shadow, 64);
  s.camera.eye = kFogEye;
  s.camera.look_at = kFogCenter;
  s.camera.vertical_fov_deg = 40;
  s.camera.width = s.camera.height = kFogImage;
  s.shadow_step = shadow_step;
  s.min_transmittance = min_transmittance;
  s.extinction = {extinction};
  return s;
}

// Median wall time of `vdb_render` (all cores) on the file, same view, steps and coefficients.
double vdb_render_seconds(const std::string& vdb, const std::string& image, double extinction) {
  const double scatter = kAlbedo * extinction, absorb = (1 - kAlbedo) * extinction;
  char command[1024];
  std::snprintf(command, sizeof command,
                "vdb_render %s %s -res %dx%d -translate %g,%g,%g -lookat %g,%g,%g -up 0,0,1 -fov 40 -step 1 "
                "-shadowstep 3 -light %g,%g,%g,1,1,1 -scatter %g,%g,%g -absorb %g,%g,%g -gain 0 -cutoff %g "
                "-cpus 0 > /dev/null 2>&1",
                vdb.c_str(), image.c_str(), kFogImage, kFogImage, kFogEye[0], kFogEye[1], kFogEye[2], kFogCenter[0],
                kFogCenter[1], kFogCenter[2], kLight[0], kLight[1], kLight[2], scatter, scatter, scatter, absorb,
                absorb, absorb, kCutOff);
  int status = 0;
  const double t = bench::median_seconds([&] { status = std::system(command); }, 3);
  if (status != 0) {
    std::printf("  vdb_render failed (exit %d): %s\n", status, command);
    return 0;
  }
  return t;
}

double mean_abs_relative(const Image& a, const Image& b) {
  double sum = 0, ref = 0;
  for (size_t k = 0; k < size_t(a.width) * a.height; ++k) {  // the first radiance plane
    sum += std::abs(a.data[k] - b.data[k]);
    ref += std::abs(b.data[k]);
  }
  return sum / ref;
}

// Pearson correlation of squall's first radiance plane with the R channel of vdb_render's EXR (same pixels,
// row 0 at the top in both): the two renderers scale radiance differently, the picture must agree.
double correlation_with(const Image& a, const std::string& exr) {
  Imf::InputFile file(exr.c_str());
  const Imath::Box2i w = file.header().dataWindow();
  const int nx = w.max.x - w.min.x + 1, ny = w.max.y - w.min.y + 1;
  if (nx != a.width || ny != a.height || !file.header().channels().findChannel("R")) return NAN;
  std::vector<float> r(size_t(nx) * ny);
  Imf::FrameBuffer frame;
  char* base = reinterpret_cast<char*>(r.data()) - (ptrdiff_t(w.min.x) + ptrdiff_t(w.min.y) * nx) * sizeof(float);
  frame.insert("R", Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * nx));
  file.setFrameBuffer(frame);
  file.readPixels(w.min.y, w.max.y);
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  const double n = double(r.size());
  for (size_t k = 0; k < r.size(); ++k) {
    sa += a.data[k], sb += r[k], saa += double(a.data[k]) * a.data[k], sbb += double(r[k]) * r[k];
    sab += double(a.data[k]) * r[k];
  }
  return (sab - sa * sb / n) / std::sqrt((saa - sa * sa / n) * (sbb - sb * sb / n));
}

double mean_ratio(const Image& a, const Image& b) {
  double sa = 0, sb = 0;
  for (size_t k = 0; k < size_t(a.width) * a.height; ++k) sa += a.data[k], sb += b.data[k];
  return sa / sb;
}

void run_fog(Runtime& runtime) {
  CloudVolume volume = build_cloud(four_spheres());
  const std::string vdb = "/tmp/squall_clouds_bench_fog.vdb";
  std::ofstream(vdb, std::ios::binary) << write_vdb(volume);
  std::printf("four spheres, voxel 1 m: %llu active voxels, written to %s; %dx%d, step 1 voxel, shadow step 3\n",
              (unsigned long long)volume.stats.active_voxels, vdb.c_str(), kFogImage, kFogImage);
  DeviceVolume device = upload_volume(runtime, volume);
  CloudRenderer renderer(runtime);
  for (double extinction : {0.01, 0.1}) {  // 1/m: optical depth 2 or 20 across the big sphere
    Image exact, fast, fast_trilinear, dsm_image, unshadowed, strict, strict_trilinear;
    auto render = [&](ShadowMode mode, double shadow_step, bool trilinear, double min_transmittance, Image* out) {
      RenderSettings settings = fog_settings(mode, shadow_step, extinction, min_transmittance);
      settings.shadow_trilinear = trilinear;
      return bench::median_seconds([&] { *out = renderer.render(device, settings); }, 3);
    };
    const double cut = kCutOffTransmittance, own = kSquallMinTransmittance;
    renderer.set_work_schedule(WorkSchedule::WorkGroups);  // a GPU's way, for comparison
    Image direct_groups, dsm_groups;
    const double direct_in_groups = render(ShadowMode::Direct, 3, false, cut, &direct_groups);
    const double dsm_in_groups = render(ShadowMode::DeepShadowMap, 3, false, cut, &dsm_groups);
    renderer.set_work_schedule(WorkSchedule::Auto);
    const double direct = render(ShadowMode::Direct, 3, false, cut, &fast);
    const double direct_trilinear = render(ShadowMode::Direct, 3, true, cut, &fast_trilinear);
    const double dsm = render(ShadowMode::DeepShadowMap, 3, false, cut, &dsm_image);
    const double primary = render(ShadowMode::None, 3, false, cut, &unshadowed);
    const double direct_strict = render(ShadowMode::Direct, 3, false, own, &strict);
    const double trilinear_strict = render(ShadowMode::Direct, 3, true, own, &strict_trilinear);
    render(ShadowMode::Direct, 1, true, own, &exact);  // the exact march: every voxel, trilinear, to T = 1e-4
    const double vdb_s = vdb_render_seconds(vdb, "/tmp/squall_clouds_bench_fog.exr", extinction);
    std::printf(
        "  extinction %.2f /m, rays ending at T = %.3f as OpenVDB's: squall direct %.3f s (trilinear shadows %.3f "
        "s), DSM 64^3 %.3f s, no shadows %.3f s; vdb_render %.3f s (file read included)\n",
        extinction, cut, direct, direct_trilinear, dsm, primary, vdb_s);
    std::printf("    rays ending at squall's default T = %g: direct %.3f s (trilinear shadows %.3f s)\n", own,
                direct_strict, trilinear_strict);
    std::printf(
        "    in work-groups of 64 items: direct %.3f s, DSM %.3f s (the device's schedule takes %.2f and %.2f of "
        "that; same images: %s)\n",
        direct_in_groups, dsm_in_groups, direct / direct_in_groups, dsm / dsm_in_groups,
        direct_groups.data == fast.data && dsm_groups.data == dsm_image.data ? "yes" : "NO");
    std::printf(
        "    vdb_render / squall: direct %.2f (trilinear %.2f; goal >= 1), DSM %.2f (goal >= 2); correlation of the "
        "images (squall direct, vdb_render) %.4f\n",
        vdb_s / direct, vdb_s / direct_trilinear, vdb_s / dsm,
        correlation_with(fast, "/tmp/squall_clouds_bench_fog.exr"));
    std::printf(
        "    against the exact march (shadow step 1 voxel, trilinear, to T = %g): mean |dL| / mean L = %.2e direct, "
        "%.2e trilinear shadows, %.2e DSM, %.2e and %.2e to T = %g; mean L ratio %.4f direct, %.4f DSM\n",
        own, mean_abs_relative(fast, exact), mean_abs_relative(fast_trilinear, exact),
        mean_abs_relative(dsm_image, exact), mean_abs_relative(strict, exact),
        mean_abs_relative(strict_trilinear, exact), own, mean_ratio(fast, exact), mean_ratio(dsm_image, exact));
  }
  std::printf("\n");
}

// ---- (2) the reference cumulus against VolumeRender linked in ----

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
  const double rays = double(g_image.width) * g_image.height;
  for (int nodes : {64, 128, 0}) {  // 0: direct shadow rays
    RenderSettings settings =
        squall_settings(dx, nodes ? ShadowMode::DeepShadowMap : ShadowMode::Direct, nodes ? nodes : 2);
    double t = bench::median_seconds([&] { renderer.render(device, settings); }, 3);
    std::string mode = nodes ? "sparse DSM " + std::to_string(nodes) + "^3" : std::string("direct");
    std::printf("  squall OpenCL render (%s shadows): %.3f s, %.3g rays/s, %.2f frames/s\n", mode.c_str(), t, rays / t,
                1 / t);
    if (nodes) {  // a stored volume keeps its map: the next frames from other cameras only march the rays
      DeviceVolume stored = device;
      stored.kept_shadow_map = std::make_shared<KeptShadowMap>();
      renderer.render(stored, settings);
      int frame = 0;
      double kept = bench::median_seconds(
          [&] {
            settings.camera.eye[0] += 1.0 * ++frame;  // a camera moving about the volume
            renderer.render(stored, settings);
          },
          3);
      std::printf("    the next frames of a stored volume, from other cameras, its map kept: %.3f s (%.1fx)\n", kept,
                  t / kept);
    }
    if (g_image.width == 1920 && g_image.height == 1080 && nodes != 128) {
      char goal[128];
      std::snprintf(goal, sizeof goal, "cloud 1920x1080, N=%d cumulus, %s shadows, rays to T = %.3f", n, mode.c_str(),
                    kCutOffTransmittance);
      bench::print_gpu_goal(goal, 1 / t, 30, "frames/s");
    }
  }
  double vdb = openvdb_render_seconds(*volume.density, dx);
  std::printf("  openvdb::tools::VolumeRender (direct shadows, CPU, TBB): %.3f s, %.3g rays/s\n", vdb, rays / vdb);
}

}  // namespace
}  // namespace squall::clouds

int bench_main(int argc, char** argv) {
  using namespace squall;
  configure_kernel_cache();
  clouds::initialize_openvdb();
  RuntimeOptions options;
  options.program_prefixes = {"clouds/"};
  std::vector<int> sizes;
  for (int i = 1; i < argc; ++i)
    if (!std::strcmp(argv[i], "--kernel-dir") && i + 1 < argc)
      options.kernel_dir = argv[++i];  // other kernels, same host code
    else if (!std::strcmp(argv[i], "--device") && i + 1 < argc)
      options.device = argv[++i];
    else if (!std::strcmp(argv[i], "--image") && i + 1 < argc)
      std::sscanf(argv[++i], "%dx%d", &clouds::g_image.width, &clouds::g_image.height);
    else
      sizes.push_back(std::atoi(argv[i]));
  if (clouds::g_image.width < 1 || clouds::g_image.height < 1) {
    std::fprintf(stderr, "clouds_bench: --image WxH needs two positive sizes\n");
    return 2;
  }
  Runtime runtime(options);
  runtime.build_programs();
  if (sizes.empty()) sizes = {256, 512};
  std::printf("device: %s; image of the cumuli %dx%d, step 1 voxel\n", runtime.device_info().name.c_str(),
              clouds::g_image.width, clouds::g_image.height);
  clouds::run_fog(runtime);
  for (int n : sizes)
    if (n > 0) clouds::run(runtime, n);  // 0: the fog volume alone
  return 0;
}

int main(int argc, char** argv) {
  return squall::bench::guarded_main(argv[0], [&] { return bench_main(argc, argv); });
}
