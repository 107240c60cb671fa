#include "textures/deform_support.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "support/test_runtime.h"

namespace squall::test {

using namespace squall::textures;

DeformEngine& deform_engine() {
  static LimitGate gate{Limits{}};
  static DeformEngine engine(runtime(), gate);
  return engine;
}

DeformSpec disk_spec(int size, const std::vector<Disk>& disks, const std::vector<float>& texture) {
  DeformSpec spec;
  spec.width = spec.height = size;
  spec.pixels = texture;
  spec.channels = int(texture.size() / (size_t(size) * size));
  spec.rigidity.assign(size_t(size) * size, disks.empty() ? 0.0f : -1.0f);
  for (int j = 0; j < size; ++j)
    for (int i = 0; i < size; ++i)
      for (const Disk& d : disks)
        if (std::hypot(i + 0.5 - d.x, j + 0.5 - d.y) <= d.radius) spec.rigidity[size_t(i) + size_t(size) * j] = 1;
  return spec;
}

std::vector<float> smooth_texture(int size) {
  std::vector<float> out(size_t(size) * size);
  const double k = 2 * std::numbers::pi;
  for (int j = 0; j < size; ++j)
    for (int i = 0; i < size; ++i)
      out[size_t(i) + size_t(size) * j] =
          float(0.5 + 0.25 * std::sin(k * (i + 0.5) / 16) + 0.25 * std::cos(k * (j + 0.5) / 13));
  return out;
}

std::vector<float> disk_indicator(int size, const Disk& disk) {
  std::vector<float> out(size_t(size) * size);
  for (int j = 0; j < size; ++j)
    for (int i = 0; i < size; ++i)
      out[size_t(i) + size_t(size) * j] =
          float(std::clamp(disk.radius - std::hypot(i + 0.5 - disk.x, j + 0.5 - disk.y) + 0.5, 0.0, 1.0));
  return out;
}

std::vector<DeformFrame> run(const DeformSpec& spec, int frames, const DeformPlanes& planes) {
  deform_engine().validate(spec, "spec");
  auto deformation = deform_engine().start(spec);
  std::vector<DeformFrame> out;
  for (int i = 0; i < frames; ++i) out.push_back(deformation->next(planes));
  return out;
}

std::vector<float> plane(const DeformFrame& frame, int k) {
  const size_t n = size_t(frame.width) * frame.height;
  return std::vector<float>(frame.planes.begin() + k * n, frame.planes.begin() + (k + 1) * n);
}

std::vector<uint8_t> free_mask(int w, int h, const std::vector<uint8_t>& chart) {
  auto inside = [&](int i, int j) { return chart.empty() || chart[size_t(i) + size_t(w) * j] != 0; };
  std::vector<uint8_t> out(size_t(w) * h, 0);
  for (int j = 1; j < h - 1; ++j)
    for (int i = 1; i < w - 1; ++i)
      out[size_t(i) + size_t(w) * j] =
          inside(i, j) && inside(i - 1, j) && inside(i + 1, j) && inside(i, j - 1) && inside(i, j + 1);
  return out;
}

namespace {

// D^T r on the free texels (x then y planes), the transpose of the dual-cell divergence of eq. 6.
std::vector<double> apply_dt(int w, int h, const std::vector<double>& r, const std::vector<uint8_t>& free) {
  std::vector<double> g(2 * size_t(w) * h, 0.0);
  auto cell = [&](int i, int j) { return r[size_t(i) + size_t(w - 1) * j]; };
  for (int j = 1; j < h - 1; ++j) {
    for (int i = 1; i < w - 1; ++i) {
      const size_t t = size_t(i) + size_t(w) * j;
      if (!free[t]) continue;
      const double a = cell(i - 1, j - 1), b = cell(i, j - 1), d = cell(i - 1, j), e = cell(i, j);
      g[t] = 0.5 * ((a + d) - (b + e));
      g[t + size_t(w) * h] = 0.5 * ((a + b) - (d + e));
    }
  }
  return g;
}

double norm(const std::vector<double>& x) {
  double s = 0;
  for (double v : x) s += v * v;
  return std::sqrt(s);
}

}  // namespace

double normal_residual(int w, int h, const std::vector<float>& rigidity, const std::vector<uint8_t>& chart,
                       const std::vector<float>& vx, const std::vector<float>& vy) {
  std::vector<double> b(size_t(w - 1) * (h - 1)), r(b.size());
  auto at = [&](const std::vector<float>& f, int i, int j) { return double(f[size_t(i) + size_t(w) * j]); };
  for (int j = 0; j < h - 1; ++j) {
    for (int i = 0; i < w - 1; ++i) {
      const size_t c = size_t(i) + size_t(w - 1) * j;
      b[c] = 0.25 * (at(rigidity, i, j) + at(rigidity, i + 1, j) + at(rigidity, i, j + 1) + at(rigidity, i + 1, j + 1));
      const double div = 0.5 * ((at(vx, i + 1, j) + at(vx, i + 1, j + 1)) - (at(vx, i, j) + at(vx, i, j + 1))) +
                         0.5 * ((at(vy, i, j + 1) + at(vy, i + 1, j + 1)) - (at(vy, i, j) + at(vy, i + 1, j)));
      r[c] = div - b[c];
    }
  }
  const std::vector<uint8_t> free = free_mask(w, h, chart);
  return norm(apply_dt(w, h, r, free)) / norm(apply_dt(w, h, b, free));
}

double mean_abs_difference(const std::vector<float>& a, const std::vector<float>& b) {
  double s = 0;
  for (size_t k = 0; k < a.size(); ++k) s += std::abs(double(a[k]) - double(b[k]));
  return s / double(a.size());
}

double psnr(const std::vector<float>& a, const std::vector<float>& b, double peak) {
  double s = 0;
  for (size_t k = 0; k < a.size(); ++k) s += (double(a[k]) - double(b[k])) * (double(a[k]) - double(b[k]));
  return 10 * std::log10(peak * peak / (s / double(a.size())));
}

}  // namespace squall::test
