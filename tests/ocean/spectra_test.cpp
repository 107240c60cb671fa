// The pure formulas (kernels/ocean/spectra.h, kernels/common/dispersion.h) against closed forms. Equation
// numbers: J. Tessendorf, "Gilligan: A Prototype Framework for Simulating and Rendering Maritime
// Environments" (2017), sec. 2; "App A": its App. A, J. Tessendorf, "Simulating Ocean Water".
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "common/dispersion.h"
#include "common/sincos.h"
#include "common/surface_normal.h"
#include "ocean/cpu_reference.h"
#include "ocean/spectra.h"
#include "ocean/spectrum_setup.h"
#include "support/worst.h"

namespace {

constexpr double kG = 9.81;

double argmax(double (*s)(double), double lo, double hi) {
  double best = lo, value = -1;
  for (int i = 0; i <= 200000; ++i) {
    double w = lo + (hi - lo) * i / 200000.0;
    if (s(w) > value) value = s(w), best = w;
  }
  return best;
}

TEST(Spectra, PiersonMoskowitzPeaksAtOmegaPAndHasClosedFormM0) {
  static double wp = sq_pm_omega_p(kG, 10.0);
  EXPECT_NEAR(wp, 0.879 * kG / 10, 1e-12);
  double peak = argmax([](double w) { return sq_pierson_moskowitz(w, 0.0081, kG, wp); }, 0.2, 3.0);
  EXPECT_NEAR(peak / wp, 1.0, 1e-4);
  // m0 = alpha g^2 / (5 w_p^4); Hs = 4 sqrt(m0) = 2.122 m at U = 10 m/s, g = 9.81 (0.2084 U^2 / g = 2.124)
  double m0 = 0, dw = 1e-4;
  for (double w = 0.5 * dw; w < 60; w += dw) m0 += sq_pierson_moskowitz(w, 0.0081, kG, wp) * dw;
  double closed = 0.0081 * kG * kG / (5 * std::pow(wp, 4));
  EXPECT_NEAR(m0 / closed, 1.0, 1e-5);
  EXPECT_NEAR(4 * std::sqrt(closed), 0.2084 * 100 / kG, 0.005);
}

TEST(Spectra, JonswapPeaksAtOmegaPAndIsContinuous) {
  static double wp = sq_jonswap_omega_p(kG, 12.0, 50e3);
  static double alpha = sq_jonswap_alpha(kG, 12.0, 50e3);
  // eq 8 is the standard 22 (g^2 / (U X))^(1/3) up to 7 pi / 22 and the exponent 0.33 instead of 1/3
  double x = kG * 50e3 / (12.0 * 12.0);
  EXPECT_NEAR(wp / (22 * std::cbrt(kG * kG / (12.0 * 50e3))), 7 * SQUALL_PI / 22 * std::pow(x, 1.0 / 3 - 0.33), 1e-12);
  double peak = argmax([](double w) { return sq_jonswap(w, alpha, kG, wp, 3.3, 0.07, 0.09); }, 0.2, 3.0);
  EXPECT_NEAR(peak / wp, 1.0, 1e-3);
  double below = sq_jonswap(wp * (1 - 1e-9), alpha, kG, wp, 3.3, 0.07, 0.09);
  double above = sq_jonswap(wp * (1 + 1e-9), alpha, kG, wp, 3.3, 0.07, 0.09);
  EXPECT_NEAR(below / above, 1.0, 1e-6);
  // at the peak the enhancement is exactly gamma over PM of the same alpha
  EXPECT_NEAR(sq_jonswap(wp, alpha, kG, wp, 3.3, 0.07, 0.09) / sq_pierson_moskowitz(wp, alpha, kG, wp), 3.3, 1e-12);
  // eq 7, alpha = 0.076 (g X / U^2)^-0.22, and the enhancement gamma^exp(-(w - w_p)^2 / (2 sigma^2 w_p^2)) one
  // sigma from the peak, sigma_a = 0.07 below it and sigma_b = 0.09 above: 3.3^exp(-1/2); at 0.07 w_p above
  // it, 3.3^exp(-(0.07 / 0.09)^2 / 2). Values typed by hand.
  EXPECT_NEAR(alpha, 0.01269734, 1e-8);
  EXPECT_NEAR(sq_peak_enhancement(wp * (1 - 0.07), wp, 3.3, 0.07, 0.09), 2.062978, 1e-6);
  EXPECT_NEAR(sq_peak_enhancement(wp * (1 + 0.09), wp, 3.3, 0.07, 0.09), 2.062978, 1e-6);
  EXPECT_NEAR(sq_peak_enhancement(wp * (1 + 0.07), wp, 3.3, 0.07, 0.09), 2.416447, 1e-6);
  static double wpm = wp;
  double mpeak = argmax([](double w) { return sq_modified_jonswap(w, kG, 12.0, wpm, 0.07, 0.09); }, 0.2, 3.0);
  EXPECT_NEAR(mpeak / wp, 1.0, 1e-3);
}

// Donelan, Hamilton and Hui (1985), in the modified JONSWAP's nu = U / (2 pi c_p), with r = U / c_p:
// gamma = 1.7 + 6 log10(r) over 1 <= r < 5 and 1.7 below, so continuous at r = 1 and held past 5;
// beta = 0.006 r^0.55.
TEST(Spectra, ModifiedJonswapIsDonelansInUOverCp) {
  auto nu = [](double u_over_cp) { return u_over_cp / (2 * SQUALL_PI); };
  EXPECT_NEAR(sq_modified_jonswap_nu(kG, 12.0, 1.5 * kG / 12.0), nu(1.5), 1e-15);
  EXPECT_NEAR(sq_modified_jonswap_gamma(nu(3)), 1.7 + 6 * std::log10(3.0), 1e-12);  // 4.563
  EXPECT_NEAR(sq_modified_jonswap_gamma(nu(1 - 1e-9)), 1.7, 1e-12);
  EXPECT_NEAR(sq_modified_jonswap_gamma(nu(1 + 1e-9)), 1.7, 1e-7);
  EXPECT_NEAR(sq_modified_jonswap_gamma(nu(0.85)), 1.7, 1e-12);
  EXPECT_NEAR(sq_modified_jonswap_gamma(nu(7.5)), 1.7 + 6 * std::log10(5.0), 1e-12);  // 5.894
  EXPECT_NEAR(sq_modified_jonswap_beta(nu(1.5)), 0.006 * std::pow(1.5, 0.55), 1e-15);
  EXPECT_NEAR(sq_modified_jonswap_beta(nu(1)), 0.006, 1e-15);
  // At the peak the spectrum is beta g^2 w_p^-5 e^-1 gamma.
  const double wp = 2.0, U = 1.5 * kG / wp;
  EXPECT_NEAR(
      sq_modified_jonswap(wp, kG, U, wp, 0.07, 0.09) /
          (0.006 * std::pow(1.5, 0.55) * kG * kG / std::pow(wp, 5) * std::exp(-1.0) * (1.7 + 6 * std::log10(1.5))),
      1.0, 1e-12);
}

// Hasselmann, Dunckel and Ewing (1980): s = 9.77 (w / w_p)^mu above the peak with mu = -2.33 - 1.45 (U / c_p -
// 1.17), c_p = g / w_p: one exponent for the whole spectrum, so s is a power law of w / w_p.
TEST(Spectra, JonswapSpreadingIsAPowerLawWithThePeaksExponent) {
  const double wp = 1.0, U = 10.0, mu = -2.33 - 1.45 * (U * wp / kG - 1.17);
  EXPECT_NEAR(sq_jonswap_spread_s(2 * wp, wp, U, kG), 9.77 * std::pow(2.0, mu), 1e-12);  // 2.2607
  for (double w : {1.0, 1.5, 3.0, 7.0})
    EXPECT_NEAR(sq_jonswap_spread_s(2 * w, wp, U, kG) / sq_jonswap_spread_s(w, wp, U, kG), std::pow(2.0, mu), 1e-12)
        << w;
  EXPECT_NEAR(sq_jonswap_spread_s(0.5 * wp, wp, U, kG), 6.97 * std::pow(0.5, 4.06), 1e-12);
}

TEST(Spectra, TmaDepthFactorLimits) {
  // deep water: r -> 1; shallow: r -> w*^2 / 2 (Kitaigorodskii)
  EXPECT_NEAR(sq_tma_r(1.0, 1e4, kG), 1.0, 1e-9);
  double ws2 = 0.5 * 0.5 * 0.01 / kG;
  EXPECT_NEAR(sq_tma_r(0.5, 0.01, kG) / (0.5 * ws2), 1.0, 1e-3);
  // f solves eq 23 and equals 1 / tanh(k h) with k from the shallow dispersion relation
  double f = sq_tma_f(0.3);
  EXPECT_NEAR(f * std::tanh(0.3 * f), 1.0, 1e-10);
  double kh = 0.3 * f;  // w*^2 f = k h
  EXPECT_NEAR(sq_tma_r(std::sqrt(0.3 * kG / 5.0), 5.0, kG),
              std::pow(std::tanh(kh), 2) / (1 + 2 * kh / std::sinh(2 * kh)), 1e-9);
}

TEST(Spectra, MultipeakShapeIntegral) {
  // integral of the shape against a fine midpoint rule
  double sum = 0, dr = 1e-5;
  for (double r = 0.5 * dr; r < 100; r += dr) sum += sq_multipeak_shape(r, 1.835, 22.2222, 4.211, 5, 8) * dr;
  EXPECT_NEAR(sq_multipeak_shape_integral(1.835, 22.2222, 4.211, 5, 8) / sum, 1.0, 1e-4);
  // the Gaussian part alone: A sqrt(pi / B)
  EXPECT_NEAR(sq_multipeak_shape_integral(1.835, 22.2222, 0, 5, 8), 1.835 * std::sqrt(SQUALL_PI / 22.2222), 1e-6);
}

SpectrumParams spread(int model) {
  SpectrumParams p{};
  p.spreading = model;
  p.g = kG;
  p.wind_speed = 10;
  p.omega_p = sq_pm_omega_p(kG, 10);
  p.omega_mean = 1.2 * p.omega_p;
  p.theta0 = 0.7;
  return p;
}

TEST(Spectra, EveryDirectionalModelIntegratesToOneAndPeaksDownwind) {
  for (int model = SQUALL_SPREAD_ISOTROPIC; model <= SQUALL_SPREAD_HYPERBOLIC; ++model) {
    SpectrumParams p = spread(model);
    for (double r : {0.3, 0.5, 0.8, 1.0, 1.2, 2.0, 5.0}) {
      double w = r * p.omega_p;
      const int n = 20000;
      double sum = 0, best = -1, best_theta = 0;
      for (int i = 0; i < n; ++i) {
        double theta = -SQUALL_PI + 2 * SQUALL_PI * (i + 0.5) / n;
        double d = sq_spreading(p, sq_angle_difference(theta, p.theta0), w);
        sum += d * 2 * SQUALL_PI / n;
        if (d > best) best = d, best_theta = theta;
      }
      EXPECT_NEAR(sum, 1.0, 1e-4) << "model " << model << " w/w_p " << r;
      if (model != SQUALL_SPREAD_ISOTROPIC) {
        EXPECT_NEAR(best_theta, p.theta0, 2 * SQUALL_PI / n) << "model " << model << " w/w_p " << r;
      }
    }
  }
  // eq 27 as printed, Pierson's (2/pi) cos(theta), would integrate to 4/pi, not 1: the fixed form is cos^2
  EXPECT_NEAR(sq_spreading(spread(SQUALL_SPREAD_PIERSON_COS2), 0.0, 1.0), 2 / SQUALL_PI, 1e-12);
}

// Integral of D(d) cos d over the circle: a spread's first circular moment, by the midpoint rule.
double first_moment(const SpectrumParams& p, double w) {
  const int n = 200000;
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    const double d = -SQUALL_PI + 2 * SQUALL_PI * (i + 0.5) / n;
    sum += sq_spreading(p, d, w) * std::cos(d);
  }
  return sum * 2 * SQUALL_PI / n;
}

