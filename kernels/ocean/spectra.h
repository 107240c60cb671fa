/* Pure formulas of the ocean spectra (J. Tessendorf, "Gilligan: A Prototype Framework for Simulating and
 * Rendering Maritime Environments" (2017), sec. 2.3, whose equation numbers are used below, and eq 40 of its
 * App. A, J. Tessendorf, "Simulating Ocean Water"): frequency spectra S(omega), directional spreads
 * D(theta; omega, k) and the spatial spectrum P(k) of eq 3. Shared by the OpenCL kernels
 * (sq_real = float; the program is built with -cl-single-precision-constant) and by host C++ in double
 * precision (the engine's set-up and the FFTW reference). The tests check every formula against closed
 * forms (peak positions, m0, normalization of each D, TMA limits). SI units. Misprints in the printed
 * equations (the exponents of eqs 4, 5 and 13, the sigma_0 ranges of eqs 10 and 18, the normalizations of
 * eqs 27, 29 and 45) are corrected; each fix is marked "fixed". */
#ifndef SQUALL_OCEAN_SPECTRA_H
#define SQUALL_OCEAN_SPECTRA_H

#ifdef __OPENCL_VERSION__
typedef float sq_real;
#else
#include <math.h>
typedef double sq_real;
#endif

#define SQUALL_PI 3.14159265358979323846

/* Model numbers: the values of squall::ocean::SpectrumModel / SpreadingModel. */
#define SQUALL_SPECTRUM_PHILLIPS 0
#define SQUALL_SPECTRUM_PIERSON_MOSKOWITZ 1
#define SQUALL_SPECTRUM_JONSWAP 2
#define SQUALL_SPECTRUM_MODIFIED_JONSWAP 3
#define SQUALL_SPECTRUM_TMA 4
#define SQUALL_SPECTRUM_MULTIPEAK 5

#define SQUALL_SPREAD_ISOTROPIC 0
#define SQUALL_SPREAD_PIERSON_COS2 1
#define SQUALL_SPREAD_KRYLOV 2
#define SQUALL_SPREAD_MITSUYASU 3
#define SQUALL_SPREAD_JONSWAP 4
#define SQUALL_SPREAD_VON_MISES 5
#define SQUALL_SPREAD_HYPERBOLIC 6

#define SQUALL_MAX_PARTIALS 4

/* Everything a spectrum needs, derived once per layer (sq_frequency_setup on the host). */
typedef struct {
  int spectrum, spreading, partials, pad;
  sq_real g, wind_speed, alpha, omega_p, gamma, sigma_a, sigma_b, depth;
  sq_real theta0, omega_mean;
  sq_real phillips_amplitude, phillips_length, phillips_cutoff, phillips_exponent;
  sq_real partial_omega_p[SQUALL_MAX_PARTIALS], partial_scale[SQUALL_MAX_PARTIALS];
  sq_real partial_a[SQUALL_MAX_PARTIALS], partial_b[SQUALL_MAX_PARTIALS], partial_c[SQUALL_MAX_PARTIALS];
  sq_real partial_n[SQUALL_MAX_PARTIALS], partial_m[SQUALL_MAX_PARTIALS];
} SpectrumParams;

/* x^y for x >= 0, as pow (0^y is 0 for y > 0, 1 for y = 0, +inf for y < 0). In the kernels exp(y ln x):
 * OpenCL's pow on PoCL's CPU device goes through an extended-precision log and exp, which took most of
 * ocean_h0's time; this form's relative error is about |y ln x| ulp, under 1e-5 for the exponents and
 * ranges of the spectra below. The host keeps pow in double. */
static inline sq_real sq_powr(sq_real x, sq_real y) {
#ifdef __OPENCL_VERSION__
  if (x > 0) return exp(y * log(x));
  return y > 0 ? (sq_real)0 : (y == 0 ? (sq_real)1 : (sq_real)INFINITY);
#else
  return pow(x, y);
#endif
}

/* ---- parameters of the wind spectra ---- */
static inline sq_real sq_pm_omega_p(sq_real g, sq_real U) { return 0.879 * g / U; } /* eq 4 table */
static inline sq_real sq_jonswap_alpha(sq_real g, sq_real U, sq_real X) {
  return 0.076 * pow(g * X / (U * U), (sq_real)-0.22);
} /* eq 7 */
static inline sq_real sq_jonswap_omega_p(sq_real g, sq_real U, sq_real X) { /* eq 8 */
  return 7.0 * SQUALL_PI * (g / U) * pow(g * X / (U * U), (sq_real)-0.33);
}

