// The surface current the textures follow: u = grad phi of the ocean's linear potential plus its drift.
// Independent check: for linear waves a surface particle's horizontal displacement is D (choppiness 1,
// App A eq 47 with the crest-sharpening sign), so its velocity is dD/dt, taken here by a central
// difference in time of the engine's displacement output (another kernel, another FFT).
#include <gtest/gtest.h>

#include "common/error.h"
#include "ocean_test_util.h"
#include "support/expect_error.h"

namespace squall::ocean {
namespace {

using test::engine;

TEST(OceanCurrent, OrbitalVelocityIsTheTimeDerivativeOfTheDisplacement) {
  TileSpec spec = test::single(SpectrumModel::PiersonMoskowitz, SpreadingModel::Mitsuyasu, 128, 256);
  spec.layers[0].wind_speed = 10;  // peak wavelength ~ 80 m, 40 cells
  spec.choppiness = 1;
  const double t = 7.3, eps = 2e-3;
  SurfaceCurrent current = engine().surface_current(spec, t);
  ASSERT_EQ(current.nx, 128);
  EXPECT_DOUBLE_EQ(current.dx, 2.0);
  EXPECT_EQ(current.time, t);
  TileFields before = engine().tile(spec, t - eps, Displacement), after = engine().tile(spec, t + eps, Displacement);
  std::vector<float> dDx(current.u.size()), dDy(current.v.size());
  for (size_t n = 0; n < dDx.size(); ++n) {
    dDx[n] = float((after.displacement_x[n] - before.displacement_x[n]) / (2 * eps));
    dDy[n] = float((after.displacement_y[n] - before.displacement_y[n]) / (2 * eps));
  }
  EXPECT_GT(test::rms(dDx), 0.1);  // m/s: real waves
  // Measured 7e-5 (float32 and the eps^2 w^2 / 6 of the time difference); a sign or a factor g/w wrong is O(1).
  EXPECT_LT(test::relative_rms_error(current.u, dDx), 1e-3);
  EXPECT_LT(test::relative_rms_error(current.v, dDy), 1e-3);
}

// With a drift U_D the field translates and the current is U_D on top of the orbital velocity, whose
// mean over the periodic tile is 0 (the k = 0 mode of grad phi is 0).
TEST(OceanCurrent, DriftIsTheMeanCurrent) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 64, 128);
  spec.layers[0].drift_x = 0.3;
  spec.layers[0].drift_y = -0.2;
  SurfaceCurrent current = engine().surface_current(spec, 3.0);
  double u = 0, v = 0;
  for (size_t n = 0; n < current.u.size(); ++n) u += current.u[n], v += current.v[n];
  EXPECT_NEAR(u / current.u.size(), 0.3, 1e-5);
  EXPECT_NEAR(v / current.v.size(), -0.2, 1e-5);
  EXPECT_GT(test::rms(current.u), 0.35);  // the waves' orbital velocity is there too
}

TEST(OceanCurrent, LayersMustShareOneDrift) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 64, 128);
  spec.layers.push_back(spec.layers[0]);
  spec.layers[1].drift_y = 0.5;
  LimitGate gate{Limits{}};
  squall::test::expect_error(Code::InvalidArgument, "ocean.layers[1].drift_y = 0.5 must be equal to layers[0]'s 0",
                             [&] { validate_current(spec, gate, "ocean"); });
  spec.layers[1].drift_y = 0;
  validate_current(spec, gate, "ocean");
}

}  // namespace
}  // namespace squall::ocean
