// With zero velocity nothing moves: every method shows the reference texture registered to the domain
// (or, for Lagrangian grids on random patches, the same frame again), and no particle is born or killed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "support/worst.h"
#include "textures/textures_support.h"

namespace squall::test {
namespace {

using namespace squall::textures;

// Plane index of uv_x (uv_y follows).
int uv_plane(const TextureFrame& f) { return f.final_planes + f.raw_planes + 4; }

TEST(TexturesStatic, EulerianMethodsShowTheInputTexture) {
  for (Method method : {Method::EulerianMultilayer, Method::TwoPhaseFlowMap, Method::Naive}) {
    AdvectSpec spec = noise_spec(method, SQUALL_VELOCITY_UNIFORM);
    TextureFrame input = texture_engine().window(spec);
    for (const TextureFrame& frame : run(spec, 40)) {
      EXPECT_LT(max_abs_difference(frame, input, 0), 1e-5) << "method " << int(method) << " frame " << frame.index;
      for (int k : {uv_plane(frame), uv_plane(frame) + 1})  // u = S x
        EXPECT_LT(max_abs_difference(frame, input, k), 1e-5) << "method " << int(method) << " plane " << k;
      for (int k = 0; k < frame.width * frame.height; ++k) ASSERT_NEAR(frame.weight_sum()[k], 1.0, 1e-6);
    }
  }
}

TEST(TexturesStatic, LagrangianGridsOnTheWindowShowTheInputTexture) {
  AdvectSpec spec = noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_UNIFORM);
  spec.lagrangian.patch_origin = PatchOrigin::Window;
  spec.lagrangian.blend = Blend::Normalized;  // eq. 4 presumes independent samples; these coincide
  TextureFrame input = texture_engine().window(spec);
  auto frames = run(spec, 3);
  for (const TextureFrame& frame : frames) {
    EXPECT_LT(max_abs_difference(frame, input, 0), 1e-5);
    for (int k : {uv_plane(frame), uv_plane(frame) + 1}) EXPECT_LT(max_abs_difference(frame, input, k), 1e-5);
  }
  EXPECT_EQ(frames.back().stats.uncovered, 0);
}

// Also with grids at the narrowest margin beta allows, whose borders clear the kernels by 0.025 d.
TEST(TexturesStatic, LagrangianGridsFramesAreIdenticalAndNoParticleIsBornOrKilled) {
  for (double beta : {0.6, 0.05}) {
    AdvectSpec spec = noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_UNIFORM);
    spec.lagrangian.beta = beta;
    auto frames = run(spec, beta == 0.6 ? 30 : 5);
    const ParticleStats& first = frames[0].stats.particles;
    EXPECT_GT(first.born, 50);
    EXPECT_EQ(first.alive, first.born);
    for (size_t i = 1; i < frames.size(); ++i) {
      const ParticleStats& p = frames[i].stats.particles;
      ASSERT_EQ(frames[i].planes, frames[0].planes) << "beta " << beta << ", frame " << i;
      EXPECT_EQ(p.born + p.killed_coverage + p.killed_quality + p.killed_fold + p.killed_density + p.deleted, 0)
          << "beta " << beta;
      EXPECT_EQ(p.alive, first.alive);
      EXPECT_EQ(frames[i].stats.uncovered, 0);
    }
  }
}

// Under a uniform translation v the naive method's coordinates are the window's carried along:
// u(x, t) = S (x - v (t - t0)) exactly (bilinear interpolation of a linear map), including the fluid that
// entered through the upstream edge (inflow continues the edge's map; a reset to S x there would leave
// every entering particle the same coordinate, a streak).
TEST(TexturesUv, NaiveCoordinatesAreTheWindowCarriedByTheFlow) {
  const double vx = 0.1, vy = -0.05;
  AdvectSpec spec = noise_spec(Method::Naive, SQUALL_VELOCITY_UNIFORM, {vx, vy}, 64);
  const TextureFrame last = run(spec, 11).back();
  const double t = last.time - spec.t0, S = spec.texture.scale;
  const float *u = last.uv_x(), *v = last.uv_y();
  double worst = 0;
  for (int py = 0; py < last.height; ++py) {
    for (int px = 0; px < last.width; ++px) {
      const double x = (px + 0.5) / last.width, y = (py + 0.5) / last.height;
      const size_t k = size_t(px) + size_t(last.width) * py;
      worst = squall::test::worse(worst, std::abs(u[k] - S * (x - vx * t)), std::abs(v[k] - S * (y - vy * t)));
    }
  }
  EXPECT_LT(worst, 1e-4);
}

// A periodic velocity grid (an ocean tile's current) wraps past its edges: the flow over the next period,
// [1, 2] x [0, 1], is the flow over [0, 1]^2 moved by one period, so the coordinates carried there are
// those of [0, 1]^2 plus S. Held at the edge nodes instead (clamp), they are off by about 0.1.
TEST(TexturesUv, APeriodicVelocityGridWrapsPastItsEdges) {
  constexpr int n = 16;  // nodes at (i, j) / n: node n is node 0 again
  AdvectSpec spec = noise_spec(Method::Naive, SQUALL_VELOCITY_GRID, {}, 64);
  VelocitySpec& v = spec.velocity;
  v.nx = v.ny = n;
  v.hx = v.hy = 1.0 / n;
  v.extrapolation = Extrapolation::Wrap;
  VelocityFrame frame;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      frame.u.push_back(float(0.2 + 0.1 * std::sin(2 * M_PI * j / n)));
      frame.v.push_back(float(0.1 * std::cos(2 * M_PI * i / n)));
    }
  }
  v.frames = {frame};
  const TextureFrame here = run(spec, 11).back();
  spec.output.x0 = 1, spec.output.x1 = 2;
  const TextureFrame next = run(spec, 11).back();
  double worst = 0;
  for (int k = 0; k < here.width * here.height; ++k)
    worst = squall::test::worse(worst, std::abs(double(next.uv_x()[k]) - here.uv_x()[k] - spec.texture.scale),
                                std::abs(double(next.uv_y()[k]) - here.uv_y()[k]));
  EXPECT_LT(worst, 1e-3);
}

}  // namespace
}  // namespace squall::test