/* ---- frequency spectra ---- */
/* eq 4, exponent fixed to (w_p / w)^4 */
static inline sq_real sq_pierson_moskowitz(sq_real w, sq_real alpha, sq_real g, sq_real wp) {
  if (w <= 0) return 0;
  sq_real r = wp / w;
  sq_real w2 = w * w;
  return alpha * g * g / (w2 * w2 * w) * exp(-1.25 * r * r * r * r);
}

/* eqs 6, 10 (fixed: sigma_b for w > w_p), 14: the peak enhancement gamma^delta */
static inline sq_real sq_peak_enhancement(sq_real w, sq_real wp, sq_real gamma, sq_real sa, sq_real sb) {
  sq_real sigma = w <= wp ? sa : sb;
  sq_real d = (w - wp) / (sigma * wp);
  return sq_powr(gamma, exp(-0.5 * d * d));
}

/* eq 5 */
static inline sq_real sq_jonswap(sq_real w, sq_real alpha, sq_real g, sq_real wp, sq_real gamma, sq_real sa,
                                 sq_real sb) {
  return sq_pierson_moskowitz(w, alpha, g, wp) * sq_peak_enhancement(w, wp, gamma, sa, sb);
}

/* eq 19: nu = w_p U / (2 pi g), so that U / c_p = 2 pi nu, c_p = g / w_p the peak's deep-water phase speed */
static inline sq_real sq_modified_jonswap_nu(sq_real g, sq_real U, sq_real wp) {
  return wp * U / (2.0 * SQUALL_PI * g);
}
/* eq 17 fixed: M. A. Donelan, J. Hamilton and W. H. Hui, "Directional spectra of wind-generated waves"
 * (1985): gamma = 1.7 + 6 log10(U / c_p) for 1 <= U / c_p < 5, 1.7 for 0.83 < U / c_p < 1. The printed
 * 6.489 + 6 log nu is that in nu with log10 (6.489 = 1.7 + 6 log10(2 pi)), but its ranges are U / c_p's:
 * read as nu's, gamma would jump from 1.7 to 6.489 at nu = 1 and stay 1.7 for any fetch past a few
 * hundred metres. gamma holds its value at U / c_p = 5 past it. */
static inline sq_real sq_modified_jonswap_gamma(sq_real nu) {
  sq_real u_over_cp = 2.0 * SQUALL_PI * nu;
  if (u_over_cp < 1.0) return 1.7;
  return 1.7 + 6.0 * log10(fmin(u_over_cp, (sq_real)5.0));
}
/* eq 15 fixed the same way: beta = 0.006 (U / c_p)^0.55 (Donelan et al. 1985), the printed 0.006 nu^0.55
 * with nu for U / c_p */
static inline sq_real sq_modified_jonswap_beta(sq_real nu) {
  return 0.006 * sq_powr(2.0 * SQUALL_PI * nu, (sq_real)0.55);
}
/* eq 13 (exponent fixed to (w_p / w)^4) */
static inline sq_real sq_modified_jonswap(sq_real w, sq_real g, sq_real U, sq_real wp, sq_real sa, sq_real sb) {
  if (w <= 0) return 0;
  sq_real nu = sq_modified_jonswap_nu(g, U, wp);
  sq_real r = wp / w;
  return sq_modified_jonswap_beta(nu) * g * g / wp / (w * w * w * w) * exp(-r * r * r * r) *
         sq_peak_enhancement(w, wp, sq_modified_jonswap_gamma(nu), sa, sb);
}

