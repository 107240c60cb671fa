// Characteristic-map advection (eqs 115-117 of J. Tessendorf, "Gilligan: A Prototype Framework for
// Simulating and Rendering Maritime Environments" (2017), and its App. E, J. Tessendorf, "Advection Solver
// Performance with Long Time Steps, and Strategies for Fast and Accurate Numerical Implementation" (2015))
// on App E's rigid rotation test.
#include <gtest/gtest.h>

#include <cmath>

#include "clouds/advection.h"
#include <openvdb/tools/Interpolation.h>

#include "clouds/volume.h"

namespace squall::clouds {
namespace {

// App E Table 1: u = (pi/314) x cross w, w = (0, 1, 0), on [-100, 100]^3.
const double kOmega = M_PI / 314;
Vec3d rotation_velocity(const Vec3d& x) { return {-x[2] * kOmega, 0, x[0] * kOmega}; }  // x cross (0, w, 0)

// The exact backward map: Rodrigues rotation by +a = w dt about w-hat (App E eq 31 with the sign fixed).
Vec3d exact_map(const Vec3d& x, double a) {
  return {x[0] * std::cos(a) + x[2] * std::sin(a), x[1], x[2] * std::cos(a) - x[0] * std::sin(a)};
}

// rms |X_solver - X_exact| / rms |x_perp| over the 20^3 samples.
double relative_map_error(double a, int substeps, AdvectionScheme scheme) {
  double err2 = 0, perp2 = 0;
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 20; ++j)
      for (int k = 0; k < 20; ++k) {
        Vec3d x{-100 + 200.0 * i / 19, -100 + 200.0 * j / 19, -100 + 200.0 * k / 19};
        Vec3d X = characteristic_map(rotation_velocity, x, a / kOmega, substeps, scheme);
        Vec3d E = exact_map(x, a);
        err2 += std::pow(X[0] - E[0], 2) + std::pow(X[1] - E[1], 2) + std::pow(X[2] - E[2], 2);
        perp2 += x[0] * x[0] + x[2] * x[2];
      }
  return std::sqrt(err2 / perp2);
}

// The exact map (whose sign App E's eq 31 misprints) and both schemes' maps tend to x - u dt.
TEST(Advection, SmallStepLimitIsXMinusUDt) {
  Vec3d x{30, -5, 70};
  double dt = 1e-4;
  Vec3d X = exact_map(x, kOmega * dt), u = rotation_velocity(x);
  Vec3d sl = characteristic_map(rotation_velocity, x, dt, 1, AdvectionScheme::SemiLagrangian);
  Vec3d mm = characteristic_map(rotation_velocity, x, dt, 1, AdvectionScheme::ModifiedMacCormack);
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(X[a], x[a] - u[a] * dt, 1e-9);
    EXPECT_NEAR(sl[a], x[a] - u[a] * dt, 1e-12);  // eq 115: exactly one step back along u(x)
    EXPECT_NEAR(mm[a], X[a], 1e-12);              // its error is O(dt^3), SL's here 4e-11 m
  }
}

TEST(Advection, RigidRotationErrorsMatchClosedFormsAndMacCormackBeatsSemiLagrangian) {
  for (double a : {0.03, 0.3, 1.0}) {
    double sl = relative_map_error(a, 1, AdvectionScheme::SemiLagrangian);
    double mm = relative_map_error(a, 1, AdvectionScheme::ModifiedMacCormack);
    // In the rotation plane X_SL = I + aJ and X_MM = (1 - a^2/2) I + aJ; the exact map is cos a I + sin a J.
    double sl_exact = std::hypot(1 - std::cos(a), a - std::sin(a));
    double mm_exact = std::hypot(1 - a * a / 2 - std::cos(a), a - std::sin(a));
    EXPECT_NEAR(sl, sl_exact, 1e-9 * sl_exact) << a;
    EXPECT_NEAR(mm, mm_exact, 1e-9 * mm_exact) << a;
    EXPECT_LT(mm, sl) << a;
  }
  EXPECT_NEAR(relative_map_error(1.0, 1, AdvectionScheme::SemiLagrangian), 0.486, 1e-3);  // sl_exact at a = 1
  EXPECT_NEAR(relative_map_error(1.0, 1, AdvectionScheme::ModifiedMacCormack), 0.164, 1e-3);
  // Orders: slope of log error vs log a is 2 for SL and 3 for MM.
  double s_sl = std::log(relative_map_error(1e-2, 1, AdvectionScheme::SemiLagrangian) /
                         relative_map_error(1e-3, 1, AdvectionScheme::SemiLagrangian)) /
                std::log(10.0);
  double s_mm = std::log(relative_map_error(1e-2, 1, AdvectionScheme::ModifiedMacCormack) /
                         relative_map_error(1e-3, 1, AdvectionScheme::ModifiedMacCormack)) /
                std::log(10.0);
  EXPECT_NEAR(s_sl, 2.0, 0.1);
  EXPECT_NEAR(s_mm, 3.0, 0.1);
  // Sub-steps: 8 SL steps of a/8 beat one SL step of a.
  EXPECT_LT(relative_map_error(1.0, 8, AdvectionScheme::SemiLagrangian),
            relative_map_error(1.0, 1, AdvectionScheme::SemiLagrangian) / 4);
}

// The density of a sphere rotated an eighth of a turn about +y on a sparse grid: modified MacCormack stays
// closer to the exactly rotated sphere than semi-Lagrangian with the same sub-steps.
TEST(Advection, RotatedSphereDensityErrorIsSmallerWithMacCormack) {
  CloudModel m;
  m.voxel_size = 1;
  m.skin = 3;
  const Vec3d c{20, 0, 0};
  m.spheres.push_back({c, 8});
  CloudVolume v = build_cloud(m);
  const double angle = M_PI / 4, time = angle / kOmega;
  const double max_speed = kOmega * 30;  // |u| = w r, r <= 28 m where there is density
  auto error = [&](AdvectionScheme scheme) {
    auto out = advect_density(*v.density, rotation_velocity, max_speed, time, 4, scheme);
    // Exact: rho_T(x) = rho_0(X(x, T)).
    auto exact = v.density->getConstAccessor();
    openvdb::tools::GridSampler<openvdb::FloatGrid::ConstAccessor, openvdb::tools::BoxSampler> sampler(
        exact, v.density->transform());
    auto got = out->getConstAccessor();
    double err = 0;
    for (int i = -40; i <= 40; ++i)
      for (int k = -40; k <= 40; ++k)
        for (int j = -10; j <= 10; j += 2) {
          Vec3d x{double(i), double(j), double(k)};
          Vec3d X = exact_map(x, angle);
          err += std::abs(got.getValue(openvdb::Coord(i, j, k)) - sampler.wsSample(openvdb::Vec3d(X[0], X[1], X[2])));
        }
    return err;
  };
  double sl = error(AdvectionScheme::SemiLagrangian), mm = error(AdvectionScheme::ModifiedMacCormack);
  std::printf("rotated sphere L1 error: SL %.1f, MM %.1f\n", sl, mm);
  EXPECT_LT(mm, 0.5 * sl);
}

}  // namespace
}  // namespace squall::clouds