// The spreads' parameters at points of their published forms, the values typed by hand: Mitsuyasu's s_p =
// 11.5 (w_p U / g)^-2.5 = 15.8754 at w_p = 0.879 g / U, s = s_p (w / w_p)^5 below the peak and s_p (w /
// w_p)^-2.5 above (eqs 34-37); Krylov's s = 1.8 w_mean / w (eq 31); Donelan's beta = 2.61 r^1.3, 2.28 r^-1.3,
// 1.24 (eq 46). Then each spread's first circular moment against its closed form in that parameter: s / (s +
// 1) for cos^{2s}(d / 2); I1(c) / I0(c) for von Mises with c = ln 2 / (2 (1 - 2^(-1/s))) (eqs 43-44);
// Gamma(s/2 + 1) Gamma(s/2 + 1) / (Gamma(s/2 + 1/2) Gamma(s/2 + 3/2)) for Krylov's cos^s(d) on the half
// plane; 8 / (3 pi) for (2 / pi) cos^2(d).
TEST(Spectra, SpreadingParametersAreTheirPublishedValues) {
  const SpectrumParams mitsuyasu = spread(SQUALL_SPREAD_MITSUYASU);
  const double wp = mitsuyasu.omega_p, U = mitsuyasu.wind_speed;
  EXPECT_NEAR(sq_mitsuyasu_s(0.5 * wp, wp, U, kG), 0.496107, 1e-6);
  EXPECT_NEAR(sq_mitsuyasu_s(wp, wp, U, kG), 15.875436, 1e-6);
  EXPECT_NEAR(sq_mitsuyasu_s(2 * wp, wp, U, kG), 2.806407, 1e-6);
  const SpectrumParams krylov = spread(SQUALL_SPREAD_KRYLOV);
  EXPECT_NEAR(sq_krylov_s(krylov, krylov.omega_mean), 1.8, 1e-12);
  EXPECT_NEAR(sq_krylov_s(krylov, 2 * krylov.omega_mean), 0.9, 1e-12);
  EXPECT_NEAR(sq_hyperbolic_beta(0.8), 1.952799, 1e-6);
  EXPECT_NEAR(sq_hyperbolic_beta(1.2), 1.798868, 1e-6);
  EXPECT_DOUBLE_EQ(sq_hyperbolic_beta(0.5), 1.24);
  EXPECT_DOUBLE_EQ(sq_hyperbolic_beta(2.0), 1.24);

  const double s = 2.806407;  // Mitsuyasu's at 2 w_p
  EXPECT_NEAR(first_moment(mitsuyasu, 2 * wp), s / (s + 1), 1e-6);
  const double c = std::log(2.0) / (2 * (1 - std::pow(2.0, -1 / s)));
  EXPECT_NEAR(first_moment(spread(SQUALL_SPREAD_VON_MISES), 2 * wp),
              std::cyl_bessel_i(1.0, c) / std::cyl_bessel_i(0.0, c), 1e-6);
  const double h = 0.45;  // Krylov's s / 2 at 2 w_mean
  EXPECT_NEAR(first_moment(krylov, 2 * krylov.omega_mean),
              std::exp(2 * std::lgamma(h + 1) - std::lgamma(h + 0.5) - std::lgamma(h + 1.5)), 1e-6);
  EXPECT_NEAR(first_moment(spread(SQUALL_SPREAD_PIERSON_COS2), wp), 8 / (3 * SQUALL_PI), 1e-6);
}

