// With zero velocity nothing moves: every method shows the reference texture registered to the domain
// (or, for Lagrangian grids on random patches, the same frame again), and no particle is born or killed.
#include <gtest/gtest.h>

#include "textures/textures_support.h"

namespace squall::test {
namespace {

using namespace squall::textures;

TEST(TexturesStatic, EulerianMethodsShowTheInputTexture) {
  for (Method method : {Method::EulerianMultilayer, Method::TwoPhaseFlowMap, Method::Naive}) {
    AdvectSpec spec = noise_spec(method, SQUALL_VELOCITY_UNIFORM);
    TextureFrame input = texture_engine().window(spec);
    for (const TextureFrame& frame : run(spec, 40)) {
      EXPECT_LT(max_abs_difference(frame, input, 0), 1e-5) << "method " << int(method) << " frame " << frame.index;
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
  for (const TextureFrame& frame : frames) EXPECT_LT(max_abs_difference(frame, input, 0), 1e-5);
  EXPECT_EQ(frames.back().stats.uncovered, 0);
}

TEST(TexturesStatic, LagrangianGridsFramesAreIdenticalAndNoParticleIsBornOrKilled) {
  AdvectSpec spec = noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_UNIFORM);
  auto frames = run(spec, 30);
  const ParticleStats& first = frames[0].stats.particles;
  EXPECT_GT(first.born, 50);
  EXPECT_EQ(first.alive, first.born);
  for (size_t i = 1; i < frames.size(); ++i) {
    const ParticleStats& p = frames[i].stats.particles;
    ASSERT_EQ(frames[i].planes, frames[0].planes) << "frame " << i;
    EXPECT_EQ(p.born + p.killed_coverage + p.killed_quality + p.killed_fold + p.killed_density + p.deleted, 0);
    EXPECT_EQ(p.alive, first.alive);
    EXPECT_EQ(frames[i].stats.uncovered, 0);
  }
}

}  // namespace
}  // namespace squall::test
