#include "common/surface_current.h"

#include <cstddef>

namespace squall {

void periodic_gradient(const std::vector<float>& phi, SurfaceCurrent& c) {
  const int64_t nx = c.nx, ny = c.ny;
  auto at = [&](int64_t i, int64_t j) { return double(phi[size_t(((j + ny) % ny) * nx + (i + nx) % nx)]); };
  c.u.assign(size_t(nx * ny), 0.0f);
  c.v.assign(size_t(nx * ny), 0.0f);
  for (int64_t j = 0; j < ny; ++j) {
    for (int64_t i = 0; i < nx; ++i) {
      c.u[size_t(j * nx + i)] = float((at(i + 1, j) - at(i - 1, j)) / (2 * c.dx));
      c.v[size_t(j * nx + i)] = float((at(i, j + 1) - at(i, j - 1)) / (2 * c.dy));
    }
  }
}

}  // namespace squall
