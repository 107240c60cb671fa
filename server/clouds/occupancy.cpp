#include "clouds/occupancy.h"

#include <algorithm>
#include <cmath>

namespace squall::clouds {

CoarseOccupancy CoarseOccupancy::of(const Vec3d& lo, const Vec3d& hi, const std::vector<std::array<double, 6>>& boxes) {
  CoarseOccupancy o;
  o.min = lo;
  const double longest = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  o.cell = longest > 0 ? longest / kCells : 1;
  for (int a = 0; a < 3; ++a) o.n[a] = std::clamp(int(std::ceil((hi[a] - lo[a]) / o.cell)), 1, kCells);
  o.marked.assign(size_t(o.n[0]) * o.n[1] * o.n[2], 0);
  for (const auto& b : boxes) {
    int first[3], last[3];
    for (int a = 0; a < 3; ++a) {
      first[a] = std::clamp(int(std::floor((b[a] - lo[a]) / o.cell)), 0, o.n[a] - 1);
      last[a] = std::clamp(int(std::floor((b[a + 3] - lo[a]) / o.cell)), 0, o.n[a] - 1);
    }
    for (int k = first[2]; k <= last[2]; ++k)
      for (int j = first[1]; j <= last[1]; ++j)
        for (int i = first[0]; i <= last[0]; ++i) o.marked[(size_t(k) * o.n[1] + j) * o.n[0] + i] = 1;
  }
  return o;
}

double CoarseOccupancy::marked_length(const Vec3d& origin, const Vec3d& direction) const {
  double t0 = 0, t1 = INFINITY;  // the ray's span inside the grid (slab test)
  for (int a = 0; a < 3; ++a) {
    const double lo = min[a], hi = min[a] + n[a] * cell;
    if (direction[a] == 0) {
      if (origin[a] < lo || origin[a] > hi) return 0;
      continue;
    }
    double enter = (lo - origin[a]) / direction[a], exit = (hi - origin[a]) / direction[a];
    if (enter > exit) std::swap(enter, exit);
    t0 = std::max(t0, enter);
    t1 = std::min(t1, exit);
  }
  if (!(t1 > t0) || !std::isfinite(t1)) return 0;
  // Steps counted from the entry point, not accumulated onto t: far from the grid (a camera 1e18 m
  // away) t0 + step would round back to t0. The span is at most the grid's diagonal, a few kCells cells.
  const double step = cell / 2;
  const int steps = int(std::min(std::ceil((t1 - t0) / step), 8.0 * kCells));
  Vec3d entry;
  for (int a = 0; a < 3; ++a) entry[a] = origin[a] + t0 * direction[a] - min[a];
  double length = 0;
  for (int k = 0; k < steps; ++k) {
    const double s = (k + 0.5) * step;
    int c[3];
    for (int a = 0; a < 3; ++a) c[a] = std::clamp(int(std::floor((entry[a] + s * direction[a]) / cell)), 0, n[a] - 1);
    if (marked[(size_t(c[2]) * n[1] + c[1]) * n[0] + c[0]]) length += step;
  }
  return length;
}

}  // namespace squall::clouds
