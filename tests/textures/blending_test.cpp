// Blending and coverage: LTA11 (Yu et al., TVCG 2011) eq. 4 keeps the mean and the variance of the
// reference texture where eq. 3 lowers the variance to sigma^2 sum w^2 / (sum w)^2 (fig. 3 and appendix);
// the grids cover every fluid pixel, near a sink (fig. 9) and along walls (sec. 3.3.4); the Eulerian phase
// weights are a partition of unity (F. Neyret, "Advected Textures", SCA 2003, sec. 2.2).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "support/expect_error.h"
#include "support/test_runtime.h"
#include "textures/grid_quality.h"
#include "textures/textures_support.h"

namespace squall::test {
namespace {

using namespace squall::textures;

TEST(TexturesBlending, VariancePreservingBlendKeepsTheInputStdWhereNormalizedBlendLowersIt) {
  // 256 x 256 pixels over 2 x 2 du hold 32 x 32 noise cells: the mean of a frame then deviates from Rhat
  // by about sigma / 32 from sampling alone.
  AdvectSpec spec = noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_UNIFORM, {0.2, 0.1}, 256);
  spec.output.x1 = spec.output.y1 = 2;
  ReferenceStats reference = texture_engine().reference_stats(spec.texture);
  const double sigma = std::sqrt(reference.variance[0]), mean = reference.mean[0];
  TextureFrame preserving = run(spec, 16).back();
  spec.lagrangian.blend = Blend::Normalized;
  TextureFrame normalized = run(spec, 16).back();

  Image image = plane_image(preserving, 0);
  std::printf("sigma_R %.4f; eq. 4: mean %.4f std %.4f local-std CV %.3f\n", sigma, test::mean(image), stddev(image),
              coefficient_of_variation(local_std(image, 32)));
  EXPECT_NEAR(test::mean(image), mean, 0.1 * sigma);
  EXPECT_NEAR(stddev(image), sigma, 0.05 * sigma);
  EXPECT_LT(coefficient_of_variation(local_std(image, 32)), 0.15);

  double predicted = 0;  // eq. 3: Var = sigma^2 sum w^2 / (sum w)^2, averaged over the pixels
  const size_t n = size_t(normalized.width) * normalized.height;
  for (size_t k = 0; k < n; ++k)
    predicted += normalized.weight_sq_sum()[k] / (normalized.weight_sum()[k] * normalized.weight_sum()[k]);
  predicted = sigma * std::sqrt(predicted / n);
  double measured = stddev(plane_image(normalized, 0));
  std::printf("eq. 3: std %.4f, predicted %.4f\n", measured, predicted);
  EXPECT_LT(measured, 0.85 * sigma);
  EXPECT_NEAR(measured, predicted, 0.10 * predicted);
}

// Every fluid pixel (coverage >= 0) of every frame has a grid's weight (sum w^2 > 0), read from the planes
// here, NaN failing both; and the solid pixels are the field's solid area, `solid_share` of the region.
void expect_covered(const AdvectSpec& spec, int frames, double solid_share, const char* what) {
  int64_t solid = 0, pixels = 0;
  for (const TextureFrame& frame : run(spec, frames)) {
    EXPECT_EQ(frame.stats.uncovered, 0) << what << ", frame " << frame.index;
    for (int k = 0; k < frame.width * frame.height; ++k) {
      const float coverage = frame.coverage()[k];
      ASSERT_TRUE(coverage < 0 || coverage >= 0) << what << ", frame " << frame.index << ": coverage NaN";
      ASSERT_TRUE(coverage < 0 || frame.weight_sq_sum()[k] > 1e-12f)
          << what << ", frame " << frame.index << ": fluid pixel " << k << " uncovered";
      solid += coverage < 0, ++pixels;
    }
  }
  std::printf("%s: no uncovered fluid pixel in %d frames (%lld solid pixel-frames)\n", what, frames, (long long)solid);
  EXPECT_NEAR(double(solid) / double(pixels), solid_share, 0.02) << what;
}

TEST(TexturesBlending, GridsCoverEveryFluidPixelNearASinkAndAlongWalls) {
  expect_covered(noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_SINK, {0.25, 0.5, 0.5, 0.05}), 90, 0, "sink");
  expect_covered(noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_CHANNEL, {0.4, 0.5, 0.35}), 60, 0.3, "channel");
  expect_covered(noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_CYLINDER, {0.3, 0.5, 0.5, 0.15}), 60,
                 M_PI * 0.15 * 0.15, "cylinder");
}