TEST(Spectra, VonMisesBesselAndPhillipsClosedForms) {
  EXPECT_NEAR(sq_bessel_i0_scaled(1.0), 1.2660658777520082 * std::exp(-1.0), 3e-7);
  EXPECT_NEAR(sq_bessel_i0_scaled(10.0), 2815.716628466254 * std::exp(-10.0), 3e-7 * 2815.7 * std::exp(-10.0));
  SpectrumParams p{};
  p.spectrum = SQUALL_SPECTRUM_PHILLIPS;
  p.phillips_amplitude = 2e-3;
  p.phillips_length = 31.0 * 31.0 / kG;
  p.phillips_cutoff = 1.0;
  p.phillips_exponent = 2;
  p.theta0 = 0;
  double kx = 0.03, ky = 0.04, k = 0.05, kL = k * p.phillips_length;
  double expected = 2e-3 * std::exp(-1 / (kL * kL)) / std::pow(k, 4) * std::pow(kx / k, 2) * std::exp(-k * k);
  EXPECT_NEAR(sq_phillips(p, kx, ky) / expected, 1.0, 1e-12);
  EXPECT_EQ(sq_phillips(p, 0, 0), 0.0);
}

TEST(Spectra, SpatialSpectrumIntegratesToHalfM0) {
  // eq 3: the integral of P over the plane is m0 / 2 (the other half comes from P(-k) in App A eq 43)
  squall::ocean::LayerSpec L;
  L.spectrum = squall::ocean::SpectrumModel::Jonswap;
  L.spreading = squall::ocean::SpreadingModel::Mitsuyasu;
  L.dispersion = squall::ocean::DispersionKind::Combined;
  L.depth = 30;
  double sum = 0;
  const int nk = 3000, nt = 256;
  double u0 = std::log(1e-3), du = (std::log(50.0) - u0) / nk;
  for (int a = 0; a < nk; ++a) {
    double k = std::exp(u0 + (a + 0.5) * du);
    for (int b = 0; b < nt; ++b) {
      double th = 2 * SQUALL_PI * (b + 0.5) / nt;
      sum += squall::ocean::CpuReference::spectrum(L, k * std::cos(th), k * std::sin(th)) * k * k * du * 2 * SQUALL_PI /
             nt;
    }
  }
  double wp = sq_jonswap_omega_p(kG, L.wind_speed, L.fetch), alpha = sq_jonswap_alpha(kG, L.wind_speed, L.fetch);
  double m0 = 0, dw = 1e-4;
  for (double w = 0.5 * dw; w < 60; w += dw) m0 += sq_jonswap(w, alpha, kG, wp, 3.3, 0.07, 0.09) * dw;
  EXPECT_NEAR(sum / (0.5 * m0), 1.0, 2e-3);
}

