// Evolution (J. Tessendorf, "Gilligan: A Prototype Framework for Simulating and Rendering Maritime
// Environments" (2017), sec. 6.4): a cloud whose shape and noise drift together translates exactly.
#include <gtest/gtest.h>

#include <cmath>

#include "clouds/evolution.h"
#include "clouds/volume.h"
#include "common/error.h"

#include "support/expect_error.h"
#include "support/worst.h"

namespace squall::clouds {
namespace {

Particle particle(const Vec3d& center, double radius) {
  Particle p;
  p.center = center;
  p.radius = radius;
  return p;
}

TEST(Evolution, DriftingShapeAndNoiseTranslateTheCloud) {
  CloudModel m;
  m.voxel_size = 0.25;
  m.skin = 0.5;
  m.spheres.push_back({{0, 0, 0}, 4});
  m.pyroclastic.layers = 2;
  m.pyroclastic.amplitude = 1;
  m.pyroclastic.noise.frequency = 0.4;
  m.particles.push_back(particle({5, 0, 0}, 2));
  Evolution e;
  e.drift = e.noise_drift = {0.5, -0.25, 0.125};  // after 4 s: (2, -1, 0.5) m = (8, -4, 2) voxels
  CloudVolume v0 = build_cloud(m), v4 = build_cloud(model_at(m, e, 4));
  EXPECT_EQ(v0.stats.active_voxels, v4.stats.active_voxels);
  const openvdb::Coord shift(8, -4, 2);
  EXPECT_EQ(v4.stats.bounds.min(), v0.stats.bounds.min() + shift);
  auto a = v0.density->getConstAccessor(), b = v4.density->getConstAccessor();
  double worst = 0;
  for (auto it = v0.density->cbeginValueOn(); it; ++it) {
    if (!it.isVoxelValue()) continue;
    worst = squall::test::worse(worst, double(std::abs(b.getValue(it.getCoord() + shift) - *it)));
  }
  EXPECT_LT(worst, 1e-4);
  // The noise alone moving changes the cloud.
  Evolution n;
  n.noise_drift = {1, 0, 0};
  CloudVolume w = build_cloud(model_at(m, n, 1));
  EXPECT_NE(w.stats.active_voxels, v0.stats.active_voxels);
}

TEST(Evolution, AdvectionTimeGrowsAndBadRatesAreRejected) {
  CloudModel m;
  m.spheres.push_back({{0, 0, 0}, 4});
  Evolution e;
  e.advection_rate = 0.5;
  EXPECT_DOUBLE_EQ(model_at(m, e, 3).advection.time, 1.5);
  e.advection_rate = -1;
  EXPECT_THROW(validate(e), Error);
  e.advection_rate = 0;
  e.drift[1] = std::nan("");
  test::expect_error(Code::InvalidArgument, "evolution.drift.y", [&] { validate(e); });
}

// A noise drifts only where a stage uses it: after a drift past the noise offsets' bound, the error names
// the particles' noise, not the pattern of pyroclastic layers the model does not have.
TEST(Evolution, ADriftPastTheBoundNamesANoiseInUse) {
  CloudModel m;
  m.particles.push_back(particle({0, 0, 0}, 4));
  Evolution e;
  e.noise_drift = {1e6, 0, 0};
  const CloudModel later = model_at(m, e, 2000);  // offsets -2e9 m
  EXPECT_EQ(later.pyroclastic.noise.offset, m.pyroclastic.noise.offset);
  EXPECT_EQ(later.temperature.noise.offset, m.temperature.noise.offset);
  test::expect_error(Code::InvalidArgument, "model.particles[0].noise.offset", [&] { validate(later, "model"); });
  m.pyroclastic.layers = 1;
  m.temperature.enabled = true;
  EXPECT_EQ(model_at(m, e, 2000).pyroclastic.noise.offset[0], m.pyroclastic.noise.offset[0] - 2e9);
  EXPECT_EQ(model_at(m, e, 2000).temperature.noise.offset[0], m.temperature.noise.offset[0] - 2e9);
}

}  // namespace
}  // namespace squall::clouds
