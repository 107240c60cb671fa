// The vorticity cascade of F. Neyret, "Advected Textures" (SCA 2003), sec. 4, on the multi-layer Eulerian
// method: per node and noise band k, a vorticity w_k (w_0 = c_w |omega|, w_k relaxed toward w_(k-1) with
// beta_k = 2^(-dt / tau_k)) and a phase theta_k += w_k dt that turns band k's gradients. Checked against the
// closed form of the discrete recursion, against the frames without the cascade where the flow has no
// vorticity, and by where a Rankine vortex animates the fine band.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "support/expect_error.h"
#include "support/worst.h"
#include "textures/textures_support.h"

namespace squall::test {
namespace {

using namespace squall::textures;

constexpr int kNodes = 32 * 32;  // cascade_spec's grid

// One node's cascade under a steady uniform vorticity (w_0 the same every step), from w_k = theta_k = 0:
// the recursion the kernel runs, in double precision.
struct Recursion {
  std::vector<double> w, theta, beta;

  Recursion(const VorticityCascade& c, int bands, double dt) : w(bands), theta(bands), beta(bands) {
    for (int k = 1; k < bands; ++k) beta[k] = std::exp2(-dt / (c.tau * std::pow(c.tau_ratio, k - 1)));
  }
  void step(double w0, double dt) {
    std::vector<double> next(w.size());
    next[0] = w0;
    for (size_t k = 1; k < w.size(); ++k) next[k] = beta[k] * w[k] + (1 - beta[k]) * w[k - 1];
    w = next;
    for (size_t k = 0; k < w.size(); ++k) theta[k] += w[k] * dt;
  }
};

// The largest |got - want| / scale over every node of band k, for w (component 0) or theta (1).
double worst_over_nodes(const std::vector<float>& cascade, int k, int component, double want, double scale) {
  double worst = 0;
  for (int node = 0; node < kNodes; ++node)
    worst = squall::test::worse(worst, std::abs(cascade[2 * (size_t(k) * kNodes + node) + component] - want) / scale);
  return worst;
}

// N7a. Solid rotation at Omega has the uniform vorticity 2 Omega: w_0 = 2 c_w Omega at once, w_1 reaches it
// as w_0 (1 - 2^(-(t - dt) / tau_1)) (time constant tau_1 / ln 2), and the finer bands follow in cascade.
TEST(TexturesCascade, SolidRotationRelaxesEveryBandToW0WithItsHalfLife) {
  const double omega = 1.0, c_w = 0.5, w0 = 2 * c_w * omega;
  AdvectSpec spec = cascade_spec(SQUALL_VELOCITY_ROTATION, {omega, 0.5, 0.5}, c_w);
  spec.eulerian.cascade.tau = 0.25;
  const VorticityCascade& c = spec.eulerian.cascade;
  const int bands = spec.texture.bands, steps = 90;
  Recursion expected(c, bands, spec.dt);
  auto advection = texture_engine().start(spec);
  advection->next();
  double worst_w = 0, worst_theta = 0, worst_closed = 0;
  std::vector<float> cascade;
  for (int n = 1; n <= steps; ++n) {
    advection->next();
    expected.step(w0, spec.dt);
    cascade = cascade_of_checkpoint(advection->checkpoint());
    ASSERT_EQ(cascade.size(), size_t(2 * bands * kNodes));
    for (int k = 0; k < bands; ++k) {
      worst_w = squall::test::worse(worst_w, worst_over_nodes(cascade, k, 0, expected.w[k], w0));
      const double theta_scale = std::max(std::abs(expected.theta[k]), 1e-30);  // 0 / 0 where a band starts at 0
      worst_theta = squall::test::worse(worst_theta, worst_over_nodes(cascade, k, 1, expected.theta[k], theta_scale));
    }
    const double closed = w0 * (1 - std::exp(-(n - 1) * spec.dt * std::log(2.0) / c.tau));
    worst_closed = squall::test::worse(worst_closed, worst_over_nodes(cascade, 1, 0, closed, w0));
  }
  std::printf(
      "w_0 = %.4f rad/s; over %d steps and %d nodes: |w_k - recursion| / w_0 <= %.2e, "
      "|theta_k - recursion| / theta_k <= %.2e, |w_1 - closed form| / w_0 <= %.2e\n",
      w0, steps, kNodes, worst_w, worst_theta, worst_closed);
  EXPECT_LT(worst_w, 1e-4);
  EXPECT_LT(worst_theta, 1e-4);
  EXPECT_LT(worst_closed, 1e-4);
  for (int k = 0; k < bands; ++k) {
    const double w = cascade[2 * (size_t(k) * kNodes + kNodes / 2)];
    std::printf("band %d after %.1f s: w = %.5f (w_0 - w = %.2e)\n", k, steps * spec.dt, w, w0 - w);
    EXPECT_NEAR(w, w0, 2e-3 * w0) << "band " << k;
  }
}

// N7b. A uniform translation has no vorticity: every w_k and theta_k stays 0, and with spin 0 the frames
// equal those without the cascade (the fine octaves stay still in the advected frame).
TEST(TexturesCascade, UniformTranslationLeavesTheFramesAsWithoutTheCascade) {
  AdvectSpec on = cascade_spec(SQUALL_VELOCITY_UNIFORM, {0.3, -0.2}, 3.0);
  AdvectSpec off = on;
  off.eulerian.cascade.c_w = 0;
  auto with = texture_engine().start(on), without = texture_engine().start(off);
  double worst = 0;
  for (int i = 0; i < 30; ++i) {
    TextureFrame a = with->next(), b = without->next();
    const int planes = int(a.planes.size() / (size_t(a.width) * a.height));
    for (int k = 0; k < planes; ++k) worst = squall::test::worse(worst, max_abs_difference(a, b, k));
  }
  double largest = 0;
  for (float v : cascade_of_checkpoint(with->checkpoint())) largest = squall::test::worse(largest, double(std::abs(v)));
  std::printf("30 frames: max |frame on - frame off| = %.3g, max |w_k|, |theta_k| = %.3g\n", worst, largest);
  EXPECT_LT(worst, 1e-6);
  EXPECT_LT(largest, 1e-6);
}

// Mean |a(n + 1) - a(n)| of plane k over frames from..end and the pixels at a distance in [r0, r1) from
// (0.5, 0.5).
double mean_change(const std::vector<TextureFrame>& frames, int k, int from, double r0, double r1) {
  double sum = 0;
  int64_t count = 0;
  for (size_t n = from; n + 1 < frames.size(); ++n) {
    const TextureFrame &a = frames[n], &b = frames[n + 1];
    for (int py = 0; py < a.height; ++py) {
      for (int px = 0; px < a.width; ++px) {
        const double r = std::hypot((px + 0.5) / a.width - 0.5, (py + 0.5) / a.height - 0.5);
        if (r < r0 || r >= r1) continue;
        sum += std::abs(b.plane(k)[px + a.width * py] - a.plane(k)[px + a.width * py]);
        ++count;
      }
    }
  }
  return sum / double(count);
}

// N7c. A Rankine vortex (core radius R, rotation Omega inside) has vorticity 2 Omega in its core and none
// outside: the cascade turns the fine band inside the core only, so its frame-to-frame change there is
// several times that far outside, where without the cascade the two are alike.
TEST(TexturesCascade, RankineVortexAnimatesTheFineBandInsideTheCoreOnly) {
  const double core = 0.1, omega = 1.0, circulation = 2 * M_PI * core * core * omega;
  AdvectSpec spec = cascade_spec(SQUALL_VELOCITY_VORTEX, {circulation, 0.5, 0.5, core}, 4.0);
  spec.eulerian.cascade.tau = 0.1;
  AdvectSpec off = spec;
  off.eulerian.cascade.c_w = 0;
  const int fine = spec.texture.bands - 1, frames = 45, from = 20;
  auto on_frames = run(spec, frames), off_frames = run(off, frames);
  const double on_core = mean_change(on_frames, fine, from, 0, 0.8 * core);
  const double on_far = mean_change(on_frames, fine, from, 0.3, 0.5);
  const double off_core = mean_change(off_frames, fine, from, 0, 0.8 * core);
  const double off_far = mean_change(off_frames, fine, from, 0.3, 0.5);
  std::printf(
      "fine band, mean |change| per frame: cascade on: core %.4f, far %.4f (ratio %.2f); "
      "off: core %.4f, far %.4f (ratio %.2f)\n",
      on_core, on_far, on_core / on_far, off_core, off_far, off_core / off_far);
  EXPECT_GT(on_core / on_far, 3.0);
  EXPECT_GT(on_core, 2 * off_core);  // the cascade's turning, not the advection, makes the difference
  EXPECT_LT(on_far, 1.5 * off_far);  // far outside it adds next to nothing
}

TEST(TexturesCascade, BadCascadesAreRejectedNamingTheField) {
  struct Case {
    void (*edit)(AdvectSpec&);
    std::string needle;
  };
  const Case cases[] = {
      {[](AdvectSpec& s) { s.eulerian.cascade.c_w = NAN; }, "request.eulerian.cascade.c_w = nan must be finite"},
      {[](AdvectSpec& s) { s.eulerian.cascade.c_w = -1; },
       "request.eulerian.cascade.c_w = -1 must be finite and in [0,"},
      {[](AdvectSpec& s) { s.eulerian.cascade.tau = 0; }, "request.eulerian.cascade.tau = 0 must be finite and in (0,"},
      {[](AdvectSpec& s) { s.eulerian.cascade.tau_ratio = INFINITY; },
       "request.eulerian.cascade.tau_ratio = inf must be finite and in (0, 100]"},
      {[](AdvectSpec& s) {
         s.texture.kind = SQUALL_TEXTURE_IMAGE;
         s.texture.width = s.texture.height = 2;
         s.texture.pixels = {0, 1, 1, 0};
       },
       "request.eulerian.cascade.c_w = 1 must be 0 with an image texture"},
  };
  for (const Case& k : cases) {
    AdvectSpec spec = cascade_spec(SQUALL_VELOCITY_UNIFORM, {0.1, 0}, 1.0);
    k.edit(spec);
    expect_error(Code::InvalidArgument, k.needle, [&] { texture_engine().validate(spec, "request"); });
  }
  AdvectSpec spec = cascade_spec(SQUALL_VELOCITY_UNIFORM, {0.1, 0}, 1.0);
  spec.method = Method::TwoPhaseFlowMap;  // the cascade is the multi-layer method's: ignored here
  spec.eulerian.latencies = {1.0};
  spec.eulerian.cascade.tau = -1;
  texture_engine().validate(spec, "request");
}

TEST(TexturesCascade, ACheckpointIsRefusedByARequestThatDiffersInTheCascade) {
  AdvectSpec spec = cascade_spec(SQUALL_VELOCITY_UNIFORM, {0.1, 0}, 0);
  for (double c_w : {0.0, 1.0}) {
    spec.eulerian.cascade.c_w = c_w;
    auto advection = texture_engine().start(spec);
    advection->next();
    const std::string state = advection->checkpoint();
    spec.eulerian.cascade.c_w = 1 - c_w;
    expect_error(Code::InvalidArgument, "resume_state", [&] { texture_engine().start(spec, state); });
  }
}

}  // namespace
}  // namespace squall::test
