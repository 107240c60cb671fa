#include "textures/bake_costs.h"

#include <algorithm>
#include <cmath>

namespace squall::textures {
namespace {

// The cells [lo, hi] of width `size` from `origin` (n of them) that meet [a, b]; false when none do.
bool cells_meeting(double a, double b, double origin, double size, long n, long& lo, long& hi) {
  const double first = std::floor((a - origin) / size), last = std::floor((b - origin) / size);
  if (!(last >= 0 && first < double(n))) return false;  // none, or no number (a size that underflowed)
  lo = long(std::max(first, 0.0));
  hi = long(std::min(last, double(n - 1)));
  return true;
}

// Sums over rectangles of an nx x ny grid in O(1): the summed-area table of its values (row order).
class AreaSums {
 public:
  AreaSums(long nx, long ny, const std::vector<double>& values) : nx_(nx), sums_(size_t((nx + 1) * (ny + 1)), 0) {
    for (long j = 0; j < ny; ++j)
      for (long i = 0; i < nx; ++i)
        at(i + 1, j + 1) = values[size_t(j * nx + i)] + at(i, j + 1) + at(i + 1, j) - at(i, j);
  }
  double sum(long i0, long j0, long i1, long j1) const {  // cells [i0, i1] x [j0, j1]
    return at(i1 + 1, j1 + 1) - at(i0, j1 + 1) - at(i1 + 1, j0) + at(i0, j0);
  }

 private:
  double& at(long i, long j) { return sums_[size_t(j * (nx_ + 1) + i)]; }
  double at(long i, long j) const { return sums_[size_t(j * (nx_ + 1) + i)]; }
  long nx_;
  std::vector<double> sums_;
};

}  // namespace

std::vector<double> bake_tile_costs(const RiverGeometry& geo, const std::vector<cl_int>& bin_start,
                                    const std::vector<PolygonBox>& polygons, const BakeGrid& grid,
                                    const TileGrid& tiles) {
  const long tx = long(tiles.x), ty = long(tiles.y), bx = geo.bins_x, by = geo.bins_y;
  std::vector<double> bins(size_t(bx * by));
  for (size_t b = 0; b < bins.size(); ++b) bins[b] = bin_start[b + 1] - bin_start[b];
  const AreaSums segments(bx, by, bins);
  // Tile i covers x in [x0 + (8 i - 1/2) hx, x0 + (8 i + 15/2) hx): its nodes with half a spacing about each.
  const double hx = (grid.x1 - grid.x0) / (grid.nx - 1), hy = (grid.y1 - grid.y0) / (grid.ny - 1);
  const double ox = grid.x0 - 0.5 * hx, oy = grid.y0 - 0.5 * hy, wx = 8 * hx, wy = 8 * hy;
  std::vector<double> points(size_t(tx * ty));  // polygon points per node, by tile
  for (const PolygonBox& p : polygons) {
    long i0, i1, j0, j1;
    if (!cells_meeting(p.x0, p.x1, ox, wx, tx, i0, i1) || !cells_meeting(p.y0, p.y1, oy, wy, ty, j0, j1)) continue;
    for (long j = j0; j <= j1; ++j)
      for (long i = i0; i <= i1; ++i) points[size_t(j * tx + i)] += p.points;
  }
  std::vector<double> costs(size_t(tx * ty));
  const double s = geo.s_max;
  for (long j = 0; j < ty; ++j) {
    for (long i = 0; i < tx; ++i) {
      long b0, b1, c0, c1;
      const bool near = cells_meeting(ox + i * wx - s, ox + (i + 1) * wx + s, geo.bin_x0, geo.bin_size, bx, b0, b1) &&
                        cells_meeting(oy + j * wy - s, oy + (j + 1) * wy + s, geo.bin_y0, geo.bin_size, by, c0, c1);
      const size_t t = size_t(j * tx + i);
      costs[t] = 1 + points[t] + (near ? segments.sum(b0, c0, b1, c1) : 0);
    }
  }
  return costs;
}

std::vector<double> point_costs(const RiverGeometry& geo, const std::vector<cl_int>& bin_start,
                                const std::vector<PolygonBox>& polygons, const std::vector<Point2>& points) {
  const double s = geo.s_max;
  std::vector<double> costs;
  for (const Point2& p : points) {
    double cost = 1;
    long b0, b1, c0, c1;
    if (cells_meeting(p.x - s, p.x + s, geo.bin_x0, geo.bin_size, geo.bins_x, b0, b1) &&
        cells_meeting(p.y - s, p.y + s, geo.bin_y0, geo.bin_size, geo.bins_y, c0, c1))
      for (long c = c0; c <= c1; ++c)
        cost += bin_start[size_t(c * geo.bins_x + b1 + 1)] - bin_start[size_t(c * geo.bins_x + b0)];
    for (const PolygonBox& box : polygons)
      if (p.x >= box.x0 && p.x <= box.x1 && p.y >= box.y0 && p.y <= box.y1) cost += box.points;
    costs.push_back(cost);
  }
  return costs;
}

}  // namespace squall::textures
