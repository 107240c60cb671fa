// The OpenCL ray marcher on PoCL against closed forms: slab transmittance and radiance for any step,
// thermal emission, phase-function normalization, Planck's law. The ray march and phase functions are
// those of appendix A of J. Tessendorf and M. Kowalski, "Resolution Independent Volumes" (SIGGRAPH course
// notes 2010/2011).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <latch>
#include <memory>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include "clouds/render_params.h"
#include "clouds/renderer.h"
#include "clouds/volume.h"
#include "common/cancel.h"
#include "common/limits.h"
#include "runtime/buffer_pool.h"
#include "support/expect_error.h"
#include "support/test_runtime.h"
#include "support/worst.h"
#include <openvdb/tools/Interpolation.h>

namespace squall::clouds {
namespace {

using test::expect_error;

constexpr double kPi = 3.14159265358979323846;

// A slab of constant density rho over voxels x, y in [-64, 63], z in [0, nz - 1] (voxel size dx), as
// active tiles or (voxelized) leaves, optionally with a temperature grid.
CloudVolume slab(double dx, int nz, float rho, bool voxelize, float temperature = 0) {
  initialize_openvdb();
  CloudVolume v;
  v.density = openvdb::FloatGrid::create(0.0f);
  v.density->setTransform(openvdb::math::Transform::createLinearTransform(dx));
  v.density->setName("density");
  openvdb::CoordBBox box(openvdb::Coord(-64, -64, 0), openvdb::Coord(63, 63, nz - 1));
  v.density->tree().fill(box, rho, true);
  if (voxelize) v.density->tree().voxelizeActiveTiles();
  if (temperature > 0) {
    v.temperature = openvdb::FloatGrid::create(0.0f);
    v.temperature->setTransform(v.density->transform().copy());
    v.temperature->tree().fill(box, temperature, true);
  }
  v.stats = volume_stats(*v.density);
  return v;
}

// A camera below the slab looking up +z with a narrow field, so every ray crosses both faces.
RenderSettings slab_camera(double step) {
  RenderSettings s;
  s.camera.eye = {0.3, -0.2, -40};
  s.camera.look_at = {0.3, -0.2, 0};
  s.camera.up = {0, 1, 0};
  s.camera.vertical_fov_deg = 4;
  s.camera.width = 16;
  s.camera.height = 12;
  s.step = step;
  s.min_transmittance = 0;
  s.shadow = ShadowMode::None;
  return s;
}

// The image-plane offsets (sx, sy) of pixel (x, y)'s ray, as the kernel builds it: its direction is
// forward + sx right + sy up, normalized.
std::pair<double, double> pixel_offsets(const RenderSettings& s, int x, int y) {
  double t = std::tan(s.camera.vertical_fov_deg * kPi / 360), aspect = double(s.camera.width) / s.camera.height;
  return {(2 * (x + 0.5) / s.camera.width - 1) * t * aspect, (1 - 2 * (y + 0.5) / s.camera.height) * t};
}

// cos of the angle between pixel (x, y)'s ray and the view axis.
double pixel_cos(const RenderSettings& s, int x, int y) {
  const auto [sx, sy] = pixel_offsets(s, x, y);
  return 1 / std::sqrt(1 + sx * sx + sy * sy);
}

TEST(Render, SlabTransmittanceIsExpMinusSigmaLForAnyStep) {
  const double dx = 0.5, L = 20 * dx, rho = 0.6, kappa = 0.25;  // sigma L = kappa rho L = 1.5
  CloudRenderer renderer(test::runtime());
  for (bool voxelize : {false, true}) {
    DeviceVolume dv = upload_volume(test::runtime(), slab(dx, 20, float(rho), voxelize));
    for (double step : {2.0 * L, 0.5 * L, 0.1 * L, 0.013 * L}) {
      for (int substeps : {1, 3}) {
        RenderSettings s = slab_camera(step);
        s.substeps = substeps;
        s.extinction = {kappa};
        s.albedo = {0.8};
        // One directional light, no shadowing, uniform phase: L = albedo E (1/4pi) (1 - exp(-tau)).
        s.phase.kind = PhaseKind::Uniform;
        Light sun;
        sun.direction = {0.2, 0.1, -1};
        sun.intensity = {1000};
        s.lights = {sun};
        Image img = renderer.render(dv, s);
        double worst_t = 0, worst_l = 0;
        for (int y = 0; y < s.camera.height; ++y)
          for (int x = 0; x < s.camera.width; ++x) {
            double tau = kappa * rho * L / pixel_cos(s, x, y);
            double T = std::exp(-tau);
            double radiance = 0.8 * 1000 / (4 * kPi) * (1 - T);
            worst_t = squall::test::worse(worst_t, std::abs(img.at(1, x, y) - T));
            worst_l = squall::test::worse(worst_l, std::abs(img.at(0, x, y) - radiance) / radiance);
          }
        EXPECT_LT(worst_t, 1e-3) << "step " << step << " substeps " << substeps << " voxelized " << voxelize;
        EXPECT_LT(worst_l, 1e-3) << "step " << step << " substeps " << substeps << " voxelized " << voxelize;
        std::printf("slab step %.3f m substeps %d %s: max |T - exp(-sigma L)| = %.2e, max rel L error %.2e\n", step,
                    substeps, voxelize ? "leaves" : "tiles", worst_t, worst_l);
      }
    }
  }
}

// Direct shadows in a slab lit from below (the camera's side): a sample at depth s along a ray of cosine
// mu_c sees the light through the column rho s mu_c / mu_L, so (phase p, 1 / (4 pi) when uniform)
//   L = albedo E p (1 - exp(-tau (1 + mu_c / mu_L))) / (1 + mu_c / mu_L),  tau = kappa rho L / mu_c.
// The shadow march is exact for constant density whatever its step (its steps end at the tree's nodes).
// The primary march samples the light's transmittance at one jittered point per step: unbiased to
// O((kappa rho h)^2), noisy per pixel, so the steps are short and the image mean is compared.
double lit_from_below(double tau, double mu_c, double mu_l, double albedo, double e, double phase) {
  const double k = 1 + mu_c / mu_l;
  return albedo * e * phase * (1 - std::exp(-tau * k)) / k;
}

// The image's mean radiance against the closed form's mean over the same pixels, and the worst pixel;
// phase(mu_c): the phase function's value on the ray of cosine mu_c.
std::pair<double, double> slab_errors(
    const Image& img, const RenderSettings& s, double tau_axis, double mu_l,
    const std::function<double(double)>& phase = [](double) { return 1 / (4 * kPi); }) {
  double got = 0, want = 0, worst = 0;
  for (int y = 0; y < s.camera.height; ++y)
    for (int x = 0; x < s.camera.width; ++x) {
      const double mu_c = pixel_cos(s, x, y);
      const double w = lit_from_below(tau_axis / mu_c, mu_c, mu_l, 0.8, 1000, phase(mu_c));
      got += img.at(0, x, y), want += w;
      worst = squall::test::worse(worst, std::abs(img.at(0, x, y) - w) / w);
    }
  return {std::abs(got - want) / want, worst};
}

// The slab of the tests below, 20 voxels of 0.5 m, density 0.6, and the settings that light it: extinction 0.25,
// albedo 0.8 (as slab_errors expects), one directional light of 1000 from `toward_light`, direct shadows, steps
// of a hundredth of the slab.
constexpr double kSlabDx = 0.5, kSlabL = 20 * kSlabDx, kSlabRho = 0.6, kSlabKappa = 0.25;
RenderSettings lit_slab(const Vec3d& toward_light, PhaseKind phase) {
  RenderSettings s = slab_camera(0.01 * kSlabL);
  s.extinction = {kSlabKappa};
  s.albedo = {0.8};
  s.phase.kind = phase;
  Light sun;
  sun.direction = toward_light;
  sun.intensity = {1000};
  s.lights = {sun};
  s.shadow = ShadowMode::Direct;
  return s;
}

TEST(Render, DirectShadowsOfASlabMatchTheClosedFormForAnyShadowStep) {
  const double dx = kSlabDx, L = kSlabL, rho = kSlabRho, kappa = kSlabKappa;
  CloudRenderer renderer(test::runtime());
  DeviceVolume dv = upload_volume(test::runtime(), slab(dx, 20, float(rho), false));
  RenderSettings s = lit_slab({0.3, 0.1, -1}, PhaseKind::Uniform);  // below the slab
  const double mu_l = 1 / std::sqrt(0.3 * 0.3 + 0.1 * 0.1 + 1);
  for (double shadow_step : {0.01 * L, 0.0 /* 3 steps */, 0.7 * L, 4 * L}) {
    s.shadow_step = shadow_step;
    const auto [mean, worst] = slab_errors(renderer.render(dv, s), s, kappa * rho * L, mu_l);
    EXPECT_LT(mean, 1e-3) << "shadow step " << shadow_step;
    EXPECT_LT(worst, 1e-2) << "shadow step " << shadow_step;
    std::printf("slab, shadow step %.2f m: mean radiance error %.2e, worst pixel %.2e\n", shadow_step, mean, worst);
  }
  // A slab 40 optical depths thick: with min_transmittance 1e-2 the shadow marches stop at the column
  // -ln(1e-2) / kappa (and the primary rays at T = 1e-2); the radiance stays within 1e-2 of the exact value
  // on average, 3e-2 at every pixel (2.0e-2 measured).
  DeviceVolume thick = upload_volume(test::runtime(), slab(dx, 20, float(40 / (kappa * L)), false));
  s.step = 0.002 * L;
  s.shadow_step = 0;
  s.min_transmittance = 1e-2;
  const auto [mean, worst] = slab_errors(renderer.render(thick, s), s, 40, mu_l);
  EXPECT_LT(mean, 1e-2);
  EXPECT_LT(worst, 3e-2);
  std::printf("thick slab, min_transmittance 1e-2: mean radiance error %.2e, worst pixel %.2e\n", mean, worst);
}

// A light's direction is only a direction: scaled down to 1e-300 (whose squared norm underflows in double) it
// lights the slab exactly as at unit scale.
TEST(Render, ALightsDirectionCountsAtAnyScale) {
  CloudRenderer renderer(test::runtime());
  DeviceVolume dv = upload_volume(test::runtime(), slab(kSlabDx, 20, float(kSlabRho), false));
  const std::vector<float> unit = renderer.render(dv, lit_slab({0.3, 0.1, -1}, PhaseKind::Uniform)).data;
  const double scale = 1e-300;
  const RenderSettings s = lit_slab({0.3 * scale, 0.1 * scale, -scale}, PhaseKind::Uniform);
  validate(s, "settings");
  EXPECT_EQ(renderer.render(dv, s).data, unit);
}

// The slab lit from straight below, behind the camera, with a strongly forward-scattering phase
// (Henyey-Greenstein, g = 0.8, eq A.8): the light reaches the camera by scattering back, at the angle
// Theta with cos Theta = -mu_c between the light's travel and the camera's, where p is about 700 times weaker
// than at -Theta.
TEST(Render, ALightBehindTheCameraIsSeenByBackscatter) {
  const double g = 0.8;
  CloudRenderer renderer(test::runtime());
  DeviceVolume dv = upload_volume(test::runtime(), slab(kSlabDx, 20, float(kSlabRho), false));
  RenderSettings s = lit_slab({0, 0, -1}, PhaseKind::HenyeyGreenstein);
  s.phase.g1 = g;
  auto hg = [&](double mu) { return (1 - g * g) / (4 * kPi * std::pow(1 + g * g - 2 * g * mu, 1.5)); };
  const auto [mean, worst] =
      slab_errors(renderer.render(dv, s), s, kSlabKappa * kSlabRho * kSlabL, 1, [&](double mu_c) { return hg(-mu_c); });
  std::printf("slab lit from behind the camera, g = %.1f: mean radiance error %.2e, worst pixel %.2e\n", g, mean,
              worst);
  EXPECT_LT(mean, 1e-3);
  EXPECT_LT(worst, 1e-2);
}

// Composite Simpson's rule for f over [a, b] in n (even) intervals.
double simpson(const std::function<double(double)>& f, double a, double b, int n) {
  const double h = (b - a) / n;
  double sum = f(a) + f(b);
  for (int i = 1; i < n; ++i) sum += (i % 2 ? 4 : 2) * f(a + i * h);
  return sum * h / 3;
}

// A point light of intensity I inside the slab, with direct shadows: a sample at distance d from the light,
// u past the slab's near face, is lit through the column rho d, so along a pixel's ray
//   L = albedo kappa rho I integral of p(dir . n_L) exp(-kappa rho (u + d)) / max(d, r)^2 ds over the slab,
// r half a voxel (within r the inverse square is held at its value at r: along a ray through a point light
// the integral of 1 / d^2 diverges), here by Simpson's rule in double. The light is on the axis of an image of
// odd size, so that the centre pixel's ray runs through it (its neighbours' pass 0.28 m from it, just outside
// r), and its intensity is the largest allowed; the phase is Henyey-Greenstein (g = 0.5, eq A.8), so the
// direction toward the light counts as well as its distance. Steps of a fiftieth of a voxel, and of one voxel
// (three seeds), where the light's peak and the phase's turn from forward to backward fall within a step or
// two: the equiangular samples (render.cl's sq_point_light_inscatter) keep every pixel within 3%, and the ray
// through the light within 1e-3 (one sample a step was 37% off there).
TEST(Render, APointLightLightsTheSlabAsTheInverseSquareOutsideHalfAVoxel) {
  const double g = 0.5, intensity = 1e20, r = kSlabDx / 2, sigma = kSlabKappa * kSlabRho;
  const Vec3d light{0.3, -0.2, 4.75};
  CloudRenderer renderer(test::runtime());
  DeviceVolume dv = upload_volume(test::runtime(), slab(kSlabDx, 20, float(kSlabRho), false));
  RenderSettings s = lit_slab({0, 0, 1}, PhaseKind::HenyeyGreenstein);
  s.phase.g1 = g;
  s.camera.width = 15;
  s.camera.height = 11;
  s.lights[0].kind = LightKind::Point;
  s.lights[0].position = light;
  s.lights[0].intensity = {intensity};
  auto hg = [&](double mu) { return (1 - g * g) / (4 * kPi * std::pow(1 + g * g - 2 * g * mu, 1.5)); };
  const Vec3d& eye = s.camera.eye;
  for (const auto& [step, seed, bound] : {std::tuple{kSlabDx / 50, 1u, 5e-3}, std::tuple{kSlabDx, 1u, 3e-2},
                                          std::tuple{kSlabDx, 2u, 3e-2}, std::tuple{kSlabDx, 3u, 3e-2}}) {
    s.step = step;
    s.seed = seed;
    const Image img = renderer.render(dv, s);
    double worst = 0, centre = 0;
    for (int y = 0; y < s.camera.height; ++y)
      for (int x = 0; x < s.camera.width; ++x) {
        const auto [sx, sy] = pixel_offsets(s, x, y);  // right is -x and up +y for this camera
        const double n = std::sqrt(sx * sx + sy * sy + 1);
        const Vec3d dir{-sx / n, sy / n, 1 / n};
        const double s_in = (-kSlabDx / 2 - eye[2]) / dir[2], s_out = (kSlabL - kSlabDx / 2 - eye[2]) / dir[2];
        auto lit = [&](double t) {
          Vec3d to;
          for (int a = 0; a < 3; ++a) to[a] = light[a] - (eye[a] + t * dir[a]);
          const double d = std::hypot(to[0], to[1], to[2]);
          const double mu = d > 0 ? (dir[0] * to[0] + dir[1] * to[1] + dir[2] * to[2]) / d : dir[2];
          return hg(mu) * std::exp(-sigma * (t - s_in + d)) / std::pow(std::max(d, r), 2);
        };
        const double want = 0.8 * sigma * intensity * simpson(lit, s_in, s_out, 100000);
        const double error = std::abs(img.at(0, x, y) - want) / want;
        worst = squall::test::worse(worst, error);
        if (x == 7 && y == 5) centre = error;
      }
    std::printf(
        "point light in the slab, step %.2f m, seed %u: worst pixel's radiance error %.2e, the ray "
        "through the light's %.2e\n",
        step, seed, worst, centre);
    EXPECT_LT(worst, bound) << step << " " << seed;
    EXPECT_LT(centre, 1e-3) << step << " " << seed;
  }
}

// sq_to_light on the device (probe.cl's light_eval), a point light with r = 0.25 m (voxels of 0.5 m): at the
// light itself the direction +z and the scale 1 / r^2 (not 0 / 0), 0.1 m from it the direction toward it
// and 1 / r^2, 2 m from it 1 / d^2.
TEST(Render, APointLightsScaleIsHeldWithinHalfAVoxelAndFiniteAtTheLight) {
  Runtime& rt = test::runtime();
  CloudRenderParams p{};
  p.n_lights = 1;
  p.lights[0].kind = SQUALL_LIGHT_POINT;
  p.lights[0].position[0] = 1.5f, p.lights[0].position[1] = -2.0f, p.lights[0].position[2] = 3.25f;
  p.point_light_radius = 0.25f;
  const std::vector<float> x = {1.5f, -2.0f, 3.25f, 1.5f, -2.0f, 3.35f, 1.5f, -2.0f, 5.25f};
  cl::Buffer in = test::upload(x), out(rt.context(), CL_MEM_WRITE_ONLY, 12 * sizeof(float));
  Kernel<CloudRenderParams, cl_int, cl::Buffer, cl_int, cl::Buffer> light(rt, "clouds/probe.cl", "light_eval");
  light.launch(cl::NDRange(64), cl::NDRange(64), p, cl_int(0), in, cl_int(3), out);
  const std::vector<float> got = test::read<float>(out, 12);
  EXPECT_EQ(got, (std::vector<float>{0, 0, 1, 16, 0, 0, -1, 16, 0, 0, -1, 0.25f}));
}

// A point light's span on a sub-step (lights.h, through probe.cl's light_span_eval) against Simpson's rule
// in double, split at the held core's ends: G, the integral of g = 1 / max(b^2 + u^2, r^2) over the sub-step,
// and the offset du drawn for xi, at which the integral from the sub-step's start reaches xi G. Rays along +x
// from the origin, the light at (tc, b, 0) with r = 0.25 m: sub-steps across the light, inside its held core,
// beside it, and 100 m along rays toward lights 1e5 and 1e7 m away, where ray parameters counted from the
// light's nearest point would be rounded to a metre.
TEST(Render, APointLightsSpanIntegratesAndInvertsItsInverseSquare) {
  Runtime& rt = test::runtime();
  const double r = 0.25;
  CloudRenderParams p{};
  p.n_lights = 1;
  p.lights[0].kind = SQUALL_LIGHT_POINT;
  p.point_light_radius = float(r);
  struct Case {
    double tc, b, t0, len;
  };
  std::vector<Case> cases;
  for (double b : {0.0, r / 2, r, 10 * r})
    for (auto [from, len] : {std::pair{-0.3, 0.5}, std::pair{-0.1, 0.15}, std::pair{0.3, 0.5}})
      cases.push_back({5, b, 5 + from, len});
  for (double tc : {1e5, 1e7})
    for (double len : {0.5, 0.05}) cases.push_back({tc, 3, 100, len});
  const std::vector<double> xis = {0, 0.3, 0.7, 1};
  auto integral = [&](const Case& k, double from, double to) {  // of g over [from, to], split at the core
    const double c = std::sqrt(std::max(r * r - k.b * k.b, 0.0));
    auto g = [&](double t) { return 1 / std::max(k.b * k.b + (t - k.tc) * (t - k.tc), r * r); };
    std::vector<double> cuts = {from};
    for (double cut : {k.tc - c, k.tc + c})
      if (cut > from && cut < to) cuts.push_back(cut);
    cuts.push_back(to);
    double sum = 0;
    for (size_t i = 0; i + 1 < cuts.size(); ++i) sum += simpson(g, cuts[i], cuts[i + 1], 2000);
    return sum;
  };
  Kernel<CloudRenderParams, cl_int, cl::Buffer, cl_int, cl::Buffer> span(rt, "clouds/probe.cl", "light_span_eval");
  int n = 0;
  for (const Case& k : cases) {
    // The light in world metres, the rays along +x; its position's float rounding is the test's: tc as a float.
    p.lights[0].position[0] = float(k.tc), p.lights[0].position[1] = float(k.b), p.lights[0].position[2] = 0;
    std::vector<float> in;
    for (double xi : xis) in.insert(in.end(), {0, 0, 0, 1, 0, 0, float(k.t0), float(k.len), float(xi)});
    cl::Buffer rays = test::upload(in), out(rt.context(), CL_MEM_WRITE_ONLY, 2 * xis.size() * sizeof(float));
    span.launch(cl::NDRange(64), cl::NDRange(64), p, cl_int(0), rays, cl_int(xis.size()), out);
    const std::vector<float> got = test::read<float>(out, 2 * xis.size());
    const Case exact{double(float(k.tc)), double(float(k.b)), double(float(k.t0)), double(float(k.len))};
    const double G = integral(exact, exact.t0, exact.t0 + exact.len);
    for (size_t x = 0; x < xis.size(); ++x, ++n) {
      EXPECT_NEAR(got[2 * x] / G, 1.0, 1e-5) << "tc " << k.tc << " b " << k.b << " t0 " << k.t0;
      EXPECT_NEAR(integral(exact, exact.t0, exact.t0 + got[2 * x + 1]) / G, xis[x], 1e-5)
          << "tc " << k.tc << " b " << k.b << " t0 " << k.t0 << " xi " << xis[x];
    }
  }
  EXPECT_EQ(n, 64);
}

// A soft sphere cloud (no noise) of radius 6 m, voxel 0.25 m, skin 1.5 m.
CloudVolume soft_sphere() {
  CloudModel m;
  m.voxel_size = 0.25;
  m.skin = 1.5;
  m.spheres.push_back({{0, 0, 0}, 6});
  return build_cloud(m);
}

RenderSettings sphere_camera(double step) {
  RenderSettings s;
  s.camera.eye = {0, -25, 2};
  s.camera.look_at = {0, 0, 0};
  s.camera.up = {0, 0, 1};
  s.camera.vertical_fov_deg = 34;
  s.camera.width = 48;
  s.camera.height = 48;
  s.step = step;
  s.min_transmittance = 0;
  s.extinction = {0.4};
  s.albedo = {0.9};
  s.shadow = ShadowMode::None;
  return s;
}

double mean_channel(const Image& img, int channel) {
  double sum = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) sum += img.at(channel, x, y);
  return sum / (img.width * img.height);
}

// Jittered trilinear sampling: the image-mean transmittance does not depend on the step (the estimate of
// the optical depth is unbiased), here from 1/8 voxel to 4 voxels.
TEST(Render, JitteredTrilinearTransmittanceDoesNotDependOnStep) {
  CloudRenderer renderer(test::runtime());
  DeviceVolume dv = upload_volume(test::runtime(), soft_sphere());
  RenderSettings s = sphere_camera(0.25 / 8);
  s.trilinear = true;
  double reference = mean_channel(renderer.render(dv, s), 1);
  EXPECT_LT(reference, 0.8);  // the sphere covers much of the image
  for (double step : {0.125, 0.25, 0.5, 1.0}) {
    double mean = 0;
    for (uint32_t seed = 1; seed <= 4; ++seed) {
      s.step = step;
      s.seed = seed;
      mean += mean_channel(renderer.render(dv, s), 1) / 4;
    }
    std::printf("trilinear step %.3f m: mean T %.6f vs %.6f at 1/32 m\n", step, mean, reference);
    EXPECT_NEAR(mean, reference, 1e-3) << step;
  }
}

// -log T along the one ray of a 1 x 1 trilinear image from eye toward look_at (averaged over 4 seeds), and
// kappa times OpenVDB's own trilinear sampler (tools::BoxSampler) integrated finely along the same ray
// within the cells of the active voxels lo..hi, index [lo - 0.5, hi + 0.5) (the march's extent: the half
// voxel beyond, where trilinear density fades to the background, lies outside the grid's bounding box).
// The voxel size is 1 m: world = index space.
std::pair<double, double> trilinear_depths(const CloudVolume& v, const Vec3d& lo, const Vec3d& hi, const Vec3d& eye,
                                           const Vec3d& look_at) {
  const double kappa = 0.5;
  RenderSettings s = sphere_camera(0.02);
  s.camera.eye = eye, s.camera.look_at = look_at, s.camera.up = {0.3, 0.2, 1};
  s.camera.width = s.camera.height = 1;
  s.trilinear = true;
  s.extinction = {float(kappa)};
  CloudRenderer renderer(test::runtime());
  DeviceVolume dv = upload_volume(test::runtime(), v);
  double T = 0;
  for (uint32_t seed = 1; seed <= 4; ++seed) s.seed = seed, T += renderer.render(dv, s).at(1, 0, 0) / 4;
  openvdb::tools::GridSampler<openvdb::FloatGrid, openvdb::tools::BoxSampler> box(*v.density);
  Vec3d d{look_at[0] - eye[0], look_at[1] - eye[1], look_at[2] - eye[2]};
  const double norm = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]), ds = 1e-3;
  double column = 0;
  for (double t = 0.5 * ds; t < 200; t += ds) {
    const openvdb::Vec3d x(eye[0] + t * d[0] / norm, eye[1] + t * d[1] / norm, eye[2] + t * d[2] / norm);
    bool inside = true;
    for (int a = 0; a < 3; ++a) inside = inside && x[a] >= lo[a] - 0.5 && x[a] < hi[a] + 0.5;
    if (inside) column += box.wsSample(x) * ds;
  }
  std::printf("trilinear ray from (%.1f, %.1f, %.1f): optical depth %.5f, BoxSampler's %.5f\n", eye[0], eye[1], eye[2],
              -std::log(T), kappa * column);
  return {-std::log(T), kappa * column};
}

