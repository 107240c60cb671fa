#include "ocean/spectrum_setup.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "common/error.h"

namespace squall::ocean {
namespace {

std::string number(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

// Each check fails with "<field> = <value> must be <rule>".
void require(bool ok, const std::string& field, double value, const char* rule) {
  if (!ok) fail(Code::InvalidArgument, field + " = " + number(value) + " must be " + rule);
}
void finite(const std::string& field, double v) { require(std::isfinite(v), field, v, "finite"); }
void positive(const std::string& field, double v) { require(std::isfinite(v) && v > 0, field, v, "finite and > 0"); }
void non_negative(const std::string& field, double v) { require(std::isfinite(v) && v >= 0, field, v, "finite and >= 0"); }

void known(const std::string& field, int value, int count) {
  if (value < 0 || value >= count)
    fail(Code::InvalidArgument, field + " = " + std::to_string(value) + " is not a known model (0.." +
                                    std::to_string(count - 1) + ")");
}

bool spreading_needs_wind(SpreadingModel s) {
  return s == SpreadingModel::Mitsuyasu || s == SpreadingModel::Jonswap || s == SpreadingModel::VonMises;
}

void validate_partials(const std::string& f, const LayerSpec& L) {
  if (L.partials.empty() || L.partials.size() > size_t(kMaxPartialSpectra))
    fail(Code::InvalidArgument, f + ".partials holds " + std::to_string(L.partials.size()) +
                                    " entries; the Multipeak spectrum needs 1.." + std::to_string(kMaxPartialSpectra));
  for (size_t i = 0; i < L.partials.size(); ++i) {
    const auto& p = L.partials[i];
    std::string g = f + ".partials[" + std::to_string(i) + "]";
    positive(g + ".peak_frequency", p.peak_frequency);
    positive(g + ".significant_wave_height", p.significant_wave_height);
    non_negative(g + ".a", p.a);
    non_negative(g + ".b", p.b);
    non_negative(g + ".c", p.c);
    positive(g + ".n", p.n);
    positive(g + ".m", p.m);
    if (p.a + p.c <= 0) fail(Code::InvalidArgument, g + ".a + " + g + ".c must be > 0");
  }
}

void validate_layer(const std::string& f, const LayerSpec& L, const LimitGate& gate) {
  positive(f + ".lx", L.lx);
  positive(f + ".ly", L.ly);
  gate.check_grid(f, L.nx, L.ny);
  if (L.nx < 2 || L.nx % 2) fail(Code::InvalidArgument, f + ".nx = " + std::to_string(L.nx) + " must be even and >= 2");
  if (L.ny < 2 || L.ny % 2) fail(Code::InvalidArgument, f + ".ny = " + std::to_string(L.ny) + " must be even and >= 2");
  known(f + ".spectrum", int(L.spectrum), kSpectrumModelCount);
  known(f + ".spreading", int(L.spreading), kSpreadingModelCount);
  known(f + ".dispersion", int(L.dispersion), kDispersionKindCount);
  bool multipeak = L.spectrum == SpectrumModel::Multipeak;
  bool wind_needed = !multipeak || spreading_needs_wind(L.spreading);
  if (wind_needed) positive(f + ".wind_speed", L.wind_speed);
  else non_negative(f + ".wind_speed", L.wind_speed);
  positive(f + ".fetch", L.fetch);
  require(std::isfinite(L.gamma) && L.gamma >= 1, f + ".gamma", L.gamma, "finite and >= 1");
  positive(f + ".sigma_a", L.sigma_a);
  positive(f + ".sigma_b", L.sigma_b);
  non_negative(f + ".phillips_amplitude", L.phillips_amplitude);
  non_negative(f + ".phillips_cutoff", L.phillips_cutoff);
  non_negative(f + ".phillips_exponent", L.phillips_exponent);
  if (multipeak) validate_partials(f, L);
  finite(f + ".wind_direction", L.wind_direction);
  positive(f + ".depth", L.depth);
  non_negative(f + ".capillary_length", L.capillary_length);
  positive(f + ".gravity", L.gravity);
  finite(f + ".drift_x", L.drift_x);
  finite(f + ".drift_y", L.drift_y);
  non_negative(f + ".k_min", L.k_min);
  non_negative(f + ".k_max", L.k_max);
}

}  // namespace

void validate_tile(const TileSpec& spec, const LimitGate& gate) {
  if (spec.layers.empty()) fail(Code::InvalidArgument, "layers is empty; a tile needs at least one layer");
  for (size_t i = 0; i < spec.layers.size(); ++i)
    validate_layer("layers[" + std::to_string(i) + "]", spec.layers[i], gate);
  finite("choppiness", spec.choppiness);
  finite("whitecap_threshold", spec.whitecap_threshold);
  positive("whitecap_decay", spec.whitecap_decay);
  non_negative("pixel_scale", spec.pixel_scale);
  positive("slope_k_max", spec.slope_k_max);
  bool custom = spec.nx != 0 || spec.ny != 0 || spec.lx != 0 || spec.ly != 0;
  if (custom) {
    gate.check_grid("output", spec.nx, spec.ny);
    positive("output.lx", spec.lx);
    positive("output.ly", spec.ly);
  }
}

OutputGrid output_grid(const TileSpec& spec) {
  bool custom = spec.nx != 0 || spec.ny != 0 || spec.lx != 0 || spec.ly != 0;
  if (custom) return {spec.nx, spec.ny, spec.lx, spec.ly};
  const LayerSpec& L = spec.layers.front();
  return {L.nx, L.ny, L.lx, L.ly};
}

int channel_pairs(unsigned outputs) {
  if (outputs & (Normals | Jacobian | Whitecaps)) return 4;
  if (outputs & Slopes) return 3;
  if (outputs & Displacement) return 2;
  return 1;
}

SqSpectrum derive_spectrum(const LayerSpec& L) {
  SqSpectrum p{};
  p.spectrum = int(L.spectrum);
  p.spreading = int(L.spreading);
  p.g = L.gravity;
  p.wind_speed = L.wind_speed;
  p.gamma = L.gamma;
  p.sigma_a = L.sigma_a;
  p.sigma_b = L.sigma_b;
  p.depth = L.depth;
  p.theta0 = L.wind_direction;
  p.phillips_amplitude = L.phillips_amplitude;
  p.phillips_length = L.wind_speed * L.wind_speed / L.gravity;  // App A eq 41: L = V^2 / g
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
      p.partials = int(std::min<size_t>(L.partials.size(), SQ_MAX_PARTIALS));
      double largest = -1;
      for (int i = 0; i < p.partials; ++i) {
        const PartialSpectrum& q = L.partials[i];
        p.partial_omega_p[i] = q.peak_frequency;
        p.partial_a[i] = q.a;
        p.partial_b[i] = q.b;
        p.partial_c[i] = q.c;
        p.partial_n[i] = q.n;
        p.partial_m[i] = q.m;
        // m0 of the partial = scale * w_p * integral(shape dr) = (Hs / 4)^2
        double m0 = 0.0625 * q.significant_wave_height * q.significant_wave_height;
        p.partial_scale[i] = m0 / (q.peak_frequency * sq_multipeak_shape_integral(q.a, q.b, q.c, q.n, q.m));
        if (q.significant_wave_height > largest) {
          largest = q.significant_wave_height;
          p.omega_p = q.peak_frequency;  // the spreading models follow the dominant partial
        }
      }
      break;
    }
    case SpectrumModel::Phillips:
      p.omega_p = L.gravity / std::max(L.wind_speed, 1e-9);
      break;
  }
  if (L.spectrum != SpectrumModel::Phillips && L.spreading == SpreadingModel::Krylov)  // eq 31's mean frequency
    p.omega_mean = sq_spectral_moment(p, 1) / sq_spectral_moment(p, 0);
  return p;
}

