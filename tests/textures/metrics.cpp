// Image metrics of the advected-textures physics tests (see metrics.h).
#include "textures/metrics.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>

#include <fftw3.h>

namespace squall::test {
namespace {

using Spectrum = std::vector<std::complex<double>>;

void check_window(const Image& image, int x0, int y0, int w, int h) {
  if (x0 < 0 || y0 < 0 || w <= 0 || h <= 0 || x0 + w > image.width || y0 + h > image.height) {
    throw std::out_of_range("window " + std::to_string(w) + "x" + std::to_string(h) + " at (" + std::to_string(x0) +
                            ", " + std::to_string(y0) + ") outside a " + std::to_string(image.width) + "x" +
                            std::to_string(image.height) + " image");
  }
}

// Hann window sin^2(pi (i + 1/2) / n), symmetric about the centre of n samples.
double hann(int i, int n) {
  const double s = std::sin(std::numbers::pi * (i + 0.5) / n);
  return s * s;
}

// Signed frequency of DFT index i of n, in cycles per sample.
double frequency(int i, int n) { return (i <= n / 2 ? i : i - n) / static_cast<double>(n); }

// Unnormalised 2-D DFT of a row-major w x h array (FFTW, double); sign is FFTW_FORWARD or FFTW_BACKWARD.
Spectrum fft(Spectrum data, int w, int h, int sign) {
  auto* p = reinterpret_cast<fftw_complex*>(data.data());
  fftw_plan plan = fftw_plan_dft_2d(h, w, p, p, sign, FFTW_ESTIMATE);
  fftw_execute(plan);
  fftw_destroy_plan(plan);
  return data;
}

// Spectrum of the image with its mean removed and a separable Hann window applied.
Spectrum windowed_fft(const Image& image) {
  const double m = mean(image);
  Spectrum data(image.values.size());
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      data[static_cast<size_t>(y) * image.width + x] =
          (image.at(x, y) - m) * hann(x, image.width) * hann(y, image.height);
    }
  }
  return fft(std::move(data), image.width, image.height, FFTW_FORWARD);
}

// Eigenvalues (smaller, larger) of the symmetric matrix [[xx, xy], [xy, yy]].
std::pair<double, double> eigenvalues(double xx, double xy, double yy) {
  const double m = 0.5 * (xx + yy), r = std::hypot(0.5 * (xx - yy), xy);
  return {m - r, m + r};
}

// Offset in (-1, 1) of the maximum of a Gaussian through three equally spaced samples (the three-point
// Gaussian estimator of C. Willert, M. Gharib, "Digital particle image velocimetry", Exp. Fluids 10, 1991).
double gaussian_peak(double minus, double centre, double plus) {
  const double floor = 1e-9 * centre;
  const double lm = std::log(std::max(minus, floor)), lc = std::log(centre), lp = std::log(std::max(plus, floor));
  const double curvature = lm - 2 * lc + lp;
  return curvature < 0 ? std::clamp(0.5 * (lm - lp) / curvature, -1.0, 1.0) : 0.0;
}

// Index in [-n/2, n/2) of the circular offset i.
int wrap_signed(int i, int n) { return i >= n / 2 ? i - n : i; }

// The size x size window of b whose corner is at (x0, y0), sampled bilinearly.
Image resample(const Image& b, double x0, double y0, int size) {
  Image out{size, size, std::vector<float>(static_cast<size_t>(size) * size)};
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) out.values[static_cast<size_t>(y) * size + x] = bilinear(b, x0 + x, y0 + y);
  }
  return out;
}

struct Peak {
  double dx, dy, height;
};

// Phase correlation of two square windows: the inverse transform of the cross-power spectrum
// conj(A) B / (|conj(A) B| + eps) peaks at d where b(x) = a(x - d). eps (1e-3 of the strongest bin) keeps the
// bins that hold only window leakage out of the whitening; a Gaussian weight makes the peak a Gaussian of 1 px
// standard deviation, which the three-point Gaussian fit locates to sub-pixel accuracy. height is the peak
// relative to a perfect match.
Peak correlation_peak(const Image& wa, const Image& wb) {
  constexpr double kPeakSigma = 1.0;  // px
  constexpr double kRegularisation = 1e-3;
  const int size = wa.width;
  const Spectrum fa = windowed_fft(wa), fb = windowed_fft(wb);
  Spectrum cross(fa.size());
  double strongest = 0;
  for (size_t n = 1; n < fa.size(); ++n) {
    cross[n] = std::conj(fa[n]) * fb[n];
    strongest = std::max(strongest, std::abs(cross[n]));
  }
  if (strongest == 0) return {0, 0, 0};
  const double sigma_k = 1 / (2 * std::numbers::pi * kPeakSigma);
  double perfect = 0;
  for (int j = 0; j < size; ++j) {
    for (int i = 0; i < size; ++i) {
      const size_t n = static_cast<size_t>(j) * size + i;
      const double k2 = std::pow(frequency(i, size), 2) + std::pow(frequency(j, size), 2);
      const double g = std::exp(-k2 / (2 * sigma_k * sigma_k));
      const double magnitude = std::abs(cross[n]);
      cross[n] *= g / (magnitude + kRegularisation * strongest);
      perfect += magnitude > 0 ? g * magnitude / (magnitude + kRegularisation * strongest) : 0.0;
    }
  }
  const Spectrum r = fft(std::move(cross), size, size, FFTW_BACKWARD);
  const auto best = std::max_element(r.begin(), r.end(), [](auto p, auto q) { return p.real() < q.real(); });
  const int bi = static_cast<int>(best - r.begin()) % size, bj = static_cast<int>(best - r.begin()) / size;
  auto value = [&](int i, int j) {
    return r[static_cast<size_t>((j + size) % size) * size + (i + size) % size].real();
  };
  const double c = value(bi, bj);
  return {wrap_signed(bi, size) + gaussian_peak(value(bi - 1, bj), c, value(bi + 1, bj)),
          wrap_signed(bj, size) + gaussian_peak(value(bi, bj - 1), c, value(bi, bj + 1)), c / perfect};
}

}  // namespace

