#include "ocean/spectrum_setup.h"

#include <algorithm>
#include <cmath>

#include "common/error.h"
#include "common/validate.h"

namespace squall::ocean {
namespace {

using validate::finite;
using validate::non_negative;
using validate::positive;

std::string join(const std::string& path, const std::string& field) {
  return path.empty() ? field : path + "." + field;
}

bool spreading_needs_wind(SpreadingModel s) {
  return s == SpreadingModel::Mitsuyasu || s == SpreadingModel::Jonswap || s == SpreadingModel::VonMises;
}

// The scale of a partial's shape: its m0 = scale w_p integral(shape dr) = (Hs / 4)^2, given the integral
// (validation's order of magnitude needs a hundredth of the spectrum's steps), or computed in full.
double partial_scale(const PartialSpectrum& q, double shape_integral) {
  const double m0 = 0.0625 * q.significant_wave_height * q.significant_wave_height;
  return m0 / (q.peak_frequency * shape_integral);
}
double partial_scale(const PartialSpectrum& q) {
  return partial_scale(q, sq_multipeak_shape_integral(q.a, q.b, q.c, q.n, q.m));
}

// ln of the largest value of the hump c r^-n exp(-7.987 r^-m) (eq 25's S_h before its scale), at
// r^m = 7.987 m / n: ln c - (n / m) (ln(7.987 m / n) + 1). -inf without a hump.
double hump_log_peak(const PartialSpectrum& p) {
  if (p.c <= 0) return -INFINITY;
  return std::log(p.c) - p.n / p.m * (std::log(7.987 * p.m / p.n) + 1);
}

// A partial is normalized over w / w_p in [0.02, 2000] (sq_multipeak_shape_integral): a shape with more
// than a hundredth of its energy outside (its Hs then half a percent short), or an unbounded one, is refused.
// Returns the integral.
double check_shape_range(const std::string& g, const PartialSpectrum& p) {
  const double outside = sq_multipeak_shape_outside(p.a, p.b, p.c, p.n, p.m);
  const double inside = sq_multipeak_shape_integral(p.a, p.b, p.c, p.n, p.m, 400);
  if (outside <= 1e-2 * inside) return inside;
  const std::string share = std::isfinite(outside) ? "up to " + validate::number(outside / inside) + " of its energy"
                                                   : "energy without bound";
  fail(Code::InvalidArgument, g + ": its shape (a = " + validate::number(p.a) + ", b = " + validate::number(p.b) +
                                  ", c = " + validate::number(p.c) + ", n = " + validate::number(p.n) +
                                  ", m = " + validate::number(p.m) + ") has " + share +
                                  " outside w / w_p in [0.02, 2000], where it is normalized: b > 0 where a > 0, "
                                  "n > 1 where c > 0, and the peak of r^-n exp(-7.987 r^-m), (7.987 m / n)^(1/m), "
                                  "well above 0.02");
}

// Krylov's spread follows the mean frequency m1 / m0 (eq 31), which a hump's tail c r^-n leaves infinite for
// n <= 2.
void check_krylov_mean(const std::string& g, const PartialSpectrum& p) {
  if (p.c > 0 && p.n <= 2)
    validate::reject(g + ".n", p.n,
                     "above 2 where c > 0 with the Krylov spreading (its mean frequency m1 / m0 "
                     "diverges for a tail r^-n with n <= 2)");
}

void validate_partials(const std::string& f, const LayerSpec& L) {
  if (L.partials.empty() || L.partials.size() > size_t(kMaxPartialSpectra))
    fail(Code::InvalidArgument, f + ".partials has " + std::to_string(L.partials.size()) +
                                    " entries; the Multipeak spectrum needs 1.." + std::to_string(kMaxPartialSpectra));
  for (size_t i = 0; i < L.partials.size(); ++i) {
    const auto& p = L.partials[i];
    std::string g = validate::at(f + ".partials", i);
    positive(g + ".peak_frequency", p.peak_frequency, 100);
    positive(g + ".significant_wave_height", p.significant_wave_height, 100);
    non_negative(g + ".a", p.a, 1e6);
    non_negative(g + ".b", p.b, 1e6);
    non_negative(g + ".c", p.c, 1e6);
    positive(g + ".n", p.n, 100);
    positive(g + ".m", p.m, 100);
    if (p.a + p.c <= 0) fail(Code::InvalidArgument, g + ".a and " + g + ".c are both 0: the partial has no energy");
    if (L.spreading == SpreadingModel::Krylov) check_krylov_mean(g, p);
    // The device holds the shape's parameters and scale in float32: an a or c that rounds to 0 there, or a
    // scale past 1e30 (its product with the shape would overflow), would leave the sea flat or NaN.
    for (const auto& [name, value] : {std::pair{".a", p.a}, std::pair{".c", p.c}})
      if (value > 0 && value < 1e-30) validate::reject(g + name, value, "0 or at least 1e-30 (float32 on the device)");
    const double scale = partial_scale(p, check_shape_range(g, p));
    if (!(scale <= 1e30))
      fail(Code::InvalidArgument, g + ": its shape's scale (Hs / 4)^2 / (w_p integral) is " + validate::number(scale) +
                                      ", past 1e30 (float32 on the device): raise a or c");
    if (hump_log_peak(p) > std::log(1e30))
      fail(Code::InvalidArgument, g + ": its shape's hump c r^-n exp(-7.987 r^-m) peaks at e^" +
                                      validate::number(hump_log_peak(p)) +
                                      ", past 1e30 (float32 on the device, where its product with its scale, " +
                                      validate::number(scale) + ", underflows or overflows): lower n or c, or raise m");
  }
}

// Spectrum parameters: the wind is needed unless a Multipeak spectrum with a wind-free spreading model.
void validate_spectrum(const std::string& f, const LayerSpec& L) {
  validate::known(f + ".spectrum", int(L.spectrum), kSpectrumModelCount, "spectrum model");
  validate::known(f + ".spreading", int(L.spreading), kSpreadingModelCount, "spreading model");
  const bool multipeak = L.spectrum == SpectrumModel::Multipeak;
  const bool wind_needed = !multipeak || spreading_needs_wind(L.spreading);
  validate::in(f + ".wind_speed", L.wind_speed, wind_needed ? validate::open_closed(0, 100) : validate::closed(0, 100));
  positive(f + ".fetch", L.fetch, 1e8);
  validate::in(f + ".gamma", L.gamma, kPeakEnhancementRange);
  validate::in(f + ".sigma_a", L.sigma_a, kPeakWidthRange);
  validate::in(f + ".sigma_b", L.sigma_b, kPeakWidthRange);
  non_negative(f + ".phillips_amplitude", L.phillips_amplitude, 1e3);
  non_negative(f + ".phillips_cutoff", L.phillips_cutoff);
  non_negative(f + ".phillips_exponent", L.phillips_exponent, 64);
  if (multipeak) validate_partials(f, L);  // other spectra ignore partials
  validate::in(f + ".wind_direction", L.wind_direction, validate::closed(-1e6, 1e6));
}

void validate_layer(const std::string& f, const LayerSpec& L, const LimitGate& gate) {
  validate::in(f + ".lx", L.lx, kExtentRange);
  validate::in(f + ".ly", L.ly, kExtentRange);
  if (L.nx < 2 || L.nx % 2) validate::reject(f + ".nx", std::to_string(L.nx), "even and >= 2");
  if (L.ny < 2 || L.ny % 2) validate::reject(f + ".ny", std::to_string(L.ny), "even and >= 2");
  gate.check_grid(f, L.nx, L.ny);
  validate_spectrum(f, L);
  validate::known(f + ".dispersion", int(L.dispersion), kDispersionKindCount, "dispersion model");
  positive(f + ".depth", L.depth, 1e5);
  non_negative(f + ".capillary_length", L.capillary_length, 1);
  positive(f + ".gravity", L.gravity, 100);
  validate::in(f + ".drift_x", L.drift_x, validate::closed(-100, 100));
  validate::in(f + ".drift_y", L.drift_y, validate::closed(-100, 100));
  non_negative(f + ".k_min", L.k_min);
  non_negative(f + ".k_max", L.k_max);
  // Compared in single precision too, as the device reads them: a k_max that rounds to 0 would mean no limit.
  if (L.k_max > 0 && (L.k_max <= L.k_min || float(L.k_max) <= float(L.k_min)))
    validate::reject(f + ".k_max", L.k_max,
                     "0 (no limit) or > " + f + ".k_min = " + validate::number(L.k_min) + " in single precision too");
}

}  // namespace

void validate_tile(const TileSpec& spec, const LimitGate& gate, const std::string& path) {
  const std::string layers = join(path, "layers");
  if (spec.layers.empty() || spec.layers.size() > size_t(kMaxLayers))
    fail(Code::InvalidArgument, layers + " has " + std::to_string(spec.layers.size()) + " entries: must be 1 to " +
                                    std::to_string(kMaxLayers));
  for (size_t i = 0; i < spec.layers.size(); ++i) validate_layer(validate::at(layers, i), spec.layers[i], gate);
  validate::in(join(path, "choppiness"), spec.choppiness, validate::closed(-100, 100));
  finite(join(path, "whitecap_threshold"), spec.whitecap_threshold);
  positive(join(path, "whitecap_decay_time"), spec.whitecap_decay, 1e9);
  non_negative(join(path, "pixel_scale"), spec.pixel_scale, 1e6);
  positive(join(path, "slope_k_max"), spec.slope_k_max, 1e9);
  bool custom = spec.nx != 0 || spec.ny != 0 || spec.lx != 0 || spec.ly != 0;
  if (custom) {
    gate.check_grid(join(path, "output"), spec.nx, spec.ny);
    validate::in(join(path, "output.lx"), spec.lx, kExtentRange);
    validate::in(join(path, "output.ly"), spec.ly, kExtentRange);
  }
}

OutputGrid output_grid(const TileSpec& spec) {
  bool custom = spec.nx != 0 || spec.ny != 0 || spec.lx != 0 || spec.ly != 0;
  if (custom) return {spec.nx, spec.ny, spec.lx, spec.ly};
  const LayerSpec& L = spec.layers.front();
  return {L.nx, L.ny, L.lx, L.ly};
}

ChannelLayout channel_layout(unsigned outputs) {
  const bool derivatives = outputs & (Normals | Jacobian | Whitecaps);
  if (!(outputs & Displacement) && (derivatives || (outputs & Slopes))) return {derivatives ? 3 : 2, false};
  if (derivatives) return {4, true};
  if (outputs & Slopes) return {3, true};
  return {outputs & Displacement ? 2 : 1, true};
}

SpectrumParams derive_spectrum(const LayerSpec& L) {
  SpectrumParams p{};
  p.spectrum = int(L.spectrum);
  p.spreading = int(L.spreading);
  p.g = L.gravity;
  p.wind_speed = L.wind_speed;
  p.gamma = L.gamma;
  p.sigma_a = L.sigma_a;
  p.sigma_b = L.sigma_b;
  p.depth = L.depth;
  p.theta0 = std::remainder(L.wind_direction, 2 * SQUALL_PI);  // within +-pi: exact in double, then in float
  p.phillips_amplitude = L.phillips_amplitude;
  // L = V^2 / g under eq 40 of J. Tessendorf, "Simulating Ocean Water" (App. A of his "Gilligan" report, 2017)
  p.phillips_length = L.wind_speed * L.wind_speed / L.gravity;
  p.phillips_cutoff = L.phillips_cutoff;
  p.phillips_exponent = L.phillips_exponent;
  switch (L.spectrum) {
    case SpectrumModel::PiersonMoskowitz:
      p.alpha = 0.0081;
      p.omega_p = sq_pm_omega_p(L.gravity, L.wind_speed);
      break;
    case SpectrumModel::Jonswap:
    case SpectrumModel::ModifiedJonswap:
    case SpectrumModel::Tma:
      p.alpha = sq_jonswap_alpha(L.gravity, L.wind_speed, L.fetch);
      p.omega_p = sq_jonswap_omega_p(L.gravity, L.wind_speed, L.fetch);
      break;
    case SpectrumModel::Multipeak: {
      p.partials = int(std::min<size_t>(L.partials.size(), SQUALL_MAX_PARTIALS));
      double largest = -1;
      for (int i = 0; i < p.partials; ++i) {
        const PartialSpectrum& q = L.partials[i];
        p.partial_omega_p[i] = q.peak_frequency;
        p.partial_a[i] = q.a;
        p.partial_b[i] = q.b;
        p.partial_c[i] = q.c;
        p.partial_n[i] = q.n;
        p.partial_m[i] = q.m;
        p.partial_scale[i] = partial_scale(q);
        if (q.significant_wave_height > largest) {
          largest = q.significant_wave_height;
          p.omega_p = q.peak_frequency;  // the spreading models follow the dominant partial
        }
      }
      break;
    }
    case SpectrumModel::Phillips: p.omega_p = L.gravity / std::max(L.wind_speed, 1e-9); break;
  }
  if (L.spectrum != SpectrumModel::Phillips && L.spreading == SpreadingModel::Krylov)  // eq 31's mean frequency
    p.omega_mean = sq_spectral_moment(p, 1) / sq_spectral_moment(p, 0);
  return p;
}

Dispersion dispersion_of(const LayerSpec& L) {
  return Dispersion{int(L.dispersion), float(L.gravity), float(L.depth), float(L.capillary_length)};
}

OceanLayer device_layer(const LayerSpec& L, int index) {
  SpectrumParams p = derive_spectrum(L);
  OceanLayer d{};
  d.nx = int(L.nx);
  d.ny = int(L.ny);
  d.dkx = float(2 * SQUALL_PI / L.lx);
  d.dky = float(2 * SQUALL_PI / L.ly);
  d.spectrum = p.spectrum;
  d.spreading = p.spreading;
  d.partials = p.partials;
  d.layer_index = index;
  d.g = float(p.g);
  d.wind_speed = float(p.wind_speed);
  d.alpha = float(p.alpha);
  d.omega_p = float(p.omega_p);
  d.gamma = float(p.gamma);
  d.sigma_a = float(p.sigma_a);
  d.sigma_b = float(p.sigma_b);
  d.depth = float(p.depth);
  d.theta0 = float(p.theta0);
  d.omega_mean = float(p.omega_mean);
  d.phillips_amplitude = float(p.phillips_amplitude);
  d.phillips_length = float(p.phillips_length);
  d.phillips_cutoff = float(p.phillips_cutoff);
  d.phillips_exponent = float(p.phillips_exponent);
  d.k_min = float(L.k_min);
  d.k_max = float(L.k_max);
  for (int i = 0; i < SQUALL_MAX_PARTIALS; ++i) {
    d.partial_omega_p[i] = float(p.partial_omega_p[i]);
    d.partial_scale[i] = float(p.partial_scale[i]);
    d.partial_a[i] = float(p.partial_a[i]);
    d.partial_b[i] = float(p.partial_b[i]);
    d.partial_c[i] = float(p.partial_c[i]);
    d.partial_n[i] = float(p.partial_n[i]);
    d.partial_m[i] = float(p.partial_m[i]);
  }
  d.dispersion = dispersion_of(L);
  d.seed_lo = unsigned(L.seed & 0xffffffffu);
  d.seed_hi = unsigned(L.seed >> 32);
  return d;
}

std::vector<std::array<float, 4>> layer_bands(const TileSpec& spec) {
  std::vector<std::array<float, 4>> bands;
  if (!spec.b_correction) return bands;
  for (const LayerSpec& L : spec.layers)
    bands.push_back({float(SQUALL_PI / L.lx), float(SQUALL_PI / L.ly), float((L.nx - 1) * SQUALL_PI / L.lx),
                     float((L.ny - 1) * SQUALL_PI / L.ly)});
  return bands;
}

namespace {
// 2 * integral over k_lo < |k| < k_hi of k^3 (integral of P(k, theta) d theta) dk for one layer.
double layer_slope_variance(const LayerSpec& L, double k_lo, double k_hi) {
  if (!(k_hi > k_lo)) return 0;
  SpectrumParams p = derive_spectrum(L);
  const Dispersion d = dispersion_of(L);
  const int steps = 4000;
  double u0 = std::log(k_lo), du = (std::log(k_hi) - u0) / steps, sum = 0;
  // Phillips: integral of |cos|^p over the circle = 2 sqrt(pi) Gamma((p+1)/2) / Gamma(p/2 + 1).
  double phillips_angle =
      2 * std::sqrt(SQUALL_PI) *
      std::exp(std::lgamma(0.5 * (L.phillips_exponent + 1)) - std::lgamma(0.5 * L.phillips_exponent + 1));
  for (int i = 0; i <= steps; ++i) {
    double k = std::exp(u0 + i * du);
    if (k < L.k_min || (L.k_max > 0 && k > L.k_max)) continue;
    double angular;  // integral of P(k, theta) d theta
    if (L.spectrum == SpectrumModel::Phillips) {
      angular = sq_phillips(p, k * std::cos(p.theta0), k * std::sin(p.theta0)) * phillips_angle;
    } else {
      double w = dispersion_omega(float(k), d), vg = dispersion_group_velocity(float(k), d);
      angular = sq_frequency_spectrum(p, w) * vg / (2 * k);  // each D integrates to 1
    }
    // No energy where the float dispersion or spectrum vanishes (a depth of 1e-300 m is 0 in float, so are the
    // tile's modes): 0 times an infinite group velocity or peak term is NaN here.
    if (!(angular > 0)) continue;
    sum += (i == 0 || i == steps ? 0.5 : 1.0) * 2 * k * k * k * angular * k;  // dk = k du
  }
  return sum * du;
}
}  // namespace

double unresolved_slope_variance(const TileSpec& spec) {
  OutputGrid grid = output_grid(spec);
  double R = spec.pixel_scale > 0 ? spec.pixel_scale : std::max(grid.lx / grid.nx, grid.ly / grid.ny);
  double total = 0;
  for (const LayerSpec& L : spec.layers) total += layer_slope_variance(L, SQUALL_PI / R, spec.slope_k_max);
  return spec.b_correction ? total / double(spec.layers.size()) : total;
}

namespace {
// omega(k) / 2 pi of Table 1 in double precision, turns per second.
double mode_frequency(const LayerSpec& L, double k) {
  const bool finite_depth = L.dispersion == DispersionKind::Shallow || L.dispersion == DispersionKind::Combined;
  const bool capillary = L.dispersion == DispersionKind::Capillary || L.dispersion == DispersionKind::Combined;
  const double depth_factor = finite_depth ? std::tanh(k * L.depth) : 1.0;
  const double kl = capillary ? k * L.capillary_length : 0.0;
  return std::sqrt(L.gravity * k * depth_factor * (1 + kl * kl)) / (2 * SQUALL_PI);
}

// The mode number of index i of n (kernels/ocean/ocean.cl, mode_number).
int64_t mode_number(int64_t i, int64_t n) { return i < n / 2 ? i : i - n; }
}  // namespace

void mode_frequencies(const LayerSpec& L, size_t first, size_t count, float* hi, float* lo) {
  const size_t nx = size_t(L.nx);
  for (size_t n = 0; n < count; ++n) {
    const size_t i = (first + n) % nx, j = (first + n) / nx;
    const double kx = double(mode_number(int64_t(i), L.nx)) * 2 * SQUALL_PI / L.lx;
    const double ky = double(mode_number(int64_t(j), L.ny)) * 2 * SQUALL_PI / L.ly;
    const double f = mode_frequency(L, std::sqrt(kx * kx + ky * ky));
    hi[n] = float(f);
    lo[n] = float(f - double(hi[n]));
  }
}

}  // namespace squall::ocean