// Trilinear density as the march reads it (inside a leaf from its value table, inside a tile its value,
// across node faces a tree query per corner) against BoxSampler, in all directions: a density linear in i, j
// and k over 3 x 3 x 3 leaves (each axis its own slope, so a mixed-up corner shows), and a slab of
// constant density held as tiles. Equal to the jitter's noise (2e-5 here).
TEST(Render, TrilinearDensityMatchesOpenVdbsBoxSampler) {
  initialize_openvdb();
  CloudVolume linear;
  linear.density = openvdb::FloatGrid::create(0.0f);
  linear.density->setName("density");
  auto acc = linear.density->getAccessor();
  for (int i = 0; i < 24; ++i)
    for (int j = 0; j < 24; ++j)
      for (int k = 0; k < 24; ++k) acc.setValue(openvdb::Coord(i, j, k), 0.01f + 0.006f * i + 0.001f * j + 0.0003f * k);
  linear.stats = volume_stats(*linear.density);
  for (auto [eye, look_at] : {std::pair<Vec3d, Vec3d>{{-10, 3.3, 5.1}, {30, 17.2, 9.4}},
                              {{11.7, -12, 20.2}, {5.4, 40, 2.6}},
                              {{4.2, 8.9, 40}, {18.3, 13.1, -10}},
                              {{30, 30, 30}, {0.4, 2.2, 1.3}}}) {
    auto [depth, reference] = trilinear_depths(linear, {0, 0, 0}, {23, 23, 23}, eye, look_at);
    EXPECT_GT(reference, 0.1);  // the ray crosses the field
    EXPECT_NEAR(depth, reference, 2e-4 * reference) << eye[0] << ", " << eye[1] << ", " << eye[2];
  }
  const CloudVolume tiles = slab(1.0, 40, 0.05f, false);  // voxels x, y in [-64, 63], z in [0, 39]
  ASSERT_GT(tiles.density->tree().activeTileCount(), 0u);
  for (auto [eye, look_at] :
       {std::pair<Vec3d, Vec3d>{{-3.3, 2.1, -30}, {10.2, -5.7, 70}}, {{20.4, 50.1, 60}, {-11.3, -30.8, -20}}}) {
    auto [depth, reference] = trilinear_depths(tiles, {-64, -64, 0}, {63, 63, 39}, eye, look_at);
    EXPECT_GT(reference, 0.5);
    EXPECT_NEAR(depth, reference, 2e-4 * reference) << eye[0] << ", " << eye[1] << ", " << eye[2];
  }
}