/* eq 23: f tanh(ws2 f) = 1 by Newton from f = max(1, 1/sqrt(ws2)) (f = 1 / tanh(kh)) */
static inline sq_real sq_tma_f(sq_real ws2) {
  sq_real f = fmax((sq_real)1.0, 1.0 / sqrt(ws2));
  for (int i = 0; i < 40; ++i) {
    sq_real th = tanh(ws2 * f), ch = cosh(ws2 * f);
    sq_real step = (f * th - 1.0) / (th + ws2 * f / (ch * ch));
    f = fmax((sq_real)1.0, f - step);
    if (fabs(step) < 1e-7 * f) break;
  }
  return f;
}
/* eqs 21-22: r(w*) = f^-2 [1 + 2 w*^2 f / sinh(2 w*^2 f)]^-1; r -> 1 in deep water, w*^2 / 2 as h -> 0 */
static inline sq_real sq_tma_r(sq_real w, sq_real depth, sq_real g) {
  sq_real ws2 = w * w * depth / g;
  if (ws2 <= 0) return 0;
  sq_real f = sq_tma_f(ws2);
  sq_real x = 2.0 * ws2 * f; /* = 2 k h */
  sq_real x_over_sinh = x < 1e-4 ? (sq_real)1.0 : (x > 80.0 ? (sq_real)0.0 : x / sinh(x));
  return 1.0 / (f * f * (1.0 + x_over_sinh));
}

/* eqs 25-26: the dimensionless shape S_c + S_h of one partial at r = w / w_p; S_h's r^-n exp(-7.987 r^-m)
 * as one exponential, whose factors alone overflow float at small r */
static inline sq_real sq_multipeak_shape(sq_real r, sq_real A, sq_real B, sq_real C, sq_real n, sq_real m) {
  if (r <= 0) return 0;
  sq_real q = r - 1.0;
  return A * exp(-B * q * q) + C * exp(-n * log(r) - 7.987 * sq_powr(r, -m));
}

/* S(w) of the layer's model (not Phillips, which has no S), m^2 s */
static inline sq_real sq_frequency_spectrum(SpectrumParams p, sq_real w) {
  switch (p.spectrum) {
    case SQUALL_SPECTRUM_PIERSON_MOSKOWITZ: return sq_pierson_moskowitz(w, p.alpha, p.g, p.omega_p);
    case SQUALL_SPECTRUM_JONSWAP: return sq_jonswap(w, p.alpha, p.g, p.omega_p, p.gamma, p.sigma_a, p.sigma_b);
    case SQUALL_SPECTRUM_MODIFIED_JONSWAP:
      return sq_modified_jonswap(w, p.g, p.wind_speed, p.omega_p, p.sigma_a, p.sigma_b);
    case SQUALL_SPECTRUM_TMA: /* eq 20 */
      return sq_jonswap(w, p.alpha, p.g, p.omega_p, p.gamma, p.sigma_a, p.sigma_b) * sq_tma_r(w, p.depth, p.g);
    case SQUALL_SPECTRUM_MULTIPEAK: { /* eq 24 */
      sq_real s = 0;
      for (int i = 0; i < p.partials && i < SQUALL_MAX_PARTIALS; ++i)
        s += p.partial_scale[i] * sq_multipeak_shape(w / p.partial_omega_p[i], p.partial_a[i], p.partial_b[i],
                                                     p.partial_c[i], p.partial_n[i], p.partial_m[i]);
      return s;
    }
    default: return 0;
  }
}

/* ---- directional spreads, each integrating to 1 over theta in [-pi, pi) ---- */
/* theta - theta0 wrapped into [-pi, pi) */
static inline sq_real sq_angle_difference(sq_real theta, sq_real theta0) {
  sq_real d = theta - theta0;
  return d - 2.0 * SQUALL_PI * floor((d + SQUALL_PI) / (2.0 * SQUALL_PI));
}

/* exp(-x) I0(x), Abramowitz & Stegun 9.8.1-9.8.2 (relative error < 2e-7) */
static inline sq_real sq_bessel_i0_scaled(sq_real x) {
  x = fabs(x);
  if (x < 3.75) {
    sq_real t = x / 3.75, t2 = t * t;
    sq_real i0 =
        1.0 +
        t2 * (3.5156229 + t2 * (3.0899424 + t2 * (1.2067492 + t2 * (0.2659732 + t2 * (0.0360768 + t2 * 0.0045813)))));
    return i0 * exp(-x);
  }
  sq_real u = 3.75 / x;
  sq_real poly =
      0.39894228 +
      u * (0.01328592 +
           u * (0.00225319 +
                u * (-0.00157565 +
                     u * (0.00916281 + u * (-0.02057706 + u * (0.02635537 + u * (-0.01647633 + u * 0.00392377)))))));
  return poly / sqrt(x);
}