void expect_partitions_of_unity(const AdvectSpec& spec, int frames, const char* what) {
  for (const TextureFrame& frame : run(spec, frames)) {
    for (int k = 0; k < frame.width * frame.height; ++k)
      ASSERT_NEAR(frame.weight_sum()[k], 1.0, 1e-5) << what << ", frame " << frame.index;
  }
}

TEST(TexturesBlending, EulerianWeightsArePartitionsOfUnity) {
  const std::vector<double> vortex{0.5, 0.5, 0.5, 0.1};
  expect_partitions_of_unity(noise_spec(Method::EulerianMultilayer, SQUALL_VELOCITY_VORTEX, vortex), 90, "multilayer");
  expect_partitions_of_unity(noise_spec(Method::TwoPhaseFlowMap, SQUALL_VELOCITY_VORTEX, vortex), 90, "flow map");
  // The most slots a request may ask for: 6 layers of 3 phases, and of 2.
  AdvectSpec most = noise_spec(Method::EulerianMultilayer, SQUALL_VELOCITY_VORTEX, vortex);
  most.eulerian.latencies = {0.1, 0.2, 0.4, 0.8, 1.6, 3.2};
  for (int phases : {SQUALL_EULERIAN_MAX_PHASES, 2}) {
    most.eulerian.phases = phases;
    expect_partitions_of_unity(most, 40, phases == 2 ? "6 layers of 2 phases" : "6 layers of 3 phases");
  }
}

// Each slot's node state is one device buffer of the Eulerian grid's nodes: 6 layers of 2 phases over 4096 x
// 4096 nodes (3.2 GB, float4 per slot and node) pass PoCL's largest allocation (2 GiB on a 7 GiB device) and
// are refused before anything is allocated, naming the grid; the same slots over 512 x 512 nodes are not.
TEST(TexturesBlending, SlotsPastTheDevicesLargestAllocationNameTheGrid) {
  AdvectSpec most = noise_spec(Method::EulerianMultilayer, SQUALL_VELOCITY_VORTEX, {0.5, 0.5, 0.5, 0.1});
  most.eulerian.latencies = {0.1, 0.2, 0.4, 0.8, 1.6, 3.2};
  most.eulerian.phases = 2;
  most.eulerian.grid_nx = most.eulerian.grid_ny = 4096;
  const uint64_t bytes = TextureEngine::eulerian_slot_bytes(most);
  EXPECT_EQ(bytes, uint64_t(4096) * 4096 * 12 * 16);
  if (bytes <= runtime().device_info().max_allocation_bytes)
    GTEST_SKIP() << "this device allocates " << bytes << " bytes in one buffer";
  expect_error(Code::ResourceExhausted,
               "request.eulerian.grid_nx x grid_ny = 4096 x 4096 needs a device buffer of 3221225472 bytes",
               [&] { texture_engine().validate(most, "request"); });
  most.eulerian.grid_nx = most.eulerian.grid_ny = 512;
  EXPECT_NO_THROW(texture_engine().validate(most, "request"));
}

// Grids killed in every frame fade out over fade_tau (LTA11 eq. 6); with a long fade_tau the fading ones
// would pile up frame after frame. At most twice the region's area / d^2 particles are held, the fading ones
// killed first giving way to the newborn.
TEST(TexturesBlending, FadingGridsKilledInEveryFrameAreHeldToABound) {
  AdvectSpec spec = noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_TAYLOR_GREEN, {2.0, 0.25});
  spec.lagrangian.fade_tau = 1e6;
  const double d = spec.lagrangian.d, side = 1 + 2 * d;  // the output region, d wider on every side
  const int limit = int(2 * std::ceil(side * side / (d * d)));
  int most = 0, killed = 0;
  for (const TextureFrame& frame : run(spec, 40)) {
    const ParticleStats& p = frame.stats.particles;
    killed += p.killed_coverage + p.killed_quality + p.killed_fold + p.killed_density;
    most = std::max(most, p.alive + p.fading);
    ASSERT_LE(p.alive + p.fading, limit) << "frame " << frame.index;
  }
  std::printf("%d grids killed in 40 frames; at most %d held (bound %d)\n", killed, most, limit);
  EXPECT_GT(killed, limit);         // more kills than the bound: without it the fading grids would pass it
  EXPECT_GE(most, limit * 9 / 10);  // the bound was reached
}

