// Image metrics for the physics tests of the advected textures: the claims of Q. Yu, F. Neyret, E. Bruneton,
// N. Holzschuch, "Lagrangian Texture Advection: Preserving both Spectrum and Velocity Field" (IEEE TVCG 2011)
// are checked on rendered textures: the optical flow matches the input velocity, the Fourier spectrum matches
// the input texture's, the variance is preserved. Host-only, double precision, FFTW for the transforms.
#pragma once

#include <vector>

namespace squall::test {

// A single-channel float image, row-major, x fastest.
struct Image {
  int width = 0, height = 0;
  std::vector<float> values;
  float at(int x, int y) const;
  // The w x h sub-image whose corner is (x0, y0); throws std::out_of_range unless it lies inside.
  Image crop(int x0, int y0, int w, int h) const;
};

double mean(const Image&);
double stddev(const Image&);  // population std

// Radially averaged power spectrum: mean removed, separable Hann window, |FFT|^2 averaged over annuli of
// the radial frequency |k| in cycles per pixel; `bins` equal-width bins over (0, 0.5]. Uses FFTW (double).
// A bin that no frequency falls in is 0.
std::vector<double> radial_power_spectrum(const Image&, int bins);

// Mean over bins [first, last] of |log10(a/b)| (the spectrum comparison). Throws std::invalid_argument on a
// bin range outside both spectra or a non-positive value in it.
double mean_abs_log10_ratio(const std::vector<double>& a, const std::vector<double>& b, int first, int last);

// Spectral anisotropy lambda_max / lambda_min of M = sum |F(k)|^2 k k^T / sum |F(k)|^2 (mean removed, Hann
// window), over k != 0 with |k| <= 0.5 cycles/pixel. 1 for an isotropic image; a random isotropic texture
// fluctuates about 1 by roughly 2 / sqrt(correlation cells in the image). Throws std::invalid_argument on a
// constant image.
double spectral_anisotropy(const Image&);

// Displacement (in pixels) that moves window content of `a` to where it is in `b`: b(x) ~ a(x - d).
struct Displacement {
  double dx = 0, dy = 0;
  bool valid = false;
};

// Phase correlation on the window [x0, x0+size) x [y0, y0+size) of both images (Hann windowed); the peak is
// located to sub-pixel by a three-point Gaussian fit, and b's window is resampled (bilinear, clamp-to-edge) at
// the estimate and correlated again until the residual is below 0.01 px (at most 4 passes). valid=false if a
// pass has a weak peak (below 0.6 of a perfect match).
Displacement phase_correlation(const Image& a, const Image& b, int x0, int y0, int size);

// Windowed Lucas-Kanade on the same window, iterated (up to 10 Gauss-Newton steps with bilinear warping) so
// that displacements of a few pixels are recovered on smooth images. valid=false if the structure tensor is
// ill-conditioned or the iteration leaves the window.
Displacement lucas_kanade(const Image& a, const Image& b, int x0, int y0, int size);

// Local standard deviation (population) over non-overlapping windows of `window` x `window` pixels, row-major;
// pixels past the last whole window are left out.
std::vector<double> local_std(const Image&, int window);

// Coefficient of variation (population std / mean) of a set of values.
double coefficient_of_variation(const std::vector<double>&);

// Bilinear sample with clamp-to-edge at (x, y) in pixel coordinates where pixel (i,j) has its centre at (i, j).
double bilinear(const Image&, double x, double y);

}  // namespace squall::test