/* eq 34-37: Mitsuyasu's spreading parameter s(w) */
static inline sq_real sq_mitsuyasu_s(sq_real w, sq_real wp, sq_real U, sq_real g) {
  sq_real sp = 11.5 * sq_powr(wp * U / g, (sq_real)-2.5);
  sq_real r = w / wp; /* not w U / g over wp U / g: a wind that rounds to 0 made that 0 / 0 */
  sq_real s = w <= wp ? sp * (r * r * r * r * r) : sp * sq_powr(r, (sq_real)-2.5);
  /* held to [1e-6, 1e12]: a spread narrower than any grid resolves (a wind of 1e-14 m/s overflows s) */
  return fmin(fmax(s, (sq_real)1e-6), (sq_real)1e12);
}

/* Gamma(x + 1) / Gamma(x + 1/2) for x >= 0, the norm of the cos^{2s} and Krylov spreads. In the kernels
 * without lgamma: the recurrence R(x) = R(x + 1) (x + 1/2) / (x + 1) raises x to 6 or more, where the
 * asymptotic series of Abramowitz & Stegun 6.1.47, sqrt(x) (1 + 1/(8x) + 1/(128x^2) - 5/(1024x^3) -
 * 21/(32768x^4)), is within 2e-7. The host takes lgamma in double. */
static inline sq_real sq_gamma_ratio_half(sq_real x) {
#ifdef __OPENCL_VERSION__
  sq_real scale = 1;
  for (; x < 6; x += 1) scale *= (x + 0.5) / (x + 1);
  sq_real u = 1 / x;
  return scale * sqrt(x) * (1 + u * (0.125 + u * (0.0078125 + u * (-0.0048828125 - u * 0.000640869140625))));
#else
  return exp(lgamma(x + 1.0) - lgamma(x + 0.5));
#endif
}

/* eqs 33 / 38: (2^{2s-1} / pi) Gamma^2(s+1) / Gamma(2s+1) cos^{2s}(d/2). The norm is
 * Gamma(s+1) / (2 sqrt(pi) Gamma(s+1/2)) by the duplication formula (Abramowitz & Stegun 6.1.18). cos(d/2)
 * is taken as sin((pi - |d|) / 2), exactly 0 upwind (|d| = pi) in float and double alike and accurate
 * near it: cos(pi/2) rounds to 6e-17 in double and to -4e-8 in float, and at the small s of short waves
 * c^{2s} turns that into 0.9 or 0. */
static inline sq_real sq_cos2s(sq_real d, sq_real s) {
  sq_real norm = sq_gamma_ratio_half(s) / (2.0 * sqrt((sq_real)SQUALL_PI));
  sq_real c = sin(0.5 * ((sq_real)SQUALL_PI - fabs(d)));
  return norm * sq_powr(fmax(c, (sq_real)0.0), 2.0 * s);
}

/* eq 39-41 with the central values: s = s_p (w / w_p)^mu. mu is one per spectrum: the C of eq 41 is the
 * phase speed at the peak, c_p = g / w_p, as in D. E. Hasselmann, M. Dunckel and J. A. Ewing, "Directional
 * wave spectra observed during JONSWAP 1973" (1980), whose parametrization it is (read as each mode's w / k,
 * mu would fall with w and s would no longer be the power law of eq 39). c_p is the deep-water one on a
 * shallow or TMA layer too, as in their deep-water measurements. */
static inline sq_real sq_jonswap_spread_s(sq_real w, sq_real wp, sq_real U, sq_real g) {
  if (w < wp) return 6.97 * sq_powr(w / wp, (sq_real)4.06);
  sq_real mu = -2.33 - 1.45 * (U * wp / g - 1.17);
  return 9.77 * sq_powr(w / wp, mu);
}

/* eq 46 */
static inline sq_real sq_hyperbolic_beta(sq_real r) {
  if (r > 0.56 && r < 0.95) return 2.61 * sq_powr(r, (sq_real)1.3);
  if (r >= 0.95 && r < 1.6) return 2.28 * sq_powr(r, (sq_real)-1.3);
  return 1.24;
}

/* Krylov's exponent of cos^s (eqs 29-31): s = 1.8 w_mean / w, at most 1e4 */
static inline sq_real sq_krylov_s(SpectrumParams p, sq_real w) {
  return w > 0 ? fmin(1.8 * p.omega_mean / w, (sq_real)1e4) : (sq_real)1e4;
}

/* The von Mises concentration (eqs 43-44) c = ln 2 / (1 - cos(width)) with cos(width / 2) = 2^(-1 / (2 s)),
 * written as 1 - cos(width) = -2 expm1(-ln 2 / s): the difference cancelled in float, 42% off at s = 1e7
 * and c infinite past s = 1.16e7 (a light wind's narrow swell). */