// A particle's temporal weight (LTA11 eq. 6) changes by at most dt / tau a frame through its whole life,
// also when it is killed while fading in: it fades out from the weight it had reached, as in Yu et al.,
// "Scalable real-time animation of rivers" (2009), eq. 7, rather than jumping to 1 first.
TEST(TexturesBlending, AParticleKilledWhileFadingInFadesOutFromTheWeightItReached) {
  const double dt = 1.0 / 30, tau = 0.5, kill = 4 * dt;
  EXPECT_NEAR(temporal_weight(kill + dt, 0, tau), (kill + dt) / tau, 1e-12);
  EXPECT_NEAR(temporal_weight(kill + dt + tau / 2, tau / 2, tau), (kill + dt) / tau / 2, 1e-12);
  EXPECT_EQ(temporal_weight(kill + dt + tau, tau, tau), 0.0);
  double previous = 0;
  for (int frame = 0; frame < 40; ++frame) {  // ages as the engine counts them: frame time + dt
    const double t = frame * dt, since_kill = t >= kill ? t - kill : -1;
    const double w = temporal_weight(t + dt, since_kill, tau);
    EXPECT_LE(std::abs(w - previous), dt / tau + 1e-12) << "frame " << frame;
    previous = w;
  }
}

// With zero velocity the flow map's phases reset to the same window coordinates, so every frame is the
// texture (F. Neyret, "Advected Textures", SCA 2003, sec. 2.2). With a random offset per regeneration the
// two phases are independent samples: the linear blend of weights (1/2, 1/2) has std sqrt(1/2) = 0.71 of
// the texture's when their weights are equal, back to 1 when one phase holds all the weight; LTA11's eq. 4
// applied to the phases keeps the std at the texture's throughout.
TEST(TexturesBlending, RandomRegenerationOffsetsDecorrelateThePhases) {
  AdvectSpec spec = noise_spec(Method::TwoPhaseFlowMap, SQUALL_VELOCITY_UNIFORM);
  spec.eulerian.random_offset = true;
  spec.dt = 1.0 / 40;
  const double reference = texture_engine().window(spec).stats.stddev[0];
  auto std_ratios = [&](const AdvectSpec& s) {
    std::vector<double> ratios;
    for (const TextureFrame& f : run(s, 41)) ratios.push_back(f.stats.stddev[0] / reference);
    return ratios;
  };
  // Triangle weights 1 - |2 age / latency - 1| over the latency of 1 s, the phases half a latency apart:
  // frame 0 (t = 0) and frame 20 (t = 0.5 s) have one phase at weight 1, frame 10 (t = 0.25 s) both at 1/2.
  std::vector<double> linear = std_ratios(spec);
  std::printf("linear blend: std ratio %.3f, %.3f, %.3f at frames 0, 10, 20\n", linear[0], linear[10], linear[20]);
  EXPECT_NEAR(linear[0], 1.0, 0.03);
  EXPECT_NEAR(linear[10], std::sqrt(0.5), 0.08);
  EXPECT_NEAR(linear[20], 1.0, 0.03);
  spec.eulerian.blend = EulerianBlend::OctaveVariancePreserving;
  for (double r : std_ratios(spec)) EXPECT_NEAR(r, 1.0, 0.08);
  // Successive regenerations draw new offsets: frame 40 (one latency on) is not frame 0; without offsets it is.
  auto frames = run(spec, 41);
  EXPECT_GT(max_abs_difference(frames[0], frames[40], 0), 0.1);
  spec.eulerian.random_offset = false;
  frames = run(spec, 41);
  EXPECT_EQ(max_abs_difference(frames[0], frames[40], 0), 0.0);
}

}  // namespace
}  // namespace squall::test