// The deep shadow map (log T^L interpolated on a box grid) against a secondary march per sample, and the
// shadow march's own settings against each other.
TEST(Render, DeepShadowMapMatchesDirectShadowRays) {
  CloudRenderer renderer(test::runtime());
  DeviceVolume dv = upload_volume(test::runtime(), soft_sphere());
  RenderSettings s = sphere_camera(0.1);
  Light sun;
  sun.direction = {1, 0.3, 0.5};
  sun.intensity = {1000};
  s.lights = {sun};
  s.phase.kind = PhaseKind::HenyeyGreenstein;
  s.phase.g1 = 0.5;
  s.shadow = ShadowMode::Direct;
  Image direct = renderer.render(dv, s);
  s.shadow = ShadowMode::DeepShadowMap;
  s.shadow_map_size = {96, 96, 96};
  Image dsm = renderer.render(dv, s);
  s.shadow = ShadowMode::None;
  Image unshadowed = renderer.render(dv, s);
  double d = mean_channel(direct, 0), m = mean_channel(dsm, 0), u = mean_channel(unshadowed, 0);
  std::printf("mean radiance: direct %.4f, DSM %.4f, unshadowed %.4f\n", d, m, u);
  EXPECT_LT(d, 0.8 * u);  // self-shadowing matters in this scene
  EXPECT_NEAR(m / d, 1.0, 0.01);
  // Shadow marches sampling the nearest voxel (the default) against trilinear ones, and against one-voxel
  // shadow steps (the default is 3 steps): the same image mean within 1%.
  s.shadow = ShadowMode::Direct;
  s.shadow_trilinear = true;
  const double trilinear = mean_channel(renderer.render(dv, s), 0);
  s.shadow_step = 0.25;
  const double fine = mean_channel(renderer.render(dv, s), 0);
  std::printf("mean radiance: nearest-voxel shadows %.4f, trilinear %.4f, trilinear at one-voxel steps %.4f\n", d,
              trilinear, fine);
  EXPECT_NEAR(d / trilinear, 1.0, 0.01);
  EXPECT_NEAR(trilinear / fine, 1.0, 0.01);
}

