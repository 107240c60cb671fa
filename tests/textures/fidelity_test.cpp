// Velocity and spectrum fidelity: Q. Yu, F. Neyret, E. Bruneton, N. Holzschuch, "Lagrangian Texture
// Advection: Preserving both Spectrum and Velocity Field" (IEEE TVCG 2011), sec. 4.3 and figs. 1, 6, 7:
// the optical flow between consecutive frames matches the input velocity, and the power spectrum and its
// anisotropy stay those of the input texture; naive advection (fig. 1d) and a short-latency regenerated
// texture (fig. 7b, F. Neyret, "Advected Textures", SCA 2003) show the errors each is known for.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>

#include "textures/textures_support.h"

namespace squall::test {
namespace {

using namespace squall::textures;

constexpr double kPixelsPerUnit = 128;
constexpr double kDt = 1.0 / 30;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? NAN : v[v.size() / 2];
}

struct FlowError {
  double relative = 0;   // median |measured - expected| / |expected|
  double angle_deg = 0;  // median angle between measured and expected
  size_t windows = 0;
};

// Lucas-Kanade between frames i and i+1 for i in [first, last) on windows of `size` pixels whose expected
// displacement v(x) dt is at least 0.3 pixel, compared with the velocity at the window centre.
FlowError flow_error(const std::vector<TextureFrame>& frames, int first, int last, int size,
                     const std::function<std::pair<double, double>(double, double)>& velocity) {
  std::vector<double> relative, angle;
  for (int i = first; i < last; ++i) {
    Image a = plane_image(frames[i], 0), b = plane_image(frames[i + 1], 0);
    for (int y0 = size / 2; y0 + size <= a.height - size / 2; y0 += size / 2) {
      for (int x0 = size / 2; x0 + size <= a.width - size / 2; x0 += size / 2) {
        auto [vx, vy] = velocity((x0 + size / 2.0) / kPixelsPerUnit, (y0 + size / 2.0) / kPixelsPerUnit);
        double ex = vx * kDt * kPixelsPerUnit, ey = vy * kDt * kPixelsPerUnit, norm = std::hypot(ex, ey);
        if (norm < 0.3) continue;
        Displacement d = lucas_kanade(a, b, x0, y0, size);
        if (!d.valid) {
          relative.push_back(1);
          angle.push_back(90);
          continue;
        }
        relative.push_back(std::hypot(d.dx - ex, d.dy - ey) / norm);
        double cosine = (d.dx * ex + d.dy * ey) / (std::hypot(d.dx, d.dy) * norm + 1e-30);
        angle.push_back(std::acos(std::clamp(cosine, -1.0, 1.0)) * 180 / M_PI);
      }
    }
  }
  return {median(relative), median(angle), relative.size()};
}

TEST(TexturesFidelity, LagrangianGridsFollowUniformTranslation) {
  auto frames = run(noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_UNIFORM, {0.3, 0.15}), 26);
  std::vector<double> error_x, error_y;
  for (int i = 20; i < 25; ++i) {
    Image a = plane_image(frames[i], 0), b = plane_image(frames[i + 1], 0);
    for (int y0 = 48; y0 <= 80; y0 += 16) {
      for (int x0 = 48; x0 <= 80; x0 += 16) {
        Displacement d = phase_correlation(a, b, x0, y0, 32);
        ASSERT_TRUE(d.valid);
        error_x.push_back(std::abs(d.dx - 0.3 * kDt * kPixelsPerUnit));
        error_y.push_back(std::abs(d.dy - 0.15 * kDt * kPixelsPerUnit));
      }
    }
  }
  EXPECT_LT(median(error_x), 0.1) << "pixels, of 1.28 expected";
  EXPECT_LT(median(error_y), 0.1) << "pixels, of 0.64 expected";
}

TEST(TexturesFidelity, LagrangianGridsFollowRotationAndShear) {
  const double omega = 0.5, rate = 0.5;
  auto rotation = [&](double x, double y) { return std::make_pair(-omega * (y - 0.5), omega * (x - 0.5)); };
  auto shear = [&](double, double y) { return std::make_pair(rate * (y - 0.5), 0.0); };
  auto rotating = run(noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_ROTATION, {omega, 0.5, 0.5}), 26);
  auto sheared = run(noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_SHEAR, {rate, 0.5}), 26);
  FlowError r = flow_error(rotating, 20, 25, 24, rotation), s = flow_error(sheared, 20, 25, 24, shear);
  RecordProperty("rotation_relative_error", std::to_string(r.relative));
  RecordProperty("shear_relative_error", std::to_string(s.relative));
  std::printf("rotation: %zu windows, median relative error %.3f, angle %.2f deg\n", r.windows, r.relative,
              r.angle_deg);
  std::printf("shear: %zu windows, median relative error %.3f, angle %.2f deg\n", s.windows, s.relative, s.angle_deg);
  EXPECT_GT(r.windows, 50u);
  EXPECT_LT(r.relative, 0.10);
  EXPECT_LT(r.angle_deg, 5);
  EXPECT_LT(s.relative, 0.10);
  EXPECT_LT(s.angle_deg, 5);
}

