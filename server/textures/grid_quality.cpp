#include "textures/grid_quality.h"

#include <algorithm>
#include <cmath>

namespace squall::textures {
namespace {

// The rest edges of the two triangles of a quad, in units of the spacing: lower (00, 10, 11) has
// E = [(1, 0), (1, 1)], upper (00, 11, 01) has E = [(1, 1), (0, 1)] (columns). Their inverses:
constexpr double kLowerInverse[4] = {1, -1, 0, 1};  // row-major [[1, -1], [0, 1]]
constexpr double kUpperInverse[4] = {1, 0, -1, 1};  // row-major [[1, 0], [-1, 1]]

struct Triangle {
  int v[3];                    // vertex indices a + G b
  const double* rest_inverse;  // E^-1 in units of 1 / spacing
};

std::vector<Triangle> triangles(int res) {
  std::vector<Triangle> out;
  for (int b = 0; b + 1 < res; ++b) {
    for (int a = 0; a + 1 < res; ++a) {
      int v00 = a + res * b, v10 = v00 + 1, v01 = v00 + res, v11 = v01 + 1;
      out.push_back({{v00, v10, v11}, kLowerInverse});
      out.push_back({{v00, v11, v01}, kUpperInverse});
    }
  }
  return out;
}

double segment_distance(Vec2 p, Vec2 a, Vec2 b) {
  double ex = b.x - a.x, ey = b.y - a.y, len2 = ex * ex + ey * ey;
  double s = len2 > 0 ? std::clamp(((p.x - a.x) * ex + (p.y - a.y) * ey) / len2, 0.0, 1.0) : 0.0;
  return std::hypot(p.x - a.x - s * ex, p.y - a.y - s * ey);
}

// The grid's outline, counter-clockwise at rest: bottom row, right column, top row, left column.
std::vector<Vec2> outline(const GridView& grid) {
  std::vector<Vec2> loop;
  int last = grid.res - 1;
  for (int a = 0; a < last; ++a) loop.push_back(grid.vertex(a, 0));
  for (int b = 0; b < last; ++b) loop.push_back(grid.vertex(last, b));
  for (int a = last; a > 0; --a) loop.push_back(grid.vertex(a, last));
  for (int b = last; b > 0; --b) loop.push_back(grid.vertex(0, b));
  return loop;
}

}  // namespace

void singular_values(double a, double b, double c, double d, double& largest, double& smallest) {
  double e = (a + d) / 2, f = (a - d) / 2, g = (c + b) / 2, h = (c - b) / 2;
  double q = std::hypot(e, h), r = std::hypot(f, g);
  largest = q + r;
  smallest = std::abs(q - r);
}

GridQuality grid_quality(const GridView& grid, double delta_max, const std::vector<uint8_t>& outside) {
  const int n = grid.res * grid.res;
  std::vector<double> sum(n, 0.0);
  std::vector<int> count(n, 0);
  GridQuality q;
  for (const Triangle& t : triangles(grid.res)) {
    if (outside[t.v[0]] || outside[t.v[1]] || outside[t.v[2]]) continue;
    auto at = [&](int k) { return Vec2{grid.xy[2 * t.v[k]], grid.xy[2 * t.v[k] + 1]}; };
    Vec2 p0 = at(0), p1 = at(1), p2 = at(2);
    // J = E' E^-1 (E' the current edges as columns), in units where the rest spacing is 1.
    double e00 = (p1.x - p0.x) / grid.spacing, e01 = (p2.x - p0.x) / grid.spacing;
    double e10 = (p1.y - p0.y) / grid.spacing, e11 = (p2.y - p0.y) / grid.spacing;
    const double* m = t.rest_inverse;
    double j00 = e00 * m[0] + e01 * m[2], j01 = e00 * m[1] + e01 * m[3];
    double j10 = e10 * m[0] + e11 * m[2], j11 = e10 * m[1] + e11 * m[3];
    if (j00 * j11 - j01 * j10 <= 0) q.folded = true;
    double largest, smallest;
    singular_values(j00, j01, j10, j11, largest, smallest);
    double delta = std::max(largest, smallest > 0 ? 1 / smallest : INFINITY);  // eq. 1
    double quality = std::max((delta_max - delta) / (delta_max - 1), 0.0);     // eq. 2
    q.max_distortion = std::max(q.max_distortion, delta);
    for (int v : t.v) {
      sum[v] += quality;
      ++count[v];
    }
  }
  q.vertex_quality.assign(n, 1.0f);
  for (int v = 0; v < n; ++v) {
    if (count[v] == 0) continue;
    q.vertex_quality[v] = float(sum[v] / count[v]);
    q.min_quality = std::min(q.min_quality, double(q.vertex_quality[v]));
  }
  return q;
}

bool covers_kernel(const GridView& grid, Vec2 p, double d) {
  std::vector<Vec2> loop = outline(grid);
  bool inside = false;
  for (size_t i = 0, j = loop.size() - 1; i < loop.size(); j = i++) {
    Vec2 a = loop[i], b = loop[j];
    if ((a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x) inside = !inside;
    if (segment_distance(p, a, b) < d) return false;
  }
  return inside;
}

void vertex_weights(const GridView& grid, Vec2 p, double d, double temporal, const std::vector<float>& quality,
                    const std::vector<uint8_t>& outside, float* weights) {
  const int last = grid.res - 1;
  for (int b = 0; b < grid.res; ++b) {
    for (int a = 0; a < grid.res; ++a) {
      int v = a + grid.res * b;
      bool border = a == 0 || b == 0 || a == last || b == last;  // eq. 8
      Vec2 x = grid.vertex(a, b);
      double spatial = std::max(0.0, 1 - std::hypot(x.x - p.x, x.y - p.y) / d) * quality[v];  // eq. 7
      weights[v] = border || outside[v] ? 0.0f : float(spatial * temporal);                   // eq. 5
    }
  }
}

double temporal_weight(double age, double since_kill, double tau) {
  const double killed_at = since_kill >= 0 ? age - since_kill : age;
  const double faded_in = std::min(1.0, killed_at / tau);  // fade-in, then 1
  if (since_kill < 0) return faded_in;
  // Fade-out from the weight reached when killed, so that a particle killed while fading in does not jump
  // to 1 (Yu, Neyret, Bruneton and Holzschuch, "Scalable real-time animation of rivers", eq. 7).
  return faded_in * std::max(0.0, 1 - since_kill / tau);
}

}  // namespace squall::textures