// A sun and a deep shadow map of 48^3 nodes (442 368 bytes) over the soft sphere, seen by sphere_camera.
RenderSettings sunlit_sphere() {
  RenderSettings s = sphere_camera(0.1);
  Light sun;
  sun.direction = {1, 0.3, 0.5};
  sun.intensity = {1000};
  s.lights = {sun};
  s.shadow = ShadowMode::DeepShadowMap;
  s.shadow_map_size = {48, 48, 48};
  return s;
}

DeviceVolume stored_sphere() {
  DeviceVolume v = upload_volume(test::runtime(), soft_sphere());
  v.kept_shadow_map = std::make_shared<KeptShadowMap>();
  return v;
}

// A deep shadow map depends on the volume, the lights and the marches, not on the camera: renders of a
// stored volume from other cameras read the map of its first render and give the images of a volume that
// makes its own, bit for bit; another light or seed makes a new map.
TEST(Render, AStoredVolumesShadowMapServesEveryCamera) {
  CloudRenderer renderer(test::runtime());
  const DeviceVolume kept = stored_sphere(), fresh = upload_volume(test::runtime(), soft_sphere());
  RenderSettings s = sunlit_sphere();
  renderer.render(kept, s);
  auto expect_as_fresh = [&] { EXPECT_EQ(renderer.render(kept, s).data, renderer.render(fresh, s).data); };
  s.camera.eye = {-18, -14, 6};
  s.camera.width = 40;
  expect_as_fresh();
  EXPECT_EQ(kept.kept_shadow_map->made, 1u);
  s.lights[0].direction = {-1, 0.2, 0.6};
  expect_as_fresh();
  EXPECT_EQ(kept.kept_shadow_map->made, 2u);
  s.seed = 7;
  expect_as_fresh();
  EXPECT_EQ(kept.kept_shadow_map->made, 3u);
}

// Leaves the pool's idle buffers of `bytes` (up to 4) full of NaN: a render that takes one and leaves an
// item unwritten returns NaN there.
void poison_pool(size_t bytes) {
  std::vector<BufferLease> leases;
  for (int i = 0; i < 4; ++i) {
    leases.push_back(test::runtime().buffers().acquire(bytes));
    test::runtime().queue().enqueueFillBuffer(leases.back().buffer(), cl_float(NAN), 0, bytes);
  }
  test::runtime().queue().finish();
}

