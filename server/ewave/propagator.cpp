#include "ewave/propagator.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace squall::ewave {

Dispersion dispersion_of(const EWaveConfig& c) {
  Dispersion d;
  d.kind = int(c.dispersion);
  d.gravity = float(c.gravity);
  d.depth = float(c.depth);
  d.capillary_length = float(c.capillary_length);
  return d;
}

double wavenumber(const EWaveConfig& c, size_t i, size_t j) {
  double jj = j <= size_t(c.ny) / 2 ? double(j) : double(j) - double(c.ny);
  double kx = 2 * std::numbers::pi * double(i) / c.length_x();
  double ky = 2 * std::numbers::pi * jj / c.length_y();
  return std::hypot(kx, ky);
}

std::vector<double> propagator_coefficients(const EWaveConfig& c, double dt) {
  const size_t hx = size_t(c.nx) / 2 + 1, ny = size_t(c.ny);
  const double scale = 1.0 / (double(c.nx) * double(c.ny)), g = c.gravity;
  const Dispersion d = dispersion_of(c);
  std::vector<double> out(4 * hx * ny);
  for (size_t j = 0; j < ny; ++j)
    for (size_t i = 0; i < hx; ++i) {
      const float k = float(wavenumber(c, i, j));
      double omega = dispersion_omega(k, d), G = dispersion_restoring(k, d);
      double s = std::sin(omega * dt);
      double* m = &out[4 * (i + hx * j)];
      m[0] = std::cos(omega * dt) * scale;                  // eq 64-65: cos
      m[1] = omega / G * s * scale;                         // phi -> h: (k tanh(kh) / omega) sin
      m[2] = (omega > 0 ? G * s / omega : g * dt) * scale;  // h -> phi, k = 0 limit g dt
      m[3] = 0;
    }
  return out;
}

double shortest_wave_period(const EWaveConfig& c) {
  const double k = std::hypot(std::numbers::pi / c.dx, std::numbers::pi / c.dy);
  return 2 * std::numbers::pi / dispersion_omega(float(k), dispersion_of(c));
}

std::vector<float> trim_profile(size_t n, double d, double width, double alpha) {
  std::vector<float> t(n, 1.0f);
  const double length = double(n) * d;
  for (size_t i = 0; i < n; ++i) {
    double x = (double(i) + 0.5) * d;
    if (x / width < 1)
      t[i] = float(std::pow(x / width, alpha));  // eq 82
    else if ((length - x) / width < 1)
      t[i] = float(std::pow((length - x) / width, alpha));
  }
  return t;
}

namespace {

void bounds(const Shape& s, EWaveShape* out) {
  double c = std::cos(s.heading), sn = std::sin(s.heading), ex = s.a, ey = s.a;
  if (s.kind == ShapeKind::Ellipse) {
    ex = std::sqrt(s.a * s.a * c * c + s.b * s.b * sn * sn);
    ey = std::sqrt(s.a * s.a * sn * sn + s.b * s.b * c * c);
  } else if (s.kind == ShapeKind::Box) {
    ex = s.a * std::abs(c) + s.b * std::abs(sn);
    ey = s.a * std::abs(sn) + s.b * std::abs(c);
  }
  out->xmin = float(s.x - ex);
  out->xmax = float(s.x + ex);
  out->ymin = float(s.y - ey);
  out->ymax = float(s.y + ey);
}

}  // namespace

std::vector<EWaveShape> device_shapes(const std::vector<Shape>& shapes, std::vector<float>* vertices) {
  std::vector<EWaveShape> out;
  for (const Shape& s : shapes) {
    EWaveShape e{};
    e.kind = int(s.kind);  // ShapeKind follows SQUALL_EWAVE_SHAPE_*
    e.cx = float(s.x);
    e.cy = float(s.y);
    e.a = float(s.a);
    e.b = float(s.kind == ShapeKind::Circle ? s.a : s.b);
    e.cos_h = float(std::cos(s.heading));
    e.sin_h = float(std::sin(s.heading));
    if (s.kind == ShapeKind::Polygon) {
      e.first_vertex = int(vertices->size() / 2);
      e.vertex_count = int(s.vertices.size());
      e.xmin = e.ymin = INFINITY;
      e.xmax = e.ymax = -INFINITY;
      for (const auto& v : s.vertices) {
        vertices->push_back(float(v[0]));
        vertices->push_back(float(v[1]));
        e.xmin = std::min(e.xmin, float(v[0]));
        e.xmax = std::max(e.xmax, float(v[0]));
        e.ymin = std::min(e.ymin, float(v[1]));
        e.ymax = std::max(e.ymax, float(v[1]));
      }
    } else {
      bounds(s, &e);
    }
    out.push_back(e);
  }
  return out;
}

}  // namespace squall::ewave