static inline sq_real sq_von_mises_c(SpectrumParams p, sq_real w) {
  sq_real s = sq_mitsuyasu_s(w, p.omega_p, p.wind_speed, p.g);
  return log((sq_real)2.0) / (-2.0 * expm1(-log((sq_real)2.0) / s));
}

/* D(theta; w, k), rad^-1. d = theta - theta0 in [-pi, pi). */
static inline sq_real sq_spreading(SpectrumParams p, sq_real d, sq_real w) {
  switch (p.spreading) {
    case SQUALL_SPREAD_ISOTROPIC: return 1.0 / (2.0 * SQUALL_PI);
    case SQUALL_SPREAD_PIERSON_COS2: { /* eq 27 fixed: (2/pi) cos^2 on the half plane */
      sq_real c = cos(d);
      return fabs(d) < 0.5 * SQUALL_PI ? (2.0 / SQUALL_PI) * c * c : 0;
    }
    case SQUALL_SPREAD_KRYLOV: { /* eqs 29-31 fixed normalization */
      if (fabs(d) >= 0.5 * SQUALL_PI) return 0;
      sq_real s = sq_krylov_s(p, w);
      sq_real norm = sq_gamma_ratio_half(0.5 * s) / sqrt((sq_real)SQUALL_PI);
      return norm * sq_powr(fmax(cos(d), (sq_real)0.0), s);
    }
    case SQUALL_SPREAD_MITSUYASU: return sq_cos2s(d, sq_mitsuyasu_s(w, p.omega_p, p.wind_speed, p.g));    /* eq 33 */
    case SQUALL_SPREAD_JONSWAP: return sq_cos2s(d, sq_jonswap_spread_s(w, p.omega_p, p.wind_speed, p.g)); /* eq 38 */
    case SQUALL_SPREAD_VON_MISES: { /* eqs 43-44, with exp(-c) I0(c) against overflow */
      /* c (cos d - 1) as -2 c sin^2(d / 2), which does not cancel */
      sq_real c = sq_von_mises_c(p, w);
      sq_real half_sine = sin(0.5 * d);
      return exp(-2.0 * c * half_sine * half_sine) / (2.0 * SQUALL_PI * sq_bessel_i0_scaled(c));
    }
    case SQUALL_SPREAD_HYPERBOLIC: { /* eq 45 fixed (Donelan), normalized by tanh(beta pi) */
      sq_real beta = sq_hyperbolic_beta(w / p.omega_p);
      sq_real ch = cosh(beta * d);
      return 0.5 * beta / (ch * ch * tanh(beta * (sq_real)SQUALL_PI));
    }
    default: return 0;
  }
}

/* The variance of a narrow spread about its direction, rad^2, where it is a Gaussian in d:
 * cos^{2s}(d / 2) ~ exp(-s d^2 / 4) (Mitsuyasu, JONSWAP), cos^s(d) ~ exp(-s d^2 / 2) (Krylov) and
 * exp(-2 c sin^2(d / 2)) ~ exp(-c d^2 / 2) (von Mises), each to 1 + O(d^4) in the exponent; 0 for the
 * others, which are never narrow. */
static inline sq_real sq_spread_variance(SpectrumParams p, sq_real w) {
  switch (p.spreading) {
    case SQUALL_SPREAD_KRYLOV: return 1.0 / sq_krylov_s(p, w);
    case SQUALL_SPREAD_MITSUYASU: return 2.0 / sq_mitsuyasu_s(w, p.omega_p, p.wind_speed, p.g);
    case SQUALL_SPREAD_JONSWAP: return 2.0 / sq_jonswap_spread_s(w, p.omega_p, p.wind_speed, p.g);
    case SQUALL_SPREAD_VON_MISES: return 1.0 / sq_von_mises_c(p, w);
    default: return 0;
  }
}

/* The angular profile of a grid mode's cell (dkx by dky about (kx, ky)) across the mode's direction, rad: a
 * trapezoid of unit area, the convolution of boxes of widths *a >= *b, with base a + b = (dkx |sin| +
 * dky |cos|) / k and top a - b = |dkx |sin| - dky |cos|| / k. Along an axis a box of dky / k; along a
 * diagonal of a square cell a triangle (the modes of a diagonal lie farther apart across it). */