// The two work schedules give the same image, bit for bit (a pixel's or a map entry's jitter is seeded by
// its index, not by who computes it), over several slices, the second starting mid-row, with tiles
// overhanging the image's right and bottom edges, with direct shadows and with a deep shadow map; neither
// leaves a pixel or a map entry unwritten.
TEST(Render, BothWorkSchedulesRenderTheSameImage) {
  CloudRenderer renderer(test::runtime());
  DeviceVolume dv = upload_volume(test::runtime(), soft_sphere());
  RenderSettings s = sphere_camera(0.05);
  s.camera.width = 61;  // 8 x 6 tiles, the last column and row partly outside
  s.camera.height = 45;
  Light sun;
  sun.direction = {1, 0.3, 0.5};
  sun.intensity = {1000};
  s.lights = {sun};
  s.shadow_map_size = {96, 96, 96};
  int slices = 0;  // run_sliced asks before each slice
  const Cancellation counting([&] { return ++slices, false; });
  auto render = [&](WorkSchedule schedule) {
    poison_pool(size_t(s.camera.width) * s.camera.height * 3 * sizeof(float));  // radiance, T, depth
    poison_pool(size_t(96 * 96 * 96) * sizeof(float));
    renderer.set_work_schedule(schedule);
    slices = 0;
    Image image = renderer.render(dv, s, "render", counting);
    if (s.shadow == ShadowMode::Direct) {
      EXPECT_GE(slices, 2) << "the first slice holds a fixed cost: about 14 of the 48 tiles here";
    }
    EXPECT_EQ(std::count_if(image.data.begin(), image.data.end(), [](float x) { return std::isnan(x); }), 0);
    return image;
  };
  for (ShadowMode shadow : {ShadowMode::Direct, ShadowMode::DeepShadowMap}) {
    SCOPED_TRACE(shadow == ShadowMode::Direct ? "direct shadows" : "deep shadow map");
    s.shadow = shadow;
    const Image shared = render(WorkSchedule::SharedCounter), groups = render(WorkSchedule::WorkGroups);
    EXPECT_GT(mean_channel(groups, 0), 0.0);
    EXPECT_EQ(shared.data, groups.data);
  }
}

// A kept map holds its bytes in the memory budget until it is replaced, its volume goes, or a call takes its
// room back. A render whose map would pass the budget is refused, and one past kMaxKeptShadowMapBytes is
// made for its render alone: the kept one stays.
TEST(Render, KeptShadowMapsHoldTheirBytesInTheMemoryBudget) {
  Limits limits;
  limits.memory_budget = 1 << 20;
  LimitGate gate(limits);
  CloudRenderer renderer(test::runtime(), &gate);
  RenderSettings s = sunlit_sphere();
  auto bytes_of = [](int n) { return uint64_t(n) * n * n * sizeof(float); };
  {
    const DeviceVolume v = stored_sphere();
    renderer.render(v, s);
    renderer.render(v, s);
    EXPECT_EQ(v.kept_shadow_map->made, 1u);
    EXPECT_EQ(gate.memory_bytes(), bytes_of(48));
    s.shadow_map_size = {40, 40, 40};  // replaces it
    renderer.render(v, s);
    EXPECT_EQ(gate.memory_bytes(), bytes_of(40));
    s.shadow_map_size = {72, 72, 72};  // 1.49 MB: past the budget
    expect_error(Code::ResourceExhausted, "Render's deep shadow map", [&] { renderer.render(v, s); });
    EXPECT_EQ(v.kept_shadow_map->made, 2u);
    EXPECT_EQ(gate.memory_bytes(), bytes_of(40));
    s.shadow_map_size = {40, 40, 40};  // still kept
    renderer.render(v, s);
    EXPECT_EQ(v.kept_shadow_map->made, 2u);
    s.shadow_map_size = {48, 48, 48};
    renderer.render(v, s);
    EXPECT_EQ(gate.memory_bytes(), bytes_of(48));
    EXPECT_EQ(gate.cached_memory_bytes(), bytes_of(48));
    {
      Slot call = gate.acquire_memory("a call", limits.memory_budget);  // takes the kept map's budget back
      EXPECT_EQ(gate.cached_memory_bytes(), 0u);
    }
    renderer.render(v, s);
    renderer.render(v, s);
    EXPECT_EQ(v.kept_shadow_map->made, 4u);
    EXPECT_EQ(gate.memory_bytes(), bytes_of(48));
  }
  EXPECT_EQ(gate.memory_bytes(), 0u);  // given back with the volume
  CloudRenderer unbounded(test::runtime());
  const DeviceVolume v = stored_sphere();
  unbounded.render(v, s);               // 48^3, kept
  s.shadow_map_size = {170, 170, 170};  // 19.6 MB: past kMaxKeptShadowMapBytes
  unbounded.render(v, s);
  unbounded.render(v, s);
  EXPECT_EQ(v.kept_shadow_map->made, 3u);
  s.shadow_map_size = {48, 48, 48};
  unbounded.render(v, s);
  EXPECT_EQ(v.kept_shadow_map->made, 3u);
}

// A map made for a render holds its bytes (and its mask's) in the budget while the render runs, and a kept
// map its own bytes from then on, counted once: with a budget of just one render's map, the map is kept, the
// next render of the volume reads it with no bytes of its own, and a render that needs another map takes the
// kept one's bytes back. It fails when a kept map is counted beside the render that made it (no room to
// keep it) or when a render that reads a kept map reserves a map's bytes again (the kept one is reclaimed).
TEST(Render, AKeptShadowMapIsCountedOnceInTheMemoryBudget) {
  RenderSettings s = sunlit_sphere();  // a 48^3 map of one light
  const uint64_t map_bytes = uint64_t(48 * 48 * 48) * s.lights.size() * sizeof(float);
  Limits limits;
  limits.memory_budget = shadow_map_bytes(s);
  LimitGate gate(limits);
  CloudRenderer renderer(test::runtime(), &gate);
  const DeviceVolume v = stored_sphere();
  renderer.render(v, s);
  EXPECT_EQ(gate.memory_bytes(), map_bytes);
  EXPECT_EQ(gate.cached_memory_bytes(), map_bytes);
  s.camera.eye = {-12, -24, 2};
  renderer.render(v, s);
  EXPECT_EQ(v.kept_shadow_map->made, 1u);
  EXPECT_EQ(gate.memory_bytes(), map_bytes);
  s.seed += 1;  // another map: the kept one gives its bytes back for it, and the new one is kept
  renderer.render(v, s);
  EXPECT_EQ(v.kept_shadow_map->made, 2u);
  EXPECT_EQ(gate.memory_bytes(), map_bytes);
  {
    const Slot stream = gate.acquire_memory("a stream's frames", shadow_map_bytes(s));  // reclaims the kept map
    CloudRenderer frames(test::runtime(), &gate);
    const DeviceVolume frame = upload_volume(test::runtime(), soft_sphere());
    EXPECT_NO_THROW(frames.render(frame, s, "render", {}, &stream)) << "its map's bytes are the stream's";
    expect_error(Code::ResourceExhausted, "--memory-budget", [&] { frames.render(frame, s); });
  }
  EXPECT_EQ(gate.memory_bytes(), 0u);
}

// Renders of one stored volume from four threads at once (as many as the device has queues, the others
// waiting for one), each from cameras of its own, the later threads starting while the first one's map is
// being made: every image equals that of a volume making its own map, bit for bit, whichever render made
// the map the others read.
TEST(Render, ConcurrentRendersOfAStoredVolumeAgreeWithFreshOnes) {
  CloudRenderer renderer(test::runtime());
  const DeviceVolume kept = stored_sphere(), fresh = upload_volume(test::runtime(), soft_sphere());
  auto camera = [](int thread, int frame) {
    RenderSettings s = sunlit_sphere();
    s.shadow_map_size = {96, 96, 96};  // 3.5 MB, made in tens of milliseconds
    s.camera.eye = {-12.0 + 6 * thread, -24, 1.0 + frame};
    return s;
  };
  constexpr int kThreads = 4, kFrames = 2;
  std::vector<std::vector<float>> expected(kThreads * kFrames), got(kThreads * kFrames);
  for (int t = 0; t < kThreads; ++t)
    for (int f = 0; f < kFrames; ++f) expected[t * kFrames + f] = renderer.render(fresh, camera(t, f)).data;
  std::latch start(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&, t] {
      start.arrive_and_wait();
      std::this_thread::sleep_for(std::chrono::milliseconds(8 * t));  // while the first map is being made
      for (int f = 0; f < kFrames; ++f) got[t * kFrames + f] = renderer.render(kept, camera(t, f)).data;
    });
  for (auto& thread : threads) thread.join();
  for (size_t i = 0; i < got.size(); ++i) EXPECT_EQ(got[i], expected[i]) << "render " << i;
  EXPECT_GE(kept.kept_shadow_map->made, 1u);
  EXPECT_LE(kept.kept_shadow_map->made, uint64_t(kThreads));
}

