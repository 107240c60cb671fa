// eWave propagation physics: energy, the group property, phase speed, Cauchy-Poisson, friction, drift.
// Equation numbers: J. Tessendorf, "Gilligan: A Prototype Framework for Simulating and Rendering Maritime
// Environments" (2017), sec. 3 ("eq N"), and its App. B, J. Tessendorf, "eWave: Using an Exponential Solver
// on the iWave Problem" (2014) ("App B").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>
#include <utility>

#include "ewave_support.h"
#include "support/expect_error.h"
#include "support/test_runtime.h"
#include "support/worst.h"

namespace squall::ewave::test {
namespace {

// A smooth random initial state: a sum of a few Gaussians of height and phi.
void random_initial_state(EWaveConfig& c, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<std::array<double, 5>> bumps;
  for (int b = 0; b < 6; ++b)
    bumps.push_back(
        {u(rng) * c.length_x(), u(rng) * c.length_y(), (1 + 3 * u(rng)) * c.dx, u(rng) - 0.5, u(rng) - 0.5});
  auto sum = [&](int which) {
    return field(c, [&](double x, double y) {
      double v = 0;
      for (auto& b : bumps)
        v += b[which] * std::exp(-((x - b[0]) * (x - b[0]) + (y - b[1]) * (y - b[1])) / (2 * b[2] * b[2]));
      return v;
    });
  };
  c.initial_height = sum(3);
  c.initial_phi = sum(4);
  for (float& p : c.initial_phi) p *= 0.05f;  // phi ~ (g/omega) h at the bumps' scale
}

struct DispersionCase {
  const char* name;
  DispersionKind kind;
  double depth, capillary_length;
};

class EnergyTest : public testing::TestWithParam<DispersionCase> {};

struct Drift {
  double energy;  // relative change of E
  double moved;   // rms change of the height over its initial rms
};

// After 1000 steps of dt from a random smooth state.
Drift drift_over_1000_steps(EWaveConfig c, double dt) {
  random_initial_state(c, 7);
  double e0 = spectral_energy(c.initial_height, c.initial_phi, c);
  EWaveSession s = make_session(c);
  StepInputs in = plain_step(dt);
  in.outputs.height = false;
  for (int n = 0; n < 999; ++n) s.step(in);
  in.outputs.height = true;
  Frame f = s.step(in);
  return {(spectral_energy(f.height, f.phi, c) - e0) / e0,
          rms_difference(f.height, c.initial_height) / rms(c.initial_height)};
}

EWaveConfig energy_config(const DispersionCase& d, bool double_precision) {
  EWaveConfig c = plain_config(64, 64);
  c.double_precision = double_precision;
  c.dispersion = d.kind;
  c.depth = d.depth;
  c.capillary_length = d.capillary_length;
  return c;
}

// E conserved to 1e-4 relative over 1000 steps of 10 ms with no obstruction, trim, sources or friction,
// with the double-precision state (the propagator has determinant 1 for every dispersion).
TEST_P(EnergyTest, ConservedOver1000Steps) {
  if (!squall::test::runtime().device_info().double_precision) GTEST_SKIP() << "device has no fp64";
  const Drift drift = drift_over_1000_steps(energy_config(GetParam(), true), 0.01);
  RecordProperty("relative_drift", (std::ostringstream() << drift.energy).str());
  EXPECT_GT(drift.moved, 0.1) << "the waves must have moved";
  EXPECT_LT(std::abs(drift.energy), 1e-4);
}

// The float state drifts by two roundings a step, told apart by the same steps with dt = 1e-9 (where the
// propagator is the identity to float precision, so that only the FFT round trips act):
// - the round trips are slightly contractive (about -2.1e-7 a step with VkFFT, -1.3e-7 with clFFT on PoCL
//   for white noise; 1000 steps of 10 ms drift 5.5e-4 with VkFFT on NVIDIA's OpenCL, an H200): bounded at
//   17 float epsilons (2^-24) a step;
// - the propagator's float coefficients leave its determinant 1 to a few roundings (measured on PoCL: 3e-5
//   to 1e-4 over 1000 steps, FFTW the most): bounded at 4 float epsilons a step.
TEST_P(EnergyTest, FloatStateDriftIsThatOfFloatRoundings) {
  constexpr double kSteps = 1000, kEpsilon = 0x1p-24;
  const EWaveConfig c = energy_config(GetParam(), false);
  const Drift drift = drift_over_1000_steps(c, 0.01), round_trips = drift_over_1000_steps(c, 1e-9);
  RecordProperty("relative_drift", (std::ostringstream() << drift.energy).str());
  RecordProperty("round_trip_drift", (std::ostringstream() << round_trips.energy).str());
  EXPECT_GT(drift.moved, 0.1) << "the waves must have moved";
  EXPECT_LT(round_trips.moved, 1e-3) << "with dt = 1e-9 the waves must stay";
  EXPECT_LT(std::abs(round_trips.energy), kSteps * 17 * kEpsilon);
  EXPECT_LT(std::abs(drift.energy - round_trips.energy), kSteps * 4 * kEpsilon)
      << "drift " << drift.energy << ", round trips alone " << round_trips.energy;
}

INSTANTIATE_TEST_SUITE_P(AllDispersions, EnergyTest,
                         testing::Values(DispersionCase{"deep", DispersionKind::Deep, 0, 0},
                                         DispersionCase{"shallow", DispersionKind::Shallow, 0.02, 0},
                                         DispersionCase{"capillary", DispersionKind::Capillary, 0, 0.0027},
                                         DispersionCase{"combined", DispersionKind::Combined, 0.02, 0.0027}),
                         [](const auto& info) { return std::string(info.param.name); });

// n steps of dt equal one step of n dt (the exponential solution is exact for any time step, App B sec. 2).
TEST(EWavePhysics, TenStepsOfDtEqualOneStepOfTenDt) {
  EWaveConfig c = plain_config(64, 48);
  c.dispersion = DispersionKind::Combined;
  c.depth = 0.05;
  c.capillary_length = 0.0027;
  random_initial_state(c, 11);
  EWaveSession many = make_session(c), one = make_session(c);
  Frame a;
  for (int n = 0; n < 10; ++n) a = many.step(plain_step(0.004));
  Frame b = one.step(plain_step(0.04));
  double scale = rms(a.height);
  EXPECT_LT(rms_difference(a.height, b.height), 1e-5 * scale);
  EXPECT_LT(rms_difference(a.phi, b.phi), 1e-5 * rms(a.phi));
  EXPECT_GT(rms_difference(a.height, c.initial_height), 0.1 * rms(c.initial_height));
  EXPECT_NEAR(a.time, 0.04, 1e-15);
  EXPECT_EQ(a.step, 10u);
}

// The travelling wave A cos(k0 x - omega t) at t = 0 with `periods` periods across the grid: h = A cos(k0 x),
// phi = (A G/omega) sin(k0 x). Returns k0 and omega.
std::pair<double, double> start_travelling_wave(EWaveConfig& c, int periods, double A) {
  const double k0 = 2 * M_PI * periods / c.length_x(), w = reference_omega(k0, c), G = reference_restoring(k0, c);
  c.initial_height = field(c, [&](double x, double) { return A * std::cos(k0 * x); });
  c.initial_phi = field(c, [&](double x, double) { return A * G / w * std::sin(k0 * x); });
  return {k0, w};
}

// With surface tension, the velocity potential at the surface drives the height as linear theory has it,
// dh/dt = k phi in deep water, and the height drives it back as dphi/dt = -g (1 + (k l)^2) h (L. D. Landau,
// E. M. Lifshitz, "Fluid Mechanics", sec. 61). On 1 cm cells with l = 1 cm, a potential cos(k x) of 8
// periods (k l = 0.79) raises h = (k / omega) sin(omega dt) cos(k x) in a step (it raised 1 + (k l)^2 =
// 1.62 times that), and a height cos(k x) gives phi = -(G / omega) sin(omega dt) cos(k x).
TEST(EWavePhysics, WithSurfaceTensionThePotentialDrivesTheHeightAsLinearTheory) {
  EWaveConfig c = plain_config(64, 64, 0.01);
  c.dispersion = DispersionKind::Capillary;
  c.capillary_length = 0.01;
  const double k = 2 * M_PI * 8 / c.length_x(), w = reference_omega(k, c), G = reference_restoring(k, c), dt = 1e-3;
  const std::vector<float> wave = field(c, [&](double x, double) { return std::cos(k * x); });
  auto worst_off = [&](const std::vector<float>& got, double amplitude) {
    double worst = 0;
    for (size_t i = 0; i < got.size(); ++i) worst = squall::test::worse(worst, std::abs(got[i] - amplitude * wave[i]));
    return worst / std::abs(amplitude);
  };
  EWaveConfig potential = c;
  potential.initial_phi = wave;
  EXPECT_LT(worst_off(make_session(potential).step(plain_step(dt)).height, k / w * std::sin(w * dt)), 1e-4);
  EWaveConfig height = c;
  height.initial_height = wave;
  EXPECT_LT(worst_off(make_session(height).step(plain_step(dt)).phi, -G / w * std::sin(w * dt)), 1e-4);
}

// Plane wave: h = A cos(k0 x), phi = (A G/omega) sin(k0 x) is the travelling wave A cos(k0 x - omega t);
// the measured phase after t gives the phase speed omega/k0.
TEST(EWavePhysics, PlaneWaveMovesAtPhaseSpeed) {
  for (auto kind :
       {DispersionKind::Deep, DispersionKind::Shallow, DispersionKind::Capillary, DispersionKind::Combined}) {
    // 600 columns: the step's kernels run in two launches (a row group of 256 work-items, then the rest),
    // 301 modes a row for the propagator.
    const bool wide = kind == DispersionKind::Deep;
    EWaveConfig c = wide ? plain_config(600, 8) : plain_config(96, 40);
    c.dispersion = kind;
    c.depth = 0.01;
    c.capillary_length = 0.0027;
    const double A = 0.002;
    const auto [k0, w] = start_travelling_wave(c, 5, A);
    EWaveSession s = make_session(c);
    const double dt = 0.003;
    Frame f;
    for (int n = 0; n < 20; ++n) f = s.step(plain_step(dt));
    // Phase of the k0 mode: h = A cos(k0 x - theta) = A (cos k0x cos theta + sin k0x sin theta).
    double cs = 0, sn = 0;
    for (int64_t i = 0; i < c.nx; ++i)
      for (int64_t j = 0; j < c.ny; ++j) {
        double x = (i + 0.5) * c.dx;
        cs += f.height[i + c.nx * j] * std::cos(k0 * x);
        sn += f.height[i + c.nx * j] * std::sin(k0 * x);
      }
    double theta = std::atan2(sn, cs), t = f.time;
    double expected = std::remainder(w * t, 2 * M_PI);
    double speed = (theta + (w * t - expected)) / (k0 * t);  // unwrap with the expected turn count
    EXPECT_NEAR(speed, w / k0, 1e-4 * w / k0) << "dispersion " << int(kind) << ", nx " << c.nx;
    EXPECT_NEAR(std::hypot(cs, sn) * 2 / double(c.cells()), A, 1e-4 * A) << "amplitude, dispersion " << int(kind);
    auto want = field(c, [&](double x, double) { return A * std::cos(k0 * x - w * t); });
    EXPECT_LT(rms_difference(f.height, want), 1e-4 * A) << "dispersion " << int(kind) << ", nx " << c.nx;
  }
}

// Displacement and normals of the oblique plane wave h = A cos(k.x): with the ocean's sign
// (D = sum i k/|k| h~ e^{ik.x}, eq 47's opposite) D = -a (k/|k|) sin(k.x) with a = A cos(omega dt) after a
// step from rest, which moves points toward the crests for lambda > 0, and the normal of the displaced
// surface P = (x + lambda D_x, y + lambda D_y, h) is the cross product of its tangents dP/dx, dP/dy (eq 94).
TEST(EWavePhysics, APlaneWavesDisplacementSharpensItsCrestsAsTheOceansDoes) {
  EWaveConfig c = plain_config(96, 40);
  const double kx = 2 * M_PI * 5 / c.length_x(), ky = 2 * M_PI * 2 / c.length_y(), k = std::hypot(kx, ky);
  const double A = 0.002, lambda = 4, dt = 1e-3;
  c.displacement_scale = lambda;
  c.initial_height = field(c, [&](double x, double y) { return A * std::cos(kx * x + ky * y); });
  EWaveSession s = make_session(c);
  StepInputs in = plain_step(dt);
  in.outputs.displacement = in.outputs.normals = true;
  const Frame f = s.step(in);
  const double a = A * std::cos(reference_omega(k, c) * dt);  // h = a cos(k.x) after the step (phi was 0)
  double worst_d = 0, worst_n = 0;
  for (int64_t j = 0; j < c.ny; ++j)
    for (int64_t i = 0; i < c.nx; ++i) {
      const size_t cell = size_t(i + c.nx * j);
      const double phase = kx * (i + 0.5) * c.dx + ky * (j + 0.5) * c.dy, sn = std::sin(phase), cs = std::cos(phase);
      worst_d = squall::test::worse(worst_d, std::abs(f.displacement_x[cell] + lambda * a * kx / k * sn),
                                    std::abs(f.displacement_y[cell] + lambda * a * ky / k * sn));
      // dP/dx and dP/dy, with dD_i/dx_j = -a k_i k_j / k cos(k.x) and dh/dx_j = -a k_j sin(k.x)
      const double tx[3] = {1 - lambda * a * kx * kx / k * cs, -lambda * a * kx * ky / k * cs, -a * kx * sn};
      const double ty[3] = {-lambda * a * kx * ky / k * cs, 1 - lambda * a * ky * ky / k * cs, -a * ky * sn};
      const double n[3] = {tx[1] * ty[2] - tx[2] * ty[1], tx[2] * ty[0] - tx[0] * ty[2], tx[0] * ty[1] - tx[1] * ty[0]};
      const double norm = std::hypot(n[0], n[1], n[2]);
      for (int q = 0; q < 3; ++q)
        worst_n = squall::test::worse(worst_n, std::abs(f.normals[3 * cell + q] - n[q] / norm));
    }
  EXPECT_LT(worst_d, 1e-4 * lambda * A);  // the other sign is off by up to 2 lambda A k_i / k
  EXPECT_LT(worst_n, 1e-5);               // lambda a k = 0.36: the other sign tilts them by up to about 0.02
}

// Normals are unit vectors however steep the displaced surface: two crossing waves with lambda a k near 3e10
// make z = (1 + lambda dDx/dx)(1 + lambda dDy/dy) near 1e21, whose square overflows float.
TEST(EWavePhysics, NormalsOfAVerySteepDisplacedSurfaceAreUnitVectors) {
  EWaveConfig c = plain_config(96, 40);
  const double kx = 2 * M_PI * 5 / c.length_x(), ky = 2 * M_PI * 2 / c.length_y();
  c.displacement_scale = 1e6;
  c.initial_height = field(c, [&](double x, double y) { return 1000 * (std::cos(kx * x) + std::cos(ky * y)); });
  EWaveSession s = make_session(c);
  StepInputs in = plain_step(1e-3);
  in.outputs.normals = true;
  const Frame f = s.step(in);
  for (size_t cell = 0; cell < c.cells(); ++cell) {
    const float* n = &f.normals[3 * cell];
    ASSERT_NEAR(std::hypot(n[0], n[1], n[2]), 1.0, 1e-5) << "cell " << cell;
  }
}

// Cauchy-Poisson: h0 = A exp(-r^2/(2 s^2)), phi = 0, deep water. Centre height
// h(0, t) = A s^2 int_0^inf k exp(-k^2 s^2/2) cos(sqrt(g k) t) dk (the Hankel-transform solution of the
// linear deep-water equations, App B eqs 1-2), by quadrature in q = sqrt(k).
double cauchy_poisson_centre(double A, double s, double g, double t) {
  const double q_max = std::sqrt(12 / s);  // k = 12/s: the Gaussian weight is e^-72 there
  const int n = 20000;                     // Simpson, even n
  double sum = 0;
  for (int m = 0; m <= n; ++m) {
    double q = q_max * m / n, k = q * q;
    double f = k * std::exp(-k * k * s * s / 2) * std::cos(std::sqrt(g) * q * t) * 2 * q;  // dk = 2 q dq
    sum += f * (m == 0 || m == n ? 1 : (m % 2 ? 4 : 2));
  }
  return A * s * s * sum * (q_max / n) / 3;
}

TEST(EWavePhysics, GaussianPulseCentreFollowsCauchyPoisson) {
  EWaveConfig c = plain_config(128, 128);
  const double A = 0.01, s = 4 * c.dx, x0 = 64.5 * c.dx, y0 = 64.5 * c.dx;  // the centre of cell (64, 64)
  c.initial_height = field(
      c, [&](double x, double y) { return A * std::exp(-((x - x0) * (x - x0) + (y - y0) * (y - y0)) / (2 * s * s)); });
  EWaveSession session = make_session(c);
  const double dt = 0.005;
  double worst = 0, sum2 = 0;
  int count = 0;
  bool went_negative = false;
  for (int n = 1; n <= 80; ++n) {
    Frame f = session.step(plain_step(dt));
    double centre = f.height[64 + 128 * 64];
    double want = cauchy_poisson_centre(A, s, c.gravity, f.time);
    worst = squall::test::worse(worst, std::abs(centre - want));
    sum2 += (centre - want) * (centre - want);
    ++count;
    went_negative |= want < -0.1 * A;
  }
  RecordProperty("rms_error_over_A", (std::ostringstream() << std::sqrt(sum2 / count) / A).str());
  EXPECT_TRUE(went_negative) << "the window must reach the trough that follows the initial collapse";
  EXPECT_LT(std::sqrt(sum2 / count), 0.01 * A);
}

// Eqs 72-73 with S = 0: friction multiplies h and phi by exp(-dt/tau) per step on top of the propagator. On
// a random smooth state, and on a wave filling a grid of 600 columns, which ewave_prepare (where the friction
// is) covers in two launches.
TEST(EWavePhysics, FrictionDecaysByExpMinusDtOverTauPerStep) {
  EWaveConfig bumps = plain_config(64, 64);
  random_initial_state(bumps, 5);
  EWaveConfig wide = plain_config(600, 8);
  start_travelling_wave(wide, 7, 0.002);
  for (const EWaveConfig& c : {bumps, wide}) {
    EWaveConfig damped = c;
    damped.friction_time = 0.05;
    EWaveSession free_session = make_session(c), damped_session = make_session(damped);
    const double dt = 0.01;
    const int steps = 20;
    Frame a, b;
    for (int n = 0; n < steps; ++n) {
      a = free_session.step(plain_step(dt));
      b = damped_session.step(plain_step(dt));
    }
    const double factor = std::exp(-steps * dt / damped.friction_time);  // e^-4
    for (float& v : a.height) v *= float(factor);
    for (float& v : a.phi) v *= float(factor);
    EXPECT_LT(rms_difference(a.height, b.height), 1e-5 * rms(a.height)) << "nx " << c.nx;
    EXPECT_LT(rms_difference(a.phi, b.phi), 1e-5 * rms(a.phi)) << "nx " << c.nx;
  }
}

// With g = 0 (no dynamics) and a constant source, h -> tau S (eq 72).
TEST(EWavePhysics, FrictionWithConstantSourceApproachesTauS) {
  EWaveConfig c = plain_config(32, 32);
  c.gravity = 1e-30;  // effectively no dynamics (gravity must be > 0)
  c.friction_time = 0.02;
  EWaveSession s = make_session(c);
  StepInputs in = plain_step(0.01);
  in.source_height.assign(c.cells(), 0.5f);  // m/s
  Frame f;
  for (int n = 0; n < 60; ++n) f = s.step(in);  // 30 tau
  ASSERT_EQ(f.height.size(), c.cells());
  for (float v : f.height) ASSERT_NEAR(v, 0.02 * 0.5, 1e-6);
}

// A uniform drift of a whole number of cells per step is an exact shift (the semi-Lagrangian advection of
// eq 68-69), by that many cells mod the grid however many periods it crosses: 2^24 + 3 cells in one step,
// where float cannot hold the count, is 3 cells.
TEST(EWavePhysics, WholeCellDriftIsAnExactShift) {
  auto expect_shift = [](double spacing, double dt, double drift_x, double drift_y) {
    EWaveConfig c = plain_config(64, 32, spacing);
    random_initial_state(c, 3);
    EWaveSession still = make_session(c), drifting = make_session(c);
    StepInputs in = plain_step(dt);
    Frame a = still.step(in);
    in.drift_x = drift_x;  // 3 cells (mod 64) per step
    in.drift_y = drift_y;  // -1 cell per step
    Frame b = drifting.step(in);
    for (int64_t j = 0; j < c.ny; ++j)
      for (int64_t i = 0; i < c.nx; ++i) {
        int64_t si = (i - 3 + c.nx) % c.nx, sj = (j + 1) % c.ny;
        ASSERT_EQ(b.height[i + c.nx * j], a.height[si + c.nx * sj]) << dt << ": " << i << "," << j;
        ASSERT_EQ(b.phi[i + c.nx * j], a.phi[si + c.nx * sj]) << dt << ": " << i << "," << j;
      }
  };
  expect_shift(1.0, 0.5, 6.0, -2.0);
  expect_shift(0.25, 8192, 16777219.0 / 32768, -1.0 / 32768);  // 2^24 + 3 cells, exact in double
}

// A drift field's departure point is taken in float: a field that moves cells past 2^22 in a step is refused
// by name (1000 m/s over 1e4 s on 1 mm cells, 1e10 cells, sampled cells 1024 apart); 4e6 passes.
TEST(EWavePhysics, ADriftFieldMovingCellsPastFloatsReachIsRefused) {
  EWaveConfig c = plain_config(16, 16, 1e-3);
  StepInputs in = plain_step(1e4);
  in.drift_field_x.assign(c.cells(), 0.0f);
  in.drift_field_y.assign(c.cells(), 0.0f);
  in.drift_field_y[5] = -1000;
  squall::test::expect_error(Code::InvalidArgument, "inputs.drift_field_y moves a cell up to 1e+10 cells",
                             [&] { validate(in, c); });
  in.drift_field_y[5] = -0.4f;  // 4e6 cells
  validate(in, c);
}

}  // namespace
}  // namespace squall::ewave::test