static inline void sq_mode_cell(sq_real kx, sq_real ky, sq_real dkx, sq_real dky, sq_real* a, sq_real* b) {
  sq_real k = sqrt(kx * kx + ky * ky);
  sq_real across_x = k > 0 ? dkx * fabs(ky) / (k * k) : 0, across_y = k > 0 ? dky * fabs(kx) / (k * k) : 0;
  *a = fmax(across_x, across_y);
  *b = fmin(across_x, across_y);
}

/* z erf(z) + exp(-z^2) / sqrt(pi): the antiderivative of erf, and twice integrated a Gaussian's. */
static inline sq_real sq_erf_integral(sq_real z) { return z * erf(z) + exp(-z * z) / sqrt((sq_real)SQUALL_PI); }

/* D over a mode's angular cell, the trapezoid of sq_mode_cell (a box of width a where b = 0). A spread
 * narrower than the cell (and than 0.25 rad, where it is a Gaussian to a few parts in 1e3) is averaged over
 * it in its Gaussian form: at the cell's centre alone, it put a light wind's swell of s = 3.5e7 on the modes
 * along an axis at sqrt(s / pi) / 2 times its energy, and on none at other angles. The average is the
 * Gaussian convolved with the two boxes: erf's difference over box a, then its antiderivative's second
 * difference over box b. A box b narrower than the Gaussian joins it instead, as the Gaussian of their summed
 * variances, sigma^2 + b^2 / 12 (to O(b^4 / sigma^4); the differences over it would cancel in float). Wider
 * spreads, and a point (a = 0), take D itself: sampled at spacings under sigma, a Gaussian's sum is its
 * integral to 1e-8. */
static inline sq_real sq_cell_spreading(SpectrumParams p, sq_real d, sq_real w, sq_real a, sq_real b) {
  sq_real variance = sq_spread_variance(p, w);
  if (!(variance > 0) || !(variance < a * a) || variance > (sq_real)0.0625) return sq_spreading(p, d, w);
  sq_real r = sqrt(2.0 * variance);                /* erf's unit */
  if (fabs(d) > 0.5 * (a + b) + 6.0 * r) return 0; /* beyond the cell's reach (the differences are rounding) */
  if (b < r) {
    r = sqrt(r * r + b * b / 6.0);
    return (erf((d + 0.5 * a) / r) - erf((d - 0.5 * a) / r)) / (2.0 * a);
  }
  sq_real h = 0.5 * (a + b), q = 0.5 * (a - b);
  sq_real second_difference = sq_erf_integral((d + h) / r) - sq_erf_integral((d + q) / r) -
                              sq_erf_integral((d - q) / r) + sq_erf_integral((d - h) / r);
  return fmax(r * second_difference / (2.0 * a * b), (sq_real)0);
}

/* App A eqs 40-41: Phillips P(k), with |k^.w^|^p (p = 2 in App A eq 40) */
static inline sq_real sq_phillips(SpectrumParams p, sq_real kx, sq_real ky) {
  sq_real k2 = kx * kx + ky * ky;
  if (k2 <= 0) return 0;
  sq_real k = sqrt(k2);
  sq_real kL = k * p.phillips_length;
  sq_real cosine = fabs(kx * cos(p.theta0) + ky * sin(p.theta0)) / k;
  return p.phillips_amplitude * exp(-1.0 / (kL * kL)) / (k2 * k2) * sq_powr(cosine, p.phillips_exponent) *
         exp(-k2 * p.phillips_cutoff * p.phillips_cutoff);
}

/* Eq 3: P(k) = S(w) D(theta; w, k) v_g / (2k), m^4, given w(k) and v_g(k) of the layer's dispersion, with D
 * over an angular cell of widths a, b (sq_mode_cell on a grid; a box of a where b = 0; a point where a = 0). */
static inline sq_real sq_spatial_spectrum(SpectrumParams p, sq_real kx, sq_real ky, sq_real w, sq_real vg, sq_real a,
                                          sq_real b) {
  if (p.spectrum == SQUALL_SPECTRUM_PHILLIPS) return sq_phillips(p, kx, ky);
  sq_real k = sqrt(kx * kx + ky * ky);
  if (k <= 0 || w <= 0) return 0;
  sq_real d = sq_angle_difference(atan2(ky, kx), p.theta0);
  return sq_frequency_spectrum(p, w) * sq_cell_spreading(p, d, w, a, b) * vg / (2.0 * k);
}