// The maps kept for all volumes together stay within the renderer's own budget: a second volume's map
// that would pass it is not kept until the first volume has gone.
TEST(Render, KeptShadowMapsTogetherStayWithinTheirBudget) {
  const size_t map_bytes = 48 * 48 * 48 * sizeof(float);
  CloudRenderer renderer(test::runtime(), nullptr, map_bytes + map_bytes / 2);
  const RenderSettings s = sunlit_sphere();
  const DeviceVolume second = stored_sphere();
  {
    const DeviceVolume first = stored_sphere();
    renderer.render(first, s);
    renderer.render(second, s);
    renderer.render(second, s);
    EXPECT_EQ(second.kept_shadow_map->made, 2u);
    EXPECT_FALSE(second.kept_shadow_map->map());
  }
  renderer.render(second, s);
  renderer.render(second, s);
  EXPECT_EQ(second.kept_shadow_map->made, 3u);
}

// A march's steps are cut at every node face, whatever its step: a rod one voxel thick and 4000 long,
// seen end on, takes at least a step in each of its 500 leaves with substeps samples each, and each sample's
// shadow ray toward a light down the rod a step in each leaf it has left to cross (250 on average). The
// estimate, which bounds what a pixel's uncancellable march costs, holds that count.
TEST(Render, TheSampleEstimateCountsAStepInEveryNodeCrossed) {
  initialize_openvdb();
  CloudVolume rod;
  rod.density = openvdb::FloatGrid::create(0.0f);
  rod.density->tree().fill(openvdb::CoordBBox(openvdb::Coord(0, 0, 0), openvdb::Coord(3999, 0, 0)), 1.0f, true);
  rod.density->tree().voxelizeActiveTiles();
  rod.stats = volume_stats(*rod.density);
  const DeviceVolume dv = upload_volume(test::runtime(), rod);
  RenderSettings s;
  s.camera.eye = {-100, 0.5, 0.5};
  s.camera.look_at = {0, 0.5, 0.5};
  s.camera.width = s.camera.height = 1;
  s.step = s.shadow_step = 1e6;
  s.substeps = 8;
  s.shadow = ShadowMode::Direct;
  Light down_the_rod;
  down_the_rod.direction = {1, 0, 0};
  down_the_rod.intensity = {1};
  s.lights.assign(4, down_the_rod);
  const double primary = 500.0 * s.substeps, shadow = 4 * 250.0;
  EXPECT_GE(estimate_samples(dv, s).per_pixel, primary * (1 + shadow));
  // A point light at the rod's far end instead of a sun: its equiangular samples beyond one a sub-step (up to
  // 4 / pi of SQUALL_CLOUD_POINT_LIGHT_STRATA along a ray through the light), each a march down the rod of up
  // to its 500 leaves.
  const double with_suns = estimate_samples(dv, s).per_pixel;
  s.lights[3].kind = LightKind::Point;
  s.lights[3].position = {4000, 0.5, 0.5};
  EXPECT_GE(estimate_samples(dv, s).per_pixel - with_suns, 4 * SQUALL_CLOUD_POINT_LIGHT_STRATA / kPi * 500.0);
  s.shadow = ShadowMode::DeepShadowMap;
  EXPECT_GE(estimate_samples(dv, s).per_map_node, 500.0) << "a map node's march down the rod";
  s.lights.clear();
  EXPECT_EQ(estimate_samples(dv, s).per_map_node, 0.0) << "no light, no map";
}

// Empty-space skipping: two slabs 144 m apart (the gap spans whole internal nodes of the tree), each
// filling whole leaves (z voxels 0..15 and 304..319): the transmittance through both is exactly
// exp(-sigma (L1 + L2)) for any step: nothing is lost or added in the skipped gap. (Where a leaf is only
// partly filled, the jittered estimate is unbiased but not exact: see the trilinear test.)
TEST(Render, EmptySpaceBetweenSlabsIsSkippedExactly) {
  initialize_openvdb();
  const double dx = 0.5, rho = 0.5, kappa = 0.2;
  CloudVolume v;
  v.density = openvdb::FloatGrid::create(0.0f);
  v.density->setTransform(openvdb::math::Transform::createLinearTransform(dx));
  v.density->tree().fill(openvdb::CoordBBox(openvdb::Coord(-64, -64, 0), openvdb::Coord(63, 63, 15)), float(rho), true);
  v.density->tree().fill(openvdb::CoordBBox(openvdb::Coord(-64, -64, 304), openvdb::Coord(63, 63, 319)), float(rho),
                         true);
  v.density->tree().voxelizeActiveTiles();
  v.stats = volume_stats(*v.density);
  DeviceVolume dv = upload_volume(test::runtime(), v);
  CloudRenderer renderer(test::runtime());
  for (double step : {0.3, 7.0}) {
    RenderSettings s = slab_camera(step);
    s.camera.vertical_fov_deg = 1;
    s.extinction = {kappa};
    Image img = renderer.render(dv, s);
    double worst = 0;
    for (int y = 0; y < s.camera.height; ++y)
      for (int x = 0; x < s.camera.width; ++x)
        worst = squall::test::worse(worst,
                                    std::abs(img.at(1, x, y) - std::exp(-kappa * rho * 32 * dx / pixel_cos(s, x, y))));
    EXPECT_LT(worst, 1e-5) << step;
    // depth: T = 0.5 at tau = ln 2, 6.93 m into the first slab, whose face is at z = -0.25 m (eye at -40 m);
    // it is reported at the sample of the step where T crosses 0.5, so within one step.
    float depth = img.at(2, s.camera.width / 2, s.camera.height / 2);
    EXPECT_NEAR(depth, 39.75 + std::log(2.0) / (kappa * rho), step + 0.01) << step;
  }
}

double planck(double lambda, double T) {
  const double h = 6.62607015e-34, c = 299792458, k = 1.380649e-23;
  return 2 * h * c * c / std::pow(lambda, 5) / std::expm1(h * c / (lambda * k * T));
}

TEST(Render, ThickIsothermalSlabRadiatesThePlanckRadiance) {
  const double dx = 0.5, T = 260;
  CloudRenderer renderer(test::runtime());
  DeviceVolume dv = upload_volume(test::runtime(), slab(dx, 40, 1.0f, false, float(T)));
  RenderSettings s = slab_camera(0.37);
  s.wavelengths = {10e-6, 4e-6};
  s.extinction = {2.0, 2.0};  // tau = 40 over 20 m
  s.albedo = {0.0, 0.0};
  Image img = renderer.render(dv, s);
  for (int w = 0; w < 2; ++w) {
    double B = planck(s.wavelengths[w], T);
    for (int y = 0; y < s.camera.height; y += 3)
      for (int x = 0; x < s.camera.width; x += 3) EXPECT_NEAR(img.at(w, x, y) / B, 1.0, 1e-4) << w;
  }
}

std::vector<float> device_phase(const RenderSettings& rs, const std::vector<float>& theta) {
  Runtime& rt = test::runtime();
  CloudRenderParams p{};
  p.phase = int(rs.phase.kind);
  p.g1 = float(rs.phase.g1);
  p.g2 = float(rs.phase.g2);
  p.weight = float(rs.phase.weight);
  p.ff_n = float(rs.phase.ff_n);
  p.ff_mu = float(rs.phase.ff_mu);
  cl::Buffer in = test::upload(theta);
  cl::Buffer out(rt.context(), CL_MEM_WRITE_ONLY, theta.size() * sizeof(float));
  Kernel<CloudRenderParams, cl::Buffer, cl_int, cl::Buffer> phase(rt, "clouds/probe.cl", "phase_eval");
  phase.launch(cl::NDRange(round_up(theta.size(), 64)), cl::NDRange(64), p, in, cl_int(theta.size()), out);
  return test::read<float>(out, theta.size());
}

