// The FFTW double-precision reference of the ocean tile. Independent of the engine's code: only
// ocean_params.h and the spectrum formulas of kernels/ocean/spectra.h are shared.
#include "ocean/cpu_reference.h"

#include <fftw3.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstring>
#include <list>
#include <map>
#include <string>

#include "ocean/spectra.h"

namespace squall::ocean {
namespace {

using cplx = std::complex<double>;
constexpr double kPi = 3.14159265358979323846;

// ---- dispersion, Table 1, in double ----
bool finite_depth(const LayerSpec& L) {
  return L.dispersion == DispersionKind::Shallow || L.dispersion == DispersionKind::Combined;
}
bool capillary(const LayerSpec& L) {
  return L.dispersion == DispersionKind::Capillary || L.dispersion == DispersionKind::Combined;
}

double omega(const LayerSpec& L, double k) {
  if (k <= 0) return 0;
  double th = finite_depth(L) ? std::tanh(k * L.depth) : 1.0;
  double kl = capillary(L) ? k * L.capillary_length : 0.0;
  return std::sqrt(L.gravity * k * th * (1 + kl * kl));
}

double group_velocity(const LayerSpec& L, double k) {
  if (k <= 0) return 0;
  double bracket = 1;
  if (finite_depth(L)) {
    double kh = k * L.depth, th = std::tanh(kh);
    bracket += kh * (1 - th * th) / th;
  }
  if (capillary(L)) {
    double kl2 = std::pow(k * L.capillary_length, 2);
    bracket += 2 * kl2 / (1 + kl2);
  }
  return 0.5 * omega(L, k) / k * bracket;
}

// ---- the formula parameters of a layer: derived here again, with quadratures of its own, so that a
// mistake in the engine's spectrum_setup.cpp (alpha, omega_p, normalizations) shows up as a mismatch ----
SpectrumParams compute_formula_parameters(const LayerSpec& L);

// Memoized per thread on the layer's spectrum fields (the mean-frequency quadrature is not cheap).
SpectrumParams formula_parameters(const LayerSpec& L) {
  thread_local std::string last_key;
  thread_local SpectrumParams last{};
  std::string key;
  auto add = [&](const void* p, size_t n) { key.append(static_cast<const char*>(p), n); };
  double d[] = {
      L.wind_speed,        L.fetch,          L.gamma, L.sigma_a, L.sigma_b, L.phillips_amplitude, L.phillips_cutoff,
      L.phillips_exponent, L.wind_direction, L.depth, L.gravity};
  int i[] = {int(L.spectrum), int(L.spreading)};
  add(d, sizeof d), add(i, sizeof i);
  for (const auto& q : L.partials) add(&q, sizeof q);
  if (key != last_key) last = compute_formula_parameters(L), last_key = key;
  return last;
}

// Krylov's mean frequency m1 / m0: the midpoint rule in ln w from the lowest peak / 50 to the highest x 1e12,
// and past that a hump's tail scale c w_p^n w^(j+1-n) / (n - j - 1), where exp(-7.987 r^-m) is 1.
double mean_of(const LayerSpec& L, const SpectrumParams& p) {
  double lo = p.omega_p, hi = p.omega_p;
  if (L.spectrum == SpectrumModel::Multipeak)
    for (const PartialSpectrum& q : L.partials)
      lo = std::min(lo, q.peak_frequency), hi = std::max(hi, q.peak_frequency);
  const double top = hi * 1e12, u0 = std::log(lo / 50), du = (std::log(top) - u0) / 900000;
  double m[2] = {0, 0};
  for (int i = 0; i < 900000; ++i) {
    const double w = std::exp(u0 + (i + 0.5) * du), s = sq_frequency_spectrum(p, w) * w * du;  // dw = w du
    m[0] += s, m[1] += w * s;
  }
  for (int i = 0; L.spectrum == SpectrumModel::Multipeak && i < p.partials; ++i)
    for (int j = 0; j < 2 && p.partial_c[i] > 0; ++j)
      m[j] += p.partial_scale[i] * p.partial_c[i] * std::pow(p.partial_omega_p[i], p.partial_n[i]) *
              std::pow(top, j + 1 - p.partial_n[i]) / (p.partial_n[i] - j - 1);
  return m[1] / m[0];
}

SpectrumParams compute_formula_parameters(const LayerSpec& L) {
  SpectrumParams p{};
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
  p.phillips_length = L.wind_speed * L.wind_speed / L.gravity;
  p.phillips_cutoff = L.phillips_cutoff;
  p.phillips_exponent = L.phillips_exponent;
  double U = L.wind_speed, g = L.gravity, X = L.fetch;
  if (L.spectrum == SpectrumModel::PiersonMoskowitz) {
    p.alpha = 0.0081;
    p.omega_p = 0.879 * g / U;
  } else if (L.spectrum == SpectrumModel::Jonswap || L.spectrum == SpectrumModel::ModifiedJonswap ||
             L.spectrum == SpectrumModel::Tma) {
    p.alpha = 0.076 * std::pow(g * X / (U * U), -0.22);
    p.omega_p = 7 * kPi * (g / U) * std::pow(g * X / (U * U), -0.33);
  } else if (L.spectrum == SpectrumModel::Multipeak) {
    p.partials = int(L.partials.size());
    double largest = -1;
    for (int i = 0; i < p.partials; ++i) {
      const PartialSpectrum& q = L.partials[i];
      p.partial_omega_p[i] = q.peak_frequency;
      p.partial_a[i] = q.a, p.partial_b[i] = q.b, p.partial_c[i] = q.c, p.partial_n[i] = q.n, p.partial_m[i] = q.m;
      // scale so that the partial's m0 = (Hs/4)^2 (midpoint rule in r, independent of the engine's)
      double integral = 0, dr = 1e-4;
      for (double r = 0.5 * dr; r < 400; r += dr) integral += sq_multipeak_shape(r, q.a, q.b, q.c, q.n, q.m) * dr;
      integral += q.c / ((q.n - 1) * std::pow(400.0, q.n - 1));  // tail of C r^-n
      p.partial_scale[i] = std::pow(q.significant_wave_height / 4, 2) / (q.peak_frequency * integral);
      if (q.significant_wave_height > largest) largest = q.significant_wave_height, p.omega_p = q.peak_frequency;
    }
  } else {
    p.omega_p = g / std::max(U, 1e-9);
  }
  if (L.spectrum != SpectrumModel::Phillips && L.spreading == SpreadingModel::Krylov) p.omega_mean = mean_of(L, p);
  return p;
}

// ---- counter-based amplitudes (the documented generator: splitmix64 mixing + Box-Muller) ----
uint64_t mix64(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}
cplx gaussian_pair(uint64_t seed, int layer, int64_t n, int64_t m) {
  uint64_t a = mix64(seed ^ mix64(0x9E3779B97F4A7C15ull * uint64_t(layer + 1)));
  uint64_t b = mix64(a ^ ((uint64_t(uint32_t(int32_t(n))) << 32) | uint64_t(uint32_t(int32_t(m)))));
  uint64_t c = mix64(b + 0x9E3779B97F4A7C15ull);
  double u1 = (double(b >> 41) + 0.5) * std::ldexp(1.0, -23);
  double u2 = (double(c >> 41) + 0.5) * std::ldexp(1.0, -23);
  double r = std::sqrt(-2 * std::log(u1));
  return {r * std::cos(2 * kPi * u2), r * std::sin(2 * kPi * u2)};
}

int64_t signed_mode(int64_t i, int64_t n) { return i < n / 2 ? i : i - n; }

// B(k): the count of layers whose band holds k.
double coverage(const TileSpec& spec, double kx, double ky) {
  double count = 0;
  for (const LayerSpec& L : spec.layers) {
    double ax = std::abs(kx), ay = std::abs(ky);
    bool inside = ax < (L.nx - 1) * kPi / L.lx && ay < (L.ny - 1) * kPi / L.ly && !(ax < kPi / L.lx && ay < kPi / L.ly);
    count += inside;
  }
  return count;
}

struct LayerSpectrum {
  std::vector<cplx> h0;
  std::vector<double> w;
};

LayerSpectrum build_spectrum(const TileSpec& spec, size_t index) {
  const LayerSpec& L = spec.layers[index];
  SpectrumParams p = formula_parameters(L);
  LayerSpectrum s;
  s.h0.resize(size_t(L.nx * L.ny));
  s.w.resize(s.h0.size());
  double dkx = 2 * kPi / L.lx, dky = 2 * kPi / L.ly;
  for (int64_t j = 0; j < L.ny; ++j)
    for (int64_t i = 0; i < L.nx; ++i) {
      int64_t n = signed_mode(i, L.nx), m = signed_mode(j, L.ny);
      double kx = n * dkx, ky = m * dky, k = std::hypot(kx, ky);
      double cell_a, cell_b;  // the mode's angular cell
      sq_mode_cell(kx, ky, dkx, dky, &cell_a, &cell_b);
      double P = sq_spatial_spectrum(p, kx, ky, omega(L, k), group_velocity(L, k), cell_a, cell_b);
      if (2 * i == L.nx || 2 * j == L.ny || k < L.k_min || (L.k_max > 0 && k > L.k_max)) P = 0;
      if (spec.b_correction && P > 0) {
        double B = coverage(spec, kx, ky);
        P = B > 0 ? P / B : 0;
      }
      size_t at = size_t(i + L.nx * j);
      s.h0[at] = gaussian_pair(L.seed, int(index), n, m) * std::sqrt(0.5 * P * dkx * dky);
      s.w[at] = omega(L, k);
    }
  return s;
}

std::string spectrum_key(const TileSpec& spec, size_t index) {
  const LayerSpec& L = spec.layers[index];
  std::string key;
  auto add = [&](const void* p, size_t n) { key.append(static_cast<const char*>(p), n); };
  double d[] = {L.lx,
                L.ly,
                L.wind_speed,
                L.fetch,
                L.gamma,
                L.sigma_a,
                L.sigma_b,
                L.phillips_amplitude,
                L.phillips_cutoff,
                L.phillips_exponent,
                L.wind_direction,
                L.depth,
                L.capillary_length,
                L.gravity,
                L.k_min,
                L.k_max};
  int64_t i[] = {L.nx,
                 L.ny,
                 int64_t(L.spectrum),
                 int64_t(L.spreading),
                 int64_t(L.dispersion),
                 int64_t(index),
                 int64_t(spec.b_correction)};
  add(d, sizeof d), add(i, sizeof i), add(&L.seed, sizeof L.seed);
  for (const auto& q : L.partials) add(&q, sizeof q);
  if (spec.b_correction)
    for (const auto& o : spec.layers) {
      double g[] = {o.lx, o.ly, double(o.nx), double(o.ny)};
      add(g, sizeof g);
    }
  return key;
}

// Channels: h, Dx, Dy, eps_x, eps_y, dDx/dx, dDy/dy, dDx/dy (D = sum i k/|k| h~ e^{ik.x}).
int channels_needed(unsigned outputs) {
  if (outputs & (Normals | Jacobian | Whitecaps)) return 8;
  if (outputs & Slopes) return 5;
  if (outputs & Displacement) return 3;
  return 1;
}

}  // namespace

struct CpuReference::Impl {
  int threads;
  std::list<std::pair<std::string, LayerSpectrum>> cache;
  std::map<std::array<int64_t, 3>, fftw_plan> plans;
  std::map<std::string, double> slope_variances;