float Image::at(int x, int y) const { return values[static_cast<size_t>(y) * width + x]; }

Image Image::crop(int x0, int y0, int w, int h) const {
  check_window(*this, x0, y0, w, h);
  Image out{w, h, std::vector<float>(static_cast<size_t>(w) * h)};
  for (int y = 0; y < h; ++y) {
    std::copy_n(values.begin() + static_cast<ptrdiff_t>(y0 + y) * width + x0, w,
                out.values.begin() + static_cast<ptrdiff_t>(y) * w);
  }
  return out;
}

double mean(const Image& image) {
  double sum = 0;
  for (float v : image.values) sum += v;
  return image.values.empty() ? 0.0 : sum / image.values.size();
}

double stddev(const Image& image) {
  const double m = mean(image);
  double sum = 0;
  for (float v : image.values) sum += (v - m) * (v - m);
  return image.values.empty() ? 0.0 : std::sqrt(sum / image.values.size());
}

// Periodogram with a Hann taper (P. Welch, "The use of fast Fourier transform for the estimation of power
// spectra", IEEE Trans. Audio Electroacoust. 15, 1967, with one segment), averaged over annuli of |k|.
std::vector<double> radial_power_spectrum(const Image& image, int bins) {
  if (bins <= 0) throw std::invalid_argument("radial_power_spectrum: bins must be positive");
  const Spectrum f = windowed_fft(image);
  std::vector<double> sum(bins, 0.0);
  std::vector<int> count(bins, 0);
  for (int j = 0; j < image.height; ++j) {
    for (int i = 0; i < image.width; ++i) {
      const double k = std::hypot(frequency(i, image.width), frequency(j, image.height));
      if (k == 0 || k > 0.5) continue;
      const int bin = std::clamp(static_cast<int>(std::ceil(k * 2 * bins)) - 1, 0, bins - 1);
      sum[bin] += std::norm(f[static_cast<size_t>(j) * image.width + i]);
      ++count[bin];
    }
  }
  for (int b = 0; b < bins; ++b) sum[b] = count[b] > 0 ? sum[b] / count[b] : 0.0;
  return sum;
}

double mean_abs_log10_ratio(const std::vector<double>& a, const std::vector<double>& b, int first, int last) {
  const int size = static_cast<int>(std::min(a.size(), b.size()));
  if (first < 0 || last < first || last >= size) throw std::invalid_argument("mean_abs_log10_ratio: bad bin range");
  double sum = 0;
  for (int i = first; i <= last; ++i) {
    if (!(a[i] > 0 && b[i] > 0)) throw std::invalid_argument("mean_abs_log10_ratio: non-positive bin");
    sum += std::abs(std::log10(a[i] / b[i]));
  }
  return sum / (last - first + 1);
}

// Ratio of the principal axes of the power-weighted second moment of the spectrum (the structure tensor in
// the Fourier domain, J. Bigun, G. Granlund, "Optimal orientation detection of linear symmetry", ICCV 1987).
double spectral_anisotropy(const Image& image) {
  const Spectrum f = windowed_fft(image);
  double xx = 0, xy = 0, yy = 0;
  for (int j = 0; j < image.height; ++j) {
    for (int i = 0; i < image.width; ++i) {
      const double kx = frequency(i, image.width), ky = frequency(j, image.height);
      if ((kx == 0 && ky == 0) || std::hypot(kx, ky) > 0.5) continue;
      const double p = std::norm(f[static_cast<size_t>(j) * image.width + i]);
      xx += p * kx * kx;
      xy += p * kx * ky;
      yy += p * ky * ky;
    }
  }
  const auto [low, high] = eigenvalues(xx, xy, yy);
  if (!(high > 0)) throw std::invalid_argument("spectral_anisotropy: constant image");
  return high / low;
}