// The tree queries of rays through a volume's nodes (probe.cl's node_walk_queries): origins and directions
// in cell space, three floats a ray, walked from where they enter the volume or from their origins.
std::vector<int> node_walk_queries(const DeviceVolume& dv, const std::vector<float>& origins,
                                   const std::vector<float>& directions, bool from_entry) {
  Runtime& rt = test::runtime();
  const size_t n = origins.size() / 3;
  cl::Buffer o = test::upload(origins), d = test::upload(directions);
  cl::Buffer out(rt.context(), CL_MEM_WRITE_ONLY, n * sizeof(int));
  Kernel<cl::Buffer, cl::Buffer, cl::Buffer, cl_int, cl_int, cl::Buffer> walk(rt, "clouds/probe.cl",
                                                                              "node_walk_queries");
  walk.launch(cl::NDRange(round_up(n, 64)), cl::NDRange(64), dv.density, o, d, cl_int(n), cl_int(from_entry), out);
  return test::read<int>(out, n);
}

// A ray crosses each node once wherever the volume lies and wherever the ray comes from: a sphere 30 m wide
// in 1 m voxels, at x = 0 and at x = 1e6 (within the reach of 2^20 voxels), by rays from 400 m and 4 km on
// either side along x, straight and grazing, walked from where they enter the volume (as primary rays are)
// and from their origins (as shadow rays are). At 1e6 cell positions rounded to 1/16 voxel, which the
// walk's 1e-4 voxel nudge past a node's face was lost in: a ray going toward -x crept out of each node by
// nudges, with thousands of queries. At t = 4000 a float ulp is 2.4 times that nudge.
TEST(Render, ANodeWalkFarFromTheGridsOriginQueriesEachNodeOnce) {
  std::vector<int> near;
  for (double x : {0.0, 1e6}) {
    CloudModel m;
    m.voxel_size = 1;
    m.skin = 1;
    m.spheres.push_back({{x, 0, 0}, 15});
    const DeviceVolume dv = upload_volume(test::runtime(), build_cloud(m));
    std::vector<float> origins, directions;
    for (double distance : {400.0, 4000.0})
      for (double side : {-1.0, 1.0})
        for (double graze : {0.0, 12 / distance}) {  // passing 12 m from the centre
          origins.insert(origins.end(), {float(x + distance * side + 0.5), 0.5f, 0.5f});
          directions.insert(directions.end(), {float(-side), float(graze), float(graze / 3)});
        }
    for (bool from_entry : {true, false}) {
      const std::vector<int> queries = node_walk_queries(dv, origins, directions, from_entry);
      for (size_t r = 0; r < queries.size(); ++r) {
        SCOPED_TRACE("x = " + std::to_string(x) + ", ray " + std::to_string(r) + (from_entry ? " from its entry" : ""));
        EXPECT_GT(queries[r], 2);
        EXPECT_LT(queries[r], 40);
        if (x == 0)
          near.push_back(queries[r]);
        else
          EXPECT_LE(std::abs(queries[r] - near[r + (from_entry ? 0 : queries.size())]), 2)
              << queries[r] << " against " << near[r + (from_entry ? 0 : queries.size())] << " at x = 0";
      }
    }
  }
}

// The slab of SlabTransmittanceIsExpMinusSigmaLForAnyStep in 1 m voxels, seen from 10,000 km (as far as a
// point may be) at 0, 40 and 60 degrees from its normal through a field 20 m wide there: each ray's
// transmittance is exp(-sigma L / cos) and its depth (T = 1/2) lies ln 2 / sigma past the near face, for
// a step of 12 m and one of 0.37 m. Counted from the eye the march's parameters rounded to a whole voxel
// at the slab, and its nudge past each node's face grew to 5 voxels.
TEST(Render, ASlabSeenFromAsFarAsAPointMayBeHasItsTransmittanceAndDepth) {
  const double rho = 0.6, kappa = 0.1, L = 20, far = 1e7;  // sigma L = 1.2
  CloudRenderer renderer(test::runtime());
  for (bool voxelize : {false, true}) {
    DeviceVolume dv = upload_volume(test::runtime(), slab(1.0, 20, float(rho), voxelize));
    for (double degrees : {0.0, 40.0, 60.0}) {
      const double theta = degrees * kPi / 180, c = std::cos(theta), s = std::sin(theta);
      const Vec3d centre = {-0.5, -0.5, 9.5}, axis = {0, s, c};  // cell-centred voxels: faces at z = -0.5, 19.5
      for (double step : {12.0, 0.37}) {
        RenderSettings rs = slab_camera(step);
        for (int a = 0; a < 3; ++a) rs.camera.eye[a] = centre[a] - far * axis[a];
        rs.camera.look_at = centre;
        rs.camera.up = {1, 0, 0};
        rs.camera.vertical_fov_deg = 20 / far * 180 / kPi;
        rs.extinction = {kappa};
        const Image img = renderer.render(dv, rs);
        double worst_t = 0, worst_depth = 0;
        for (int y = 0; y < rs.camera.height; ++y)
          for (int x = 0; x < rs.camera.width; ++x) {
            // The ray's z component, with forward (0, s, c), right (0, c, -s) and up (1, 0, 0).
            const double cos_z = (c - pixel_offsets(rs, x, y).first * s) * pixel_cos(rs, x, y);
            const double depth = (-0.5 - rs.camera.eye[2]) / cos_z + std::log(2.0) / (kappa * rho);
            worst_t = test::worse(worst_t, std::abs(img.at(1, x, y) - std::exp(-kappa * rho * L / cos_z)));
            worst_depth = test::worse(worst_depth, std::abs(img.at(2, x, y) - depth));
          }
        SCOPED_TRACE(std::to_string(degrees) + " degrees, step " + std::to_string(step) + (voxelize ? ", leaves" : ""));
        EXPECT_LT(worst_t, 1e-4);
        EXPECT_LT(worst_depth, step + 2);  // a sample where T passes 1/2, in float at 1e7 m (ulp 1 m)
        std::printf(
            "slab from %.0e m at %2.0f deg, step %5.2f m, %s: max |T - exp(-sigma L / cos)| = %.1e, "
            "max depth error %.2f m\n",
            far, degrees, step, voxelize ? "leaves" : "tiles ", worst_t, worst_depth);
      }
    }
  }
}

// The slab in voxels of 0.1 mm (12.8 x 12.8 x 2 mm), seen face on from 10,000 km at the finest step the
// renderer admits for it: its transmittance is exp(-sigma L), and its radiance in unshadowed light
// albedo E (1 - T) / 4 pi. Moved once to the slab's face, a ray lands
// within a few float ulps of 1e11 voxels of it (thousands of voxels), where steps that fine round away
// and the march never ended; moved twice, it starts on the face. In 1.6e5 steps of opacity 6e-6 each,
// below a float ulp of 1, T (1 - opacity) rounded the same way each step and kept 0.2% too much light.
TEST(Render, ASmallSlabSeenFromAfarAtItsFinestStepHasItsTransmittance) {
  const double dx = 1e-4, L = 20 * dx, rho = 0.6, kappa = 1 / (rho * L);  // sigma L = 1
  DeviceVolume dv = upload_volume(test::runtime(), slab(dx, 20, float(rho), true));
  RenderSettings s = slab_camera(0);
  s.camera.eye = {0.3 * dx, -0.2 * dx, -1e7};
  s.camera.look_at = {0.3 * dx, -0.2 * dx, 0};
  s.camera.vertical_fov_deg = 1e-3 / 1e7 * 180 / kPi;
  s.camera.width = s.camera.height = 2;
  s.extinction = {kappa};
  s.albedo = {0.8};
  s.phase.kind = PhaseKind::Uniform;  // unshadowed: L = albedo E (1/4pi) (1 - T)
  Light sun;
  sun.direction = {0.2, 0.1, -1};
  sun.intensity = {1000};
  s.lights = {sun};
  const Vec3d& lo = dv.world_min;
  const Vec3d& hi = dv.world_max;
  s.step = 1.01 * kMinStepOfDistance * std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
  EXPECT_NO_THROW(check_march_resolution(dv, s, "render"));
  const Image img = CloudRenderer(test::runtime()).render(dv, s);
  const double radiance = 0.8 * 1000 / (4 * kPi) * (1 - std::exp(-1.0));
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 2; ++x) {
      EXPECT_NEAR(img.at(1, x, y), std::exp(-1.0), 1e-4) << x << ", " << y;
      EXPECT_NEAR(img.at(0, x, y) / radiance, 1, 1e-4) << x << ", " << y;
    }
}