OceanLayer device_layer(const LayerSpec& L, int index) {
  SqSpectrum p = derive_spectrum(L);
  OceanLayer d{};
  d.nx = int(L.nx);
  d.ny = int(L.ny);
  d.dkx = float(2 * SQ_PI / L.lx);
  d.dky = float(2 * SQ_PI / L.ly);
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
  for (int i = 0; i < SQ_MAX_PARTIALS; ++i) {
    d.partial_omega_p[i] = float(p.partial_omega_p[i]);
    d.partial_scale[i] = float(p.partial_scale[i]);
    d.partial_a[i] = float(p.partial_a[i]);
    d.partial_b[i] = float(p.partial_b[i]);
    d.partial_c[i] = float(p.partial_c[i]);
    d.partial_n[i] = float(p.partial_n[i]);
    d.partial_m[i] = float(p.partial_m[i]);
  }
  d.dispersion.kind = int(L.dispersion);
  d.dispersion.gravity = float(L.gravity);
  d.dispersion.depth = float(L.depth);
  d.dispersion.capillary_length = float(L.capillary_length);
  d.seed_lo = unsigned(L.seed & 0xffffffffu);
  d.seed_hi = unsigned(L.seed >> 32);
  return d;
}

std::vector<std::array<float, 4>> layer_bands(const TileSpec& spec) {
  std::vector<std::array<float, 4>> bands;
  if (!spec.b_correction) return bands;
  for (const LayerSpec& L : spec.layers)
    bands.push_back({float(SQ_PI / L.lx), float(SQ_PI / L.ly), float((L.nx - 1) * SQ_PI / L.lx),
                     float((L.ny - 1) * SQ_PI / L.ly)});
  return bands;
}

namespace {
// 2 * integral over k_lo < |k| < k_hi of k^3 (integral of P(k, theta) d theta) dk for one layer.
double layer_slope_variance(const LayerSpec& L, double k_lo, double k_hi) {
  if (!(k_hi > k_lo)) return 0;
  SqSpectrum p = derive_spectrum(L);
  Dispersion d{int(L.dispersion), float(L.gravity), float(L.depth), float(L.capillary_length)};
  const int steps = 4000;
  double u0 = std::log(k_lo), du = (std::log(k_hi) - u0) / steps, sum = 0;
  // Phillips: integral of |cos|^p over the circle = 2 sqrt(pi) Gamma((p+1)/2) / Gamma(p/2 + 1).
  double phillips_angle = 2 * std::sqrt(SQ_PI) * std::exp(std::lgamma(0.5 * (L.phillips_exponent + 1)) -
                                                           std::lgamma(0.5 * L.phillips_exponent + 1));
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
    sum += (i == 0 || i == steps ? 0.5 : 1.0) * 2 * k * k * k * angular * k;  // dk = k du
  }
  return sum * du;
}
}  // namespace

double unresolved_slope_variance(const TileSpec& spec) {
  OutputGrid grid = output_grid(spec);
  double R = spec.pixel_scale > 0 ? spec.pixel_scale : std::max(grid.lx / grid.nx, grid.ly / grid.ny);
  double total = 0;
  for (const LayerSpec& L : spec.layers) total += layer_slope_variance(L, SQ_PI / R, spec.slope_k_max);
  return spec.b_correction ? total / double(spec.layers.size()) : total;
}

}  // namespace squall::ocean