// Phase correlation (C. Kuglin, D. Hines, "The phase correlation image alignment method", 1975) refined by
// iterative window deformation (F. Scarano, "Iterative image deformation methods in PIV", Meas. Sci. Technol.
// 13, 2002): the window of b is resampled at the current estimate and the residual shift added, which removes
// the bias toward zero that the fixed Hann window causes. valid=false if any pass has a weak peak.
Displacement phase_correlation(const Image& a, const Image& b, int x0, int y0, int size) {
  constexpr int kPasses = 4;
  constexpr double kConverged = 0.01;  // px
  constexpr double kMinPeak = 0.6;     // of a perfect match: shifted noise gives 0.85-1, unrelated noise up to 0.55
  const Image window = a.crop(x0, y0, size, size);
  Displacement d{0, 0, true};
  for (int pass = 0; pass < kPasses; ++pass) {
    const Peak p = correlation_peak(window, resample(b, x0 + d.dx, y0 + d.dy, size));
    if (p.height < kMinPeak) return {};
    d.dx += p.dx;
    d.dy += p.dy;
    if (std::hypot(p.dx, p.dy) < kConverged) break;
  }
  return d;
}

// Lucas-Kanade (B. Lucas, T. Kanade, "An iterative image registration technique with an application to stereo
// vision", IJCAI 1981): Gauss-Newton on sum (a(x) - b(x + d))^2 over the window, b warped bilinearly at each
// step; the gradient is the mean of those of a and of the warped b, which speeds up convergence.
Displacement lucas_kanade(const Image& a, const Image& b, int x0, int y0, int size) {
  constexpr int kIterations = 10;
  constexpr double kMinConditioning = 1e-3;  // smaller / larger eigenvalue of the structure tensor
  constexpr double kConverged = 1e-4;        // px
  check_window(a, x0, y0, size, size);
  Displacement d;
  for (int iteration = 0; iteration < kIterations; ++iteration) {
    double xx = 0, xy = 0, yy = 0, ex = 0, ey = 0;
    for (int y = y0; y < y0 + size; ++y) {
      for (int x = x0; x < x0 + size; ++x) {
        const double px = x + d.dx, py = y + d.dy;
        const double gx =
            0.25 * (bilinear(b, px + 1, py) - bilinear(b, px - 1, py) + bilinear(a, x + 1, y) - bilinear(a, x - 1, y));
        const double gy =
            0.25 * (bilinear(b, px, py + 1) - bilinear(b, px, py - 1) + bilinear(a, x, y + 1) - bilinear(a, x, y - 1));
        const double e = a.at(x, y) - bilinear(b, px, py);
        xx += gx * gx;
        xy += gx * gy;
        yy += gy * gy;
        ex += gx * e;
        ey += gy * e;
      }
    }
    const auto [low, high] = eigenvalues(xx, xy, yy);
    if (!(high > 0 && low > kMinConditioning * high)) return {};
    const double det = xx * yy - xy * xy;
    const double sx = (yy * ex - xy * ey) / det, sy = (xx * ey - xy * ex) / det;
    d.dx += sx;
    d.dy += sy;
    if (!(std::hypot(d.dx, d.dy) < 0.5 * size)) return {};
    if (std::hypot(sx, sy) < kConverged) break;
  }
  d.valid = true;
  return d;
}

std::vector<double> local_std(const Image& image, int window) {
  if (window <= 0) throw std::invalid_argument("local_std: window must be positive");
  std::vector<double> out;
  for (int y = 0; y + window <= image.height; y += window) {
    for (int x = 0; x + window <= image.width; x += window) out.push_back(stddev(image.crop(x, y, window, window)));
  }
  return out;
}

double coefficient_of_variation(const std::vector<double>& values) {
  if (values.empty()) throw std::invalid_argument("coefficient_of_variation: no values");
  double sum = 0, sum2 = 0;
  for (double v : values) sum += v;
  const double m = sum / values.size();
  for (double v : values) sum2 += (v - m) * (v - m);
  return std::sqrt(sum2 / values.size()) / m;
}

double bilinear(const Image& image, double x, double y) {
  x = std::clamp(x, 0.0, image.width - 1.0);
  y = std::clamp(y, 0.0, image.height - 1.0);
  const int i = std::max(0, std::min(static_cast<int>(x), image.width - 2));
  const int j = std::max(0, std::min(static_cast<int>(y), image.height - 2));
  const int i1 = std::min(i + 1, image.width - 1), j1 = std::min(j + 1, image.height - 1);
  const double fx = x - i, fy = y - j;
  return (1 - fy) * ((1 - fx) * image.at(i, j) + fx * image.at(i1, j)) +
         fy * ((1 - fx) * image.at(i, j1) + fx * image.at(i1, j1));
}

}  // namespace squall::test