// A regenerated texture whose latency is short next to the time features take to cross a window cross-fades
// faster than it moves: the optical flow of the blend is no longer the velocity (LTA11 fig. 7b).
TEST(TexturesFidelity, ShortLatencyFlowMapMisreadsTheVelocityWhereLagrangianGridsDoNot) {
  const double rate = 0.5;
  auto shear = [&](double, double y) { return std::make_pair(rate * (y - 0.5), 0.0); };
  AdvectSpec flow_map = noise_spec(Method::TwoPhaseFlowMap, SQUALL_VELOCITY_SHEAR, {rate, 0.5});
  flow_map.eulerian.latencies = {0.6};
  FlowError f = flow_error(run(flow_map, 26), 20, 25, 24, shear);
  FlowError l =
      flow_error(run(noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_SHEAR, {rate, 0.5}), 26), 20, 25, 24, shear);
  std::printf("flow map 0.6 s: median relative error %.3f; Lagrangian grids: %.3f\n", f.relative, l.relative);
  EXPECT_GT(f.relative, 0.25);
  EXPECT_GT(f.relative, 3 * l.relative);
}

struct Spectra {
  double anisotropy = 0, log_ratio = 0;
};

// The anisotropy of a frame's spectrum, and the mean |log10 P_out / P_in| of its radially averaged power
// over the bins where the input holds at least 1% of its peak power (elsewhere both are round-off).
Spectra compare_with_input(const TextureFrame& frame, const TextureFrame& input) {
  Image out = plane_image(frame, 0), in = plane_image(input, 0);
  auto p_out = radial_power_spectrum(out, 32), p_in = radial_power_spectrum(in, 32);
  double peak = *std::max_element(p_in.begin(), p_in.end());
  int last = 1;
  while (last + 1 < int(p_in.size()) && p_in[last + 1] >= 0.01 * peak) ++last;
  return {spectral_anisotropy(out), mean_abs_log10_ratio(p_out, p_in, 1, last)};
}

// The worst anisotropy and log ratio over frames [first, last] (every 10th).
Spectra worst(const std::vector<TextureFrame>& frames, const TextureFrame& input, int first, int last) {
  Spectra w;
  for (int i = first; i <= last; i += 10) {
    Spectra s = compare_with_input(frames[i], input);
    w = {std::max(w.anisotropy, s.anisotropy), std::max(w.log_ratio, s.log_ratio)};
  }
  return w;
}

// Under a steady shear every grid stretches the same way until it is replaced, so the spectrum of the
// Lagrangian frames is as anisotropic as delta_max lets a grid get before it fades out (the second-moment
// ratio grows as the square of the singular-value ratio: s^4 for singular values (s, 1/s)), and no more as
// time goes on; naive advection's grows without bound (fig. 1d). A grid is killed when a vertex's Q_V drops
// below 1/2 (distortion (1 + delta_max) / 2) and then fades out, so its s reaches 1.5-1.9 with delta_max = 2:
// the blend of such grids sits near 3-4. Measured on PoCL: about 3.3-4.0 with delta_max = 2, 2.0 with 1.3,
// while naive advection reaches 27 after 4 s.
TEST(TexturesFidelity, UnderShearLagrangianGridsKeepTheSpectrumWhileNaiveAdvectionStretchesIt) {
  const double rate = 0.5;
  AdvectSpec lagrangian = noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_SHEAR, {rate, 0.5});
  TextureFrame input = texture_engine().window(lagrangian);
  auto grids = run(lagrangian, 121);
  lagrangian.lagrangian.delta_max = 1.3;
  auto tight = run(lagrangian, 121);
  auto naive = run(noise_spec(Method::Naive, SQUALL_VELOCITY_SHEAR, {rate, 0.5}), 121);
  Spectra at_rest = compare_with_input(run(noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_UNIFORM), 1)[0], input);
  std::printf("at rest: anisotropy %.3f log ratio %.3f\n", at_rest.anisotropy, at_rest.log_ratio);

  Spectra early = worst(grids, input, 10, 60), late = worst(grids, input, 70, 120),
          bounded = worst(tight, input, 10, 120);
  Spectra naive_mid = compare_with_input(naive[60], input), naive_end = compare_with_input(naive[120], input);
  std::printf(
      "input anisotropy %.3f; Lagrangian grids (delta_max 2): worst anisotropy %.3f then %.3f, worst log "
      "ratio %.3f then %.3f; delta_max 1.3: %.3f, %.3f; naive at 2 s and 4 s: %.3f, %.3f (log ratio %.3f)\n",
      spectral_anisotropy(plane_image(input, 0)), early.anisotropy, late.anisotropy, early.log_ratio, late.log_ratio,
      bounded.anisotropy, bounded.log_ratio, naive_mid.anisotropy, naive_end.anisotropy, naive_end.log_ratio);
  EXPECT_LT(late.anisotropy, 1.25 * early.anisotropy);  // bounded in time
  EXPECT_LT(bounded.anisotropy, 2.5);                   // and by delta_max
  EXPECT_LT(bounded.anisotropy, 0.75 * early.anisotropy);
  // The radial power stays the input's within the deviation the blend itself brings at rest.
  EXPECT_LT(at_rest.log_ratio, 0.2);
  EXPECT_LT(std::max(early.log_ratio, late.log_ratio), 0.25);
  EXPECT_GT(naive_end.anisotropy, 2 * naive_mid.anisotropy);  // naive advection: grows without bound
  EXPECT_GT(naive_end.anisotropy, 5 * late.anisotropy);
}

}  // namespace
}  // namespace squall::test