TEST(Dispersion, GroupVelocityMatchesFiniteDifferenceAndLimits) {
  for (int kind = SQUALL_DISPERSION_DEEP; kind <= SQUALL_DISPERSION_COMBINED; ++kind)
    for (float depth : {1.0f, 10.0f, 1e4f})
      for (double k = 1e-3; k <= 1e3; k *= 3.7) {
        Dispersion d{kind, 9.81f, depth, 2.7e-3f};
        double h = 1e-2 * k;
        double fd = (dispersion_omega(float(k + h), d) - dispersion_omega(float(k - h), d)) / (2 * h);
        EXPECT_NEAR(dispersion_group_velocity(float(k), d) / fd, 1.0, 2e-3) << kind << " " << depth << " " << k;
      }
  Dispersion deep{SQUALL_DISPERSION_DEEP, 9.81f, 1, 0};
  EXPECT_NEAR(dispersion_omega(1.0f, deep), std::sqrt(9.81), 1e-6);
  EXPECT_NEAR(dispersion_group_velocity(1.0f, deep), 0.5 * std::sqrt(9.81), 1e-6);
  Dispersion shallow{SQUALL_DISPERSION_SHALLOW, 9.81f, 1e4f, 0};
  EXPECT_NEAR(dispersion_omega(0.5f, shallow) / dispersion_omega(0.5f, deep), 1.0, 1e-6);
  Dispersion shallow1{SQUALL_DISPERSION_SHALLOW, 9.81f, 2.0f, 0};
  EXPECT_NEAR(dispersion_group_velocity(0.0f, shallow1), std::sqrt(9.81 * 2.0), 1e-5);
  EXPECT_NEAR(dispersion_group_velocity(1e-4f, shallow1), std::sqrt(9.81 * 2.0), 1e-3);
  EXPECT_EQ(dispersion_omega(0.0f, deep), 0.0f);
  Dispersion capillary{SQUALL_DISPERSION_CAPILLARY, 9.81f, 1, 0};  // l = 0 turns capillarity off
  EXPECT_EQ(dispersion_omega(3.0f, capillary), dispersion_omega(3.0f, deep));
}