// 2 pi int P(theta) sin(theta) dtheta and 2 pi int P cos sin dtheta by the trapezoid rule on a grid that is
// log-spaced near theta = 0 (the forward peaks) and uniform beyond.
std::pair<double, double> integrate(const RenderSettings& s) {
  std::vector<float> theta;
  for (int i = 0; i <= 4000; ++i) theta.push_back(float(1e-6 * std::pow(1e-2 / 1e-6, i / 4000.0)));
  for (int i = 1; i <= 20000; ++i) theta.push_back(float(1e-2 + (kPi - 1e-2) * i / 20000));
  std::vector<float> P = device_phase(s, theta);
  double norm = 0, mean = 0;
  for (size_t i = 1; i < theta.size(); ++i) {
    double a = theta[i - 1], b = theta[i];
    double fa = P[i - 1] * std::sin(a), fb = P[i] * std::sin(b);
    norm += 0.5 * (b - a) * (fa + fb);
    mean += 0.5 * (b - a) * (fa * std::cos(a) + fb * std::cos(b));
  }
  return {2 * kPi * norm, 2 * kPi * mean};
}

TEST(Render, PhaseFunctionsIntegrateToOneAndHenyeyGreensteinMeanCosineIsG) {
  RenderSettings s;
  s.phase.kind = PhaseKind::Uniform;
  EXPECT_NEAR(integrate(s).first, 1.0, 1e-4);
  s.phase.kind = PhaseKind::HenyeyGreenstein;
  for (double g : {0.0, 0.5, -0.5, 0.9}) {
    s.phase.g1 = g;
    auto [norm, mean] = integrate(s);
    EXPECT_NEAR(norm, 1.0, 1e-3) << g;
    EXPECT_NEAR(mean, g, 1e-3) << g;
  }
  s.phase.kind = PhaseKind::DoubleHenyeyGreenstein;
  s.phase.g1 = 0.8;
  s.phase.g2 = -0.4;
  s.phase.weight = 0.7;
  auto [norm, mean] = integrate(s);
  EXPECT_NEAR(norm, 1.0, 1e-3);
  EXPECT_NEAR(mean, 0.7 * 0.8 + 0.3 * -0.4, 1e-3);
  s.phase.kind = PhaseKind::FournierForand;
  s.phase.ff_n = 1.05;
  for (double mu : {4.0, 4.5, 5.0}) {  // the Junge slope; the caption of Fig A.2 prints 0.35..0.5
    s.phase.ff_mu = mu;
    double ff = integrate(s).first;
    std::printf("Fournier-Forand n 1.05 mu %.1f: integral %.5f\n", mu, ff);
    EXPECT_NEAR(ff, 1.0, 1e-3) << mu;
  }
}

// Fournier-Forand (eqs A.9-A.12) in long double. Its bracket's terms cancel to (1 - delta)^2 of their size
// near delta = 1, which costs some 1e-17 / (1 - delta)^2 of its value (2e-3 at 1e-7, measured against 60
// digits): a reference 1e-5 or more away from delta = 1 (within 2e-7 there).
long double fournier_forand(long double theta, long double n, long double mu_j) {
  using std::pow, std::sin, std::cos;
  const long double nu = (3 - mu_j) / 2, k = 4 / (3 * (n - 1) * (n - 1)), s2 = pow(sin(theta / 2), 2);
  const long double delta = k * s2, e = 1 - delta, dnu = pow(delta, nu), d180nu = pow(k, nu);
  const long double first = (nu * e - (1 - dnu) + (delta * (1 - dnu) - nu * e) / s2) / (4 * kPi * e * e * dnu);
  return first + (1 - d180nu) / (16 * kPi * (k - 1) * d180nu) * (3 * pow(cos(theta), 2) - 1);
}

// Near delta = 1 (4.96 degrees at n = 1.05) Fournier-Forand's bracket and its (1 - delta)^2 both vanish:
// every float angle there, the 4000 nearest it among them, gives a finite, positive value that meets the
// formula in long double 1e-5 or more away from the point and, nearer, its value at the point: the limit
// nu (nu - 1) / 2 - k nu (nu + 1) / 2 of the bracket over (1 - delta)^2, which P leaves by at most 1.2e-5 of
// itself there (60-digit arithmetic).
TEST(Render, FournierForandIsExactWhereItsBracketCancels) {
  RenderSettings s;
  s.phase.kind = PhaseKind::FournierForand;
  s.phase.ff_n = 1.05;
  for (double mu_j : {3.5, 4.0, 5.0}) {
    s.phase.ff_mu = mu_j;
    const double n = double(float(s.phase.ff_n)), k = 4 / (3 * (n - 1) * (n - 1)), nu = (3 - mu_j) / 2;
    const float at_one = float(2 * std::asin(std::sqrt(1 / k)));
    std::vector<float> theta{at_one};
    for (float up = at_one, down = at_one; theta.size() < 4001;) {
      theta.push_back(up = std::nextafter(up, 4.0f));
      theta.push_back(down = std::nextafter(down, 0.0f));
    }
    for (double off = 1e-4; off < 0.05; off *= 1.5)
      theta.insert(theta.end(), {at_one + float(off), at_one - float(off)});
    const std::vector<float> P = device_phase(s, theta);
    const double d180nu = std::pow(k, nu),
                 limit = (nu * (nu - 1) / 2 - k * nu * (nu + 1) / 2) / (4 * kPi) +
                         (1 - d180nu) / (16 * kPi * (k - 1) * d180nu) * (3 * std::pow(std::cos(double(at_one)), 2) - 1);
    for (size_t i = 0; i < theta.size(); ++i) {
      ASSERT_TRUE(std::isfinite(P[i]) && P[i] > 0) << "mu_j " << mu_j << " theta " << theta[i] << ": " << P[i];
      const double e = 1 - k * std::pow(std::sin(double(theta[i]) / 2), 2);
      const double want = std::abs(e) >= 1e-5 ? double(fournier_forand(theta[i], n, mu_j)) : limit;
      EXPECT_NEAR(P[i] / want, 1.0, 1e-4) << "mu_j " << mu_j << " theta " << theta[i] << " 1 - delta " << e;
    }
  }
}

// At the largest asymmetries allowed, Henyey-Greenstein's peak (forward for g = 0.9999, backward for
// g = -0.9999) is as eq A.8 gives it in double: its denominator 1 + g^2 - 2 g mu, some 1e-8 there, is not left
// to float32's cancellation.
TEST(Render, HenyeyGreensteinAtG09999KeepsItsPeak) {
  RenderSettings s;
  s.phase.kind = PhaseKind::HenyeyGreenstein;
  for (double g1 : {0.9999, -0.9999}) {
    s.phase.g1 = g1;
    std::vector<float> theta;
    for (double off : {0.0, 3e-5, 1e-4, 1e-3, 1e-2}) theta.push_back(float(g1 > 0 ? off : kPi - off));
    const std::vector<float> P = device_phase(s, theta);
    const double g = double(float(g1));
    for (size_t i = 0; i < theta.size(); ++i) {
      const double d = 1 + g * g - 2 * g * std::cos(double(theta[i]));
      EXPECT_NEAR(P[i] / ((1 - g * g) / (4 * kPi * d * std::sqrt(d))), 1.0, 1e-3) << "g " << g << " theta " << theta[i];
    }
  }
}

TEST(Render, DeviceBlackbodyMatchesPlanckInDouble) {
  Runtime& rt = test::runtime();
  std::vector<float> lambda, temp;
  for (double l : {0.5e-6, 1e-6, 4e-6, 10e-6, 12e-6})
    for (double T : {220.0, 260.0, 300.0, 1500.0}) {
      lambda.push_back(float(l));
      temp.push_back(float(T));
    }
  cl::Buffer a = test::upload(lambda), b = test::upload(temp);
  cl::Buffer out(rt.context(), CL_MEM_WRITE_ONLY, lambda.size() * sizeof(float));
  Kernel<cl::Buffer, cl::Buffer, cl_int, cl::Buffer> blackbody(rt, "clouds/probe.cl", "blackbody_eval");
  blackbody.launch(cl::NDRange(64), cl::NDRange(64), a, b, cl_int(lambda.size()), out);
  std::vector<float> B = test::read<float>(out, lambda.size());
  for (size_t i = 0; i < B.size(); ++i) {
    double ref = planck(lambda[i], temp[i]);
    if (ref < 1e-30) continue;  // below float range
    EXPECT_NEAR(B[i] / ref, 1.0, 2e-5) << lambda[i] << " m " << temp[i] << " K";
  }
}

}  // namespace
}  // namespace squall::clouds