  const LayerSpectrum& spectrum(const TileSpec& spec, size_t index) {
    std::string key = spectrum_key(spec, index);
    for (auto it = cache.begin(); it != cache.end(); ++it)
      if (it->first == key) {
        cache.splice(cache.begin(), cache, it);
        return cache.front().second;
      }
    if (cache.size() >= 16) cache.pop_back();
    cache.emplace_front(key, build_spectrum(spec, index));
    return cache.front().second;
  }

  fftw_plan plan(int64_t nx, int64_t ny, int howmany, fftw_complex* data) {
    std::array<int64_t, 3> key{nx, ny, howmany};
    auto it = plans.find(key);
    if (it != plans.end()) return it->second;
    int dims[2] = {int(ny), int(nx)};
    int dist = int(nx * ny);
    fftw_plan p = fftw_plan_many_dft(2, dims, howmany, data, nullptr, 1, dist, data, nullptr, 1, dist, FFTW_BACKWARD,
                                     FFTW_ESTIMATE);
    plans[key] = p;
    return p;
  }

  ~Impl() {
    for (auto& [key, p] : plans) fftw_destroy_plan(p);
  }
};

CpuReference::CpuReference(int threads) : impl_(std::make_unique<Impl>()) {
  impl_->threads = std::max(1, threads);
#ifdef SQUALL_FFTW_THREADS
  static bool initialized = fftw_init_threads() != 0;
  if (initialized) fftw_plan_with_nthreads(impl_->threads);
#endif
}
CpuReference::~CpuReference() = default;

double CpuReference::mean_frequency(const LayerSpec& L) { return formula_parameters(L).omega_mean; }

double CpuReference::spectrum(const LayerSpec& L, double kx, double ky, double dkx, double dky) {
  double k = std::hypot(kx, ky), cell_a, cell_b;
  sq_mode_cell(kx, ky, dkx, dky, &cell_a, &cell_b);
  return sq_spatial_spectrum(formula_parameters(L), kx, ky, omega(L, k), group_velocity(L, k), cell_a, cell_b);
}

namespace {
// h~(k, t) of eqs 43 and 1 at mode (n, m) of a layer.
cplx evolved(const LayerSpec& L, const LayerSpectrum& s, int64_t n, int64_t m, double t) {
  int64_t i = (n + L.nx) % L.nx, j = (m + L.ny) % L.ny;
  int64_t mi = (L.nx - i) % L.nx, mj = (L.ny - j) % L.ny;
  size_t at = size_t(i + L.nx * j), minus = size_t(mi + L.nx * mj);
  double w = s.w[at];
  double kx = n * 2 * kPi / L.lx, ky = m * 2 * kPi / L.ly;
  cplx h = s.h0[at] * std::polar(1.0, -w * t) + std::conj(s.h0[minus]) * std::polar(1.0, w * t);  // eq 43
  return h * std::polar(1.0, -(kx * L.drift_x + ky * L.drift_y) * t);                             // eq 1
}

// Eq 96 (sign fixed) by a 2D quadrature in (ln k, theta) of k^2 (P(k) + P(-k)).
double slope_variance(const TileSpec& spec, double R) {
  double k_lo = kPi / R, k_hi = spec.slope_k_max, total = 0;
  if (!(k_hi > k_lo)) return 0;
  const int nk = 1500, nt = 256;
  for (const LayerSpec& L : spec.layers) {
    SpectrumParams p = formula_parameters(L);
    double u0 = std::log(k_lo), du = (std::log(k_hi) - u0) / nk, sum = 0;
    for (int a = 0; a < nk; ++a) {
      double k = std::exp(u0 + (a + 0.5) * du);
      if (k < L.k_min || (L.k_max > 0 && k > L.k_max)) continue;
      double w = omega(L, k), vg = group_velocity(L, k), ring = 0;
      for (int b = 0; b < nt; ++b) {
        double th = 2 * kPi * (b + 0.5) / nt;
        ring += sq_spatial_spectrum(p, k * std::cos(th), k * std::sin(th), w, vg, 2 * kPi / nt, 0);
      }
      sum += 2 * k * k * ring * (2 * kPi / nt) * k * (k * du);  // (P(k)+P(-k)) over the circle, d^2k = k dk dth
    }
    total += sum;
  }
  return spec.b_correction ? total / double(spec.layers.size()) : total;
}
}  // namespace

TileFields CpuReference::tile(const TileSpec& spec, double t, unsigned outputs, WhitecapState* whitecaps) {
  bool custom = spec.nx != 0 || spec.ny != 0 || spec.lx != 0 || spec.ly != 0;
  const LayerSpec& first = spec.layers.front();
  int64_t onx = custom ? spec.nx : first.nx, ony = custom ? spec.ny : first.ny;
  double olx = custom ? spec.lx : first.lx, oly = custom ? spec.ly : first.ly;
  const size_t ocells = size_t(onx * ony);
  const int channels = channels_needed(outputs);
  std::vector<double> sum(size_t(channels) * ocells, 0.0);

  for (size_t a = 0; a < spec.layers.size(); ++a) {
    const LayerSpec& L = spec.layers[a];
    const size_t cells = size_t(L.nx * L.ny);
    const LayerSpectrum& spectrum = impl_->spectrum(spec, a);
    fftw_complex* data = fftw_alloc_complex(cells * channels);
    auto* c = reinterpret_cast<cplx*>(data);
    for (int64_t j = 0; j < L.ny; ++j)
      for (int64_t i = 0; i < L.nx; ++i) {
        int64_t n = signed_mode(i, L.nx), m = signed_mode(j, L.ny);
        cplx h = evolved(L, spectrum, n, m, t), ih = cplx(0, 1) * h;
        double kx = n * 2 * kPi / L.lx, ky = m * 2 * kPi / L.ly, k = std::hypot(kx, ky);
        double inv_k = k > 0 ? 1 / k : 0;
        cplx values[8] = {h,       ih * kx * inv_k,      ih * ky * inv_k,      ih * kx,
                          ih * ky, -h * kx * kx * inv_k, -h * ky * ky * inv_k, -h * kx * ky * inv_k};
        for (int q = 0; q < channels; ++q) c[q * cells + size_t(i + L.nx * j)] = values[q];
      }
    fftw_execute_dft(impl_->plan(L.nx, L.ny, channels, data), data, data);
    // periodic bilinear resampling onto the output grid
    double sx = (olx / onx) / (L.lx / L.nx), sy = (oly / ony) / (L.ly / L.ny);
    for (int64_t j = 0; j < ony; ++j)
      for (int64_t i = 0; i < onx; ++i) {
        double u = i * sx, v = j * sy;
        u -= L.nx * std::floor(u / L.nx);
        v -= L.ny * std::floor(v / L.ny);
        int64_t i0 = std::min<int64_t>(int64_t(u), L.nx - 1), j0 = std::min<int64_t>(int64_t(v), L.ny - 1);
        double fu = u - i0, fv = v - j0;
        int64_t i1 = (i0 + 1) % L.nx, j1 = (j0 + 1) % L.ny;
        for (int q = 0; q < channels; ++q) {
          const cplx* f = c + q * cells;
          double value = (1 - fv) * ((1 - fu) * f[i0 + L.nx * j0].real() + fu * f[i1 + L.nx * j0].real()) +
                         fv * ((1 - fu) * f[i0 + L.nx * j1].real() + fu * f[i1 + L.nx * j1].real());
          sum[q * ocells + size_t(i + onx * j)] += value;
        }
      }
    fftw_free(data);
  }

  TileFields out;
  out.nx = onx, out.ny = ony, out.dx = olx / onx, out.dy = oly / ony, out.t = t;
  const unsigned wanted = planes_of(outputs);
  std::array<std::vector<float>, kPlaneCount> planes;  // in TileFields' order
  for (int i = 0; i < kPlaneCount; ++i)
    if (wanted & (1u << i)) planes[i].resize(ocells);
  double decay = 0;
  bool continuing = whitecaps && !whitecaps->empty() && whitecaps->matches(onx, ony);
  if (continuing) decay = std::exp(-(t - whitecaps->last_t()) / spec.whitecap_decay);
  const double lambda = spec.choppiness;
  for (size_t p = 0; p < ocells; ++p) {
    auto set = [&](plane::Index i, double value) { planes[i][p] = float(value); };
    double ch[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    for (int q = 0; q < channels; ++q) ch[q] = sum[q * ocells + p];
    if (outputs & Height) set(plane::Height, ch[0]);
    if (outputs & Displacement) set(plane::DisplacementX, lambda * ch[1]), set(plane::DisplacementY, lambda * ch[2]);
    if (outputs & Slopes) set(plane::SlopeX, ch[3]), set(plane::SlopeY, ch[4]);
    double Jxx = 1 + lambda * ch[5], Jyy = 1 + lambda * ch[6], Jxy = lambda * ch[7];
    if (outputs & Normals) {
      double n[3] = {Jxy * ch[4] - ch[3] * Jyy, ch[3] * Jxy - Jxx * ch[4], Jxx * Jyy - Jxy * Jxy};
      double norm = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
      set(plane::NormalX, n[0] / norm), set(plane::NormalY, n[1] / norm), set(plane::NormalZ, n[2] / norm);
    }
    double half_trace = 0.5 * (Jxx + Jyy), radius = std::hypot(0.5 * (Jxx - Jyy), Jxy);
    double minus = half_trace - radius, plus = half_trace + radius;
    if (outputs & Jacobian)
      set(plane::Jacobian, Jxx * Jyy - Jxy * Jxy), set(plane::JacobianMinus, minus), set(plane::JacobianPlus, plus);
    if (outputs & Whitecaps) {
      double previous = continuing ? whitecaps->map()[p] : 0.0;
      set(plane::Whitecaps, minus < spec.whitecap_threshold ? 1.0 : previous * decay);
    }
  }
  if ((outputs & Whitecaps) && whitecaps) {
    whitecaps->mutable_map() = planes[plane::Whitecaps];
    whitecaps->set(onx, ony, t);
  }
  for (int i = 0; i < kPlaneCount; ++i)
    if (wanted & (1u << i)) out.*kTilePlanes[i] = FloatView(std::move(planes[i]));
  double R = spec.pixel_scale > 0 ? spec.pixel_scale : std::max(out.dx, out.dy);
  std::string key = std::to_string(R);
  for (size_t a = 0; a < spec.layers.size(); ++a) key += spectrum_key(spec, a);
  key.append(reinterpret_cast<const char*>(&spec.slope_k_max), sizeof(double));
  auto it = impl_->slope_variances.find(key);
  if (it == impl_->slope_variances.end()) it = impl_->slope_variances.emplace(key, slope_variance(spec, R)).first;
  out.unresolved_slope_variance = it->second;
  return out;
}

}  // namespace squall::ocean