#ifndef __OPENCL_VERSION__
/* ---- host only: quadratures for the derived parameters ---- */
/* integral of the multipeak shape over r in [0.02, 2000], where validation asks it to hold all but a
 * hundredth of its energy (sq_multipeak_shape_outside); a log-spaced trapezoid of `steps` steps */
static inline double sq_multipeak_shape_integral(double A, double B, double C, double n, double m, int steps = 40000) {
  double u0 = log(0.02), u1 = log(2000.0), du = (u1 - u0) / steps, sum = 0;
  for (int i = 0; i <= steps; ++i) {
    double r = exp(u0 + i * du);
    sum += (i == 0 || i == steps ? 0.5 : 1.0) * sq_multipeak_shape(r, A, B, C, n, m) * r;
  }
  return sum * du;
}

/* A bound on the shape's integral outside r in [0.02, 2000], the part sq_multipeak_shape_integral leaves out;
 * infinite where the integral diverges (b = 0 with a > 0, n <= 1 with c > 0). Below 0.02 the Gaussian rises
 * with r (r < 1), and the hump C r^-n exp(-7.987 r^-m) rises up to its peak at r_h = (7.987 m / n)^(1/m):
 * that part is at most 0.02 times their largest values there (the hump's at min(r_h, 0.02)). Past 2000 the
 * Gaussian's tail is A sqrt(pi / B) erfc(sqrt(B) 1999) / 2 and the hump's at most C 2000^(1 - n) / (n - 1). */
static inline double sq_multipeak_shape_outside(double A, double B, double C, double n, double m) {
  const double lo = 0.02, hi = 2000.0;
  double below = A * exp(-B * (lo - 1) * (lo - 1)), above = 0;
  if (C > 0) {
    if (n <= 1) return INFINITY;
    const double log_r_h = log(7.987 * m / n) / m, log_r = fmin(log_r_h, log(lo));
    below += C * exp(-n * log_r - 7.987 * exp(-m * log_r)); /* in logs: r_h may underflow */
    above += C * pow(hi, 1 - n) / (n - 1);
  }
  if (A > 0) {
    if (B <= 0) return INFINITY;
    above += A * sqrt(SQUALL_PI / B) * erfc(sqrt(B) * (hi - 1)) / 2;
  }
  return lo * below + above;
}

/* m_j = integral of w^j S(w) dw: over [w_lo / 50, 1e12 w_hi] (log-spaced trapezoid), w_lo and w_hi the
 * lowest and highest peaks, a Multipeak spectrum's partials' (over the dominant one's alone, a partial at
 * 0.01 rad/s beside one at 5 fell outside and Krylov's mean frequency came out 25% off), else w_p; and
 * beyond, where exp(-7.987 r^-m) is 1, a hump's tail scale c w_p^n w^(j+1-n) / (n - j - 1) (finite for
 * n > j + 1; a tail r^-2.2 leaves a quarter of m_1 past 1000 w_hi). */
static inline double sq_spectral_moment(SpectrumParams p, int j) {
  double lo = p.omega_p, hi = p.omega_p;
  for (int i = 0; p.spectrum == SQUALL_SPECTRUM_MULTIPEAK && i < p.partials; ++i) {
    lo = fmin(lo, p.partial_omega_p[i]);
    hi = fmax(hi, p.partial_omega_p[i]);
  }
  const double top = hi * 1e12;
  const int steps = 120000 + (int)(4000.0 * log(hi / lo)); /* 4000 an e-fold */
  double u0 = log(lo / 50.0), u1 = log(top), du = (u1 - u0) / steps, sum = 0;
  for (int i = 0; i <= steps; ++i) {
    double w = exp(u0 + i * du);
    sum += (i == 0 || i == steps ? 0.5 : 1.0) * pow(w, j) * sq_frequency_spectrum(p, w) * w;
  }
  sum *= du;
  for (int i = 0; p.spectrum == SQUALL_SPECTRUM_MULTIPEAK && i < p.partials; ++i) {
    const double n = p.partial_n[i], c = p.partial_c[i];
    if (c > 0) sum += p.partial_scale[i] * c * pow(p.partial_omega_p[i], n) * pow(top, j + 1 - n) / (n - j - 1);
  }
  return sum;
}
#endif

#endif