// The largest error of sq_sincos_turns(f_hi, f_lo, t_hi, t_lo) against sin and cos of 2 pi f t, f and t in
// double split into two floats each as the host splits them, over n random f in [0, f_max] turns per second
// and t in [-t_max, t_max]; the reference phase f t reduced to whole turns in long double.
double sincos_turns_error(double f_max, double t_max, int n) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> f_of(0, f_max), t_of(-t_max, t_max);
  double worst = 0;
  for (int i = 0; i < n; ++i) {
    const double f = f_of(rng), t = t_of(rng);
    const float f_hi = float(f), f_lo = float(f - f_hi), t_hi = float(t), t_lo = float(t - t_hi);
    float s, c;
    sq_sincos_turns(f_hi, f_lo, t_hi, t_lo, &s, &c);
    const long double turns = (long double)f * (long double)t;
    const double phase = double(2 * M_PIl * (turns - std::floor(turns)));
    worst = squall::test::worse(worst, std::abs(s - std::sin(phase)), std::abs(c - std::cos(phase)));
  }
  return worst;
}

TEST(SinCosPhase, RoundsToTheNearestIntegerTiesToEvenAsRintDoes) {
  std::vector<float> xs = {0.0f,       -0.0f,      0.5f,       -0.5f,       1.5f,       2.5f,        -2.5f, 0.49999997f,
                           4194303.5f, 4194304.5f, 8388607.5f, -8388607.5f, 8388608.0f, 16777217.0f, 1e30f, -1e30f};
  std::mt19937 rng(11);
  for (double scale : {1.0, 1e3, 1e6, 1e7, 1e8})
    for (int i = 0; i < 20000; ++i) xs.push_back(float(std::uniform_real_distribution<double>(-scale, scale)(rng)));
  for (float x : xs) {
    EXPECT_EQ(sq_rint(x), std::rint(x)) << "x = " << x;
    EXPECT_EQ(std::signbit(sq_rint(x)), std::signbit(std::rint(x))) << "x = " << x;
  }
  EXPECT_TRUE(std::isnan(sq_rint(NAN)));
  EXPECT_EQ(sq_rint(INFINITY), INFINITY);
}

