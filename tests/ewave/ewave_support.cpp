#include "ewave_support.h"

#include <fftw3.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <complex>
#include <cstdlib>

#include "support/test_runtime.h"

namespace squall::ewave::test {

EWaveConfig plain_config(int64_t nx, int64_t ny, double spacing) {
  EWaveConfig c;
  c.nx = nx, c.ny = ny, c.dx = spacing, c.dy = spacing;
  c.trim = false;
  return c;
}

fft::Fft& session_fft() {
  const char* backend = std::getenv("SQUALL_EWAVE_TEST_FFT");  // a backend other than the engine tests' one
  return squall::test::fft(backend ? backend : squall::test::engine_fft_backend());
}

EWaveSession make_session(const EWaveConfig& config) {
  return EWaveSession(squall::test::runtime(), session_fft(), config);
}

void expect_bit_identical(const Frame& a, const Frame& b) {
  EXPECT_EQ(a.step, b.step);
  EXPECT_EQ(a.time, b.time);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(a.phi, b.phi);
  EXPECT_EQ(a.displacement_x, b.displacement_x);
  EXPECT_EQ(a.displacement_y, b.displacement_y);
  EXPECT_EQ(a.normals, b.normals);
}

double reference_omega(double k, const EWaveConfig& c) {
  double w2 = c.gravity * k;
  if (c.dispersion == DispersionKind::Shallow || c.dispersion == DispersionKind::Combined) w2 *= std::tanh(k * c.depth);
  if (c.dispersion == DispersionKind::Capillary || c.dispersion == DispersionKind::Combined)
    w2 *= 1 + (k * c.capillary_length) * (k * c.capillary_length);
  return std::sqrt(w2);
}

double reference_restoring(double k, const EWaveConfig& c) {
  const bool tension = c.dispersion == DispersionKind::Capillary || c.dispersion == DispersionKind::Combined;
  return c.gravity * (tension ? 1 + (k * c.capillary_length) * (k * c.capillary_length) : 1);
}

namespace {

std::vector<std::complex<double>> dft(const std::vector<float>& f, size_t nx, size_t ny) {
  std::vector<std::complex<double>> data(f.begin(), f.end());
  auto* p = reinterpret_cast<fftw_complex*>(data.data());
  fftw_plan plan = fftw_plan_dft_2d(int(ny), int(nx), p, p, FFTW_FORWARD, FFTW_ESTIMATE);
  fftw_execute(plan);
  fftw_destroy_plan(plan);
  return data;
}

}  // namespace

double spectral_energy(const std::vector<float>& h, const std::vector<float>& phi, const EWaveConfig& c) {
  const size_t nx = size_t(c.nx), ny = size_t(c.ny);
  auto ht = dft(h, nx, ny), pt = dft(phi, nx, ny);
  double e = 0;
  for (size_t j = 0; j < ny; ++j)
    for (size_t i = 0; i < nx; ++i) {
      double ii = i <= nx / 2 ? double(i) : double(i) - double(nx);
      double jj = j <= ny / 2 ? double(j) : double(j) - double(ny);
      double k = std::hypot(2 * M_PI * ii / c.length_x(), 2 * M_PI * jj / c.length_y());
      double w = reference_omega(k, c), G = reference_restoring(k, c);
      size_t m = i + nx * j;
      e += G * std::norm(ht[m]) + w * w / G * std::norm(pt[m]);
    }
  return e;
}

StepInputs plain_step(double dt) {
  StepInputs in;
  in.dt = dt;
  in.outputs.phi = true;
  return in;
}

std::vector<float> field(const EWaveConfig& c, const std::function<double(double, double)>& f) {
  std::vector<float> out(c.cells());
  for (int64_t j = 0; j < c.ny; ++j)
    for (int64_t i = 0; i < c.nx; ++i) out[i + c.nx * j] = float(f((i + 0.5) * c.dx, (j + 0.5) * c.dy));
  return out;
}

double rms(const std::vector<float>& a) {
  double s = 0;
  for (float v : a) s += double(v) * v;
  return std::sqrt(s / double(a.size()));
}

double rms_difference(const std::vector<float>& a, const std::vector<float>& b) {
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i) s += (double(a[i]) - b[i]) * (double(a[i]) - b[i]);
  return std::sqrt(s / double(a.size()));
}

double max_abs(const std::vector<float>& a) {
  double m = 0;
  for (float v : a) m = std::max(m, double(std::abs(v)));
  return m;
}

}  // namespace squall::ewave::test
