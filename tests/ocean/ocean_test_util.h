// Shared helpers of the ocean engine tests.
#pragma once

#include <cmath>
#include <complex>
#include <span>
#include <vector>

#include <fftw3.h>

#include "ocean/ocean_engine.h"
#include "support/test_runtime.h"

namespace squall::ocean::test {

inline OceanEngine& engine() {
  static OceanEngine* e = new OceanEngine(squall::test::runtime(), squall::test::fft());
  return *e;
}

inline TileSpec single(SpectrumModel spectrum, SpreadingModel spreading, int64_t n, double L, uint64_t seed = 1) {
  TileSpec spec;
  LayerSpec layer;
  layer.spectrum = spectrum;
  layer.spreading = spreading;
  layer.nx = layer.ny = n;
  layer.lx = layer.ly = L;
  layer.seed = seed;
  spec.layers.push_back(layer);
  return spec;
}

inline double rms(std::span<const float> v) {
  double s = 0;
  for (float x : v) s += double(x) * x;
  return std::sqrt(s / v.size());
}

inline double relative_rms_error(std::span<const float> a, std::span<const float> b) {
  double e = 0, r = 0;
  for (size_t i = 0; i < a.size(); ++i) e += std::pow(double(a[i]) - b[i], 2), r += double(b[i]) * b[i];
  return std::sqrt(e / r);
}

// h~(k) = forward DFT / (nx ny) of a real field, in double (FFTW).
inline std::vector<std::complex<double>> spectrum_of(std::span<const float> field, int64_t nx, int64_t ny) {
  std::vector<std::complex<double>> data(field.begin(), field.end());
  fftw_plan plan = fftw_plan_dft_2d(int(ny), int(nx), reinterpret_cast<fftw_complex*>(data.data()),
                                    reinterpret_cast<fftw_complex*>(data.data()), FFTW_FORWARD, FFTW_ESTIMATE);
  fftw_execute(plan);
  fftw_destroy_plan(plan);
  for (auto& c : data) c /= double(nx * ny);
  return data;
}

inline int64_t signed_mode(int64_t i, int64_t n) { return i < n / 2 ? i : i - n; }

}  // namespace squall::ocean::test