TEST(SinCosPhase, EveryQuadrantOfOneTurnToAFewUlps) {
  double worst = 0;
  for (int i = -40000; i <= 40000; ++i) {  // -1 .. 1 turn, through every quadrant's edges
    const float x = float(i / 40000.0);
    float s, c;
    sq_sincos_turn(x, &s, &c);
    const double phase = 2 * M_PI * double(x);
    worst = squall::test::worse(worst, std::abs(s - std::sin(phase)), std::abs(c - std::cos(phase)));
  }
  EXPECT_LT(worst, 3e-7);
}

// A phase f t in turns keeps its fraction however many whole turns it holds: f up to 10 turns per second
// (w = 63 rad/s, a 2.5 cm capillary wave) within 1e-6 up to t = 1e6 s, and through SimTime's whole range
// (1e9 s) within the two-float f and t's split and the cross terms' roundings, 3 f t 2^-47 turn (1.3e-3 rad
// there). In one float, f t past 2^24 turns has no fraction left.
TEST(SinCosPhase, APhaseInTurnsKeepsItsFractionAtAnyTime) {
  EXPECT_LT(sincos_turns_error(10, 600, 200000), 1e-6);
  EXPECT_LT(sincos_turns_error(10, 1e6, 200000), 1e-6);
  EXPECT_LT(sincos_turns_error(10, 1e9, 200000), 1e-6 + 2 * M_PI * 3 * 10 * 1e9 * std::ldexp(1.0, -47));
}

// Krylov's mean frequency (eq 31) of a Multipeak spectrum is m1 / m0 of all its partials: a swell at 0.01
// rad/s beside a sea at 5 rad/s adds its moments to the sea's, each taken over its own partial's range.
TEST(Spectra, KrylovsMeanFrequencyCountsEveryPartial) {
  // Narrow Gaussian partials (c = 0, b = 400: sigma 0.035 w_p) are symmetric about their peaks and hold
  // their m0 = (Hs / 4)^2: m1 / m0 of the sum is the peaks' mean weighted by Hs^2, (4 x 5 + 1 x 0.01) / 5.
  squall::ocean::LayerSpec L;
  L.spectrum = squall::ocean::SpectrumModel::Multipeak;
  L.spreading = squall::ocean::SpreadingModel::Krylov;
  L.partials = {{5.0, 2.0, 1, 400, 0}, {0.01, 1.0, 1, 400, 0}};
  EXPECT_NEAR(squall::ocean::derive_spectrum(L).omega_mean, 4.002, 1e-5);
  EXPECT_NEAR(squall::ocean::CpuReference::mean_frequency(L), 4.002, 1e-5);
}

// A hump alone (a = 0) has m_j = scale c w_p^(j+1) K^((j+1-n)/m) Gamma((n-j-1)/m) / m, K = 7.987 (r = w / w_p,
// s = K r^-m): its mean frequency is w_p K^(1/m) Gamma((n-2)/m) / Gamma((n-1)/m), 8.2 w_p for n = 2.2, m = 8,
// a quarter of whose m1 lies past 1000 w_p, where the quadrature once stopped.
TEST(Spectra, KrylovsMeanFrequencyOfAHeavyTailIsItsClosedForm) {
  squall::ocean::LayerSpec L;
  L.spectrum = squall::ocean::SpectrumModel::Multipeak;
  L.spreading = squall::ocean::SpreadingModel::Krylov;
  L.partials = {{1.0, 1.0, 0, 22.2222, 1, 2.2, 8}};
  const double expected = std::pow(7.987, 1 / 8.0) * std::tgamma(0.2 / 8) / std::tgamma(1.2 / 8);
  EXPECT_NEAR(expected, 8.2, 0.1);
  EXPECT_NEAR(squall::ocean::derive_spectrum(L).omega_mean, expected, 1e-3 * expected);
  EXPECT_NEAR(squall::ocean::CpuReference::mean_frequency(L), expected, 1e-3 * expected);
}

TEST(SinCosPhase, TheFractionOfAProductOfTwoFloatsIsExactToARounding) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> a_of(-100, 100), log_b_of(-3, 9);  // products of 1e-5 to 1e11 turns
  double worst = 0;
  for (int i = 0; i < 200000; ++i) {
    const float a = a_of(rng), b = std::copysign(std::pow(10.0f, log_b_of(rng)), a_of(rng));
    const long double turns = (long double)a * (long double)b;  // exact: 48 bits
    const double fraction = double(turns - std::nearbyint(turns));
    const double off = std::abs(sq_product_turns(a, b) - fraction);
    worst = squall::test::worse(worst, std::min(off, 1 - off));  // a fraction of +-1/2 may come out as the other
  }
  EXPECT_LT(worst, std::ldexp(1.0, -25) * (1 + 1e-6));
}

// The normal of a displaced surface (Gilligan eq 94) is the unit vector along the tangents' cross product
// for tangents from 1e-3 to 1e18, where the cross product's components (up to 1e36) overflow float when
// squared. Past about 1.8e19 the cross product's own terms overflow (left so: docs/performance.md).
TEST(SurfaceNormal, AUnitVectorAlongTheCrossProductOverEighteenOrdersOfMagnitude) {
  for (double scale : {1.0, 1e-3, 1e10, 1e18}) {
    const double jxx = 0.8 * scale, jyy = 1.3 * scale, jxy = -0.2 * scale, ex = 0.5 * scale, ey = -0.7 * scale;
    float n[3];
    sq_surface_normal(float(jxx), float(jyy), float(jxy), float(ex), float(ey), &n[0], &n[1], &n[2]);
    const double x = jxy * ey - ex * jyy, y = ex * jxy - jxx * ey, z = jxx * jyy - jxy * jxy;
    const double length = std::hypot(x, y, z);
    EXPECT_NEAR(n[0], x / length, 1e-6) << scale;
    EXPECT_NEAR(n[1], y / length, 1e-6) << scale;
    EXPECT_NEAR(n[2], z / length, 1e-6) << scale;
  }
}

}  // namespace
