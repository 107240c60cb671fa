// Boundary sampling of a Poisson-disk set (D. Dunbar, G. Humphreys, "A Spatial Data Structure for Fast
// Poisson-Disk Sample Generation", SIGGRAPH 2006) used to keep the particles of Q. Yu, F. Neyret,
// E. Bruneton, N. Holzschuch, "Lagrangian Texture Advection: Preserving both Spectrum and Velocity Field"
// (IEEE TVCG 2011), sec. 3.3.1, covering the fluid. Every point keeps the free arcs of its radius-d circle
// (sorted [lo, hi) angle intervals in [0, 2 pi)); a new point is drawn on them, at distance d from its parent,
// so it is at least d from every point and covers part of the boundary of the union of the disks.
#include "textures/poisson.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>

namespace squall::textures {

bool PoissonRegion::contains(Vec2 p) const {
  if (!(p.x >= x0 && p.x <= x1 && p.y >= y0 && p.y <= y1)) return false;
  return !inside || inside(p.x, p.y);
}

namespace {

constexpr double kTwoPi = 2 * std::numbers::pi;
// Circle samples for the part of a circle outside the region; a multiple of 4 so that the extreme points
// of the circle along the axes (where it first leaves a rectangle) are samples.
constexpr int kCircleSamples = 64;
constexpr double kSampleStep = kTwoPi / kCircleSamples;
// Bisection steps locating where a circle crosses the region's boundary (step / 2^32 ~ 2e-11 rad).
constexpr int kBisections = 32;
// Arcs shorter than this (radians) are rounding noise and dropped.
constexpr double kMinArc = 1e-12;
// Relative tolerance on distances: a lattice point within d (1 + kTolerance) of a point is covered.
constexpr double kTolerance = 1e-9;

double dist2(Vec2 a, Vec2 b) { return (a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y); }

Vec2 on_circle(Vec2 c, double r, double theta) { return {c.x + r * std::cos(theta), c.y + r * std::sin(theta)}; }

// ---- arc sets: sorted, disjoint [lo, hi) intervals of [0, 2 pi) ----

struct Arc {
  double lo, hi;
};
using ArcSet = std::vector<Arc>;

void drop_slivers(ArcSet& arcs) {
  std::erase_if(arcs, [](const Arc& a) { return a.hi - a.lo < kMinArc; });
}

// Removes [lo, hi), 0 <= lo <= hi <= 2 pi.
void subtract_plain(ArcSet& arcs, double lo, double hi) {
  for (size_t i = 0; i < arcs.size(); ++i) {
    Arc& a = arcs[i];
    if (a.hi <= lo || a.lo >= hi) continue;
    if (a.lo < lo && hi < a.hi) {  // strictly inside one arc: split it; no other arc can overlap
      Arc right{hi, a.hi};
      a.hi = lo;
      arcs.insert(arcs.begin() + std::ptrdiff_t(i) + 1, right);
      break;
    }
    if (a.lo < lo) {
      a.hi = lo;
    } else if (hi < a.hi) {
      a.lo = hi;
    } else {
      a.hi = a.lo;  // wholly removed
    }
  }
  drop_slivers(arcs);
}

// Removes the angles [lo, hi) taken modulo 2 pi (any lo, hi >= lo).
void subtract(ArcSet& arcs, double lo, double hi) {
  if (hi - lo >= kTwoPi) {
    arcs.clear();
    return;
  }
  double len = hi - lo;
  while (lo < 0) lo += kTwoPi;  // the callers' angles are within 2 pi of [0, 2 pi)
  while (lo >= kTwoPi) lo -= kTwoPi;
  hi = lo + len;
  if (hi <= kTwoPi) {
    subtract_plain(arcs, lo, hi);
  } else {
    subtract_plain(arcs, lo, kTwoPi);
    subtract_plain(arcs, 0, hi - kTwoPi);
  }
}

ArcSet intersect(const ArcSet& a, const ArcSet& b) {
  ArcSet out;
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    double lo = std::max(a[i].lo, b[j].lo), hi = std::min(a[i].hi, b[j].hi);
    if (hi - lo >= kMinArc) out.push_back({lo, hi});
    (a[i].hi < b[j].hi) ? ++i : ++j;
  }
  return out;
}

// The angle at fraction u in [0, 1) of the total length of the (non-empty) arcs.
double draw_angle(const ArcSet& arcs, double u) {
  double total = 0;
  for (const Arc& a : arcs) total += a.hi - a.lo;
  double t = u * total;
  for (const Arc& a : arcs) {
    double len = a.hi - a.lo;
    if (t < len) return std::min(a.lo + t, std::nextafter(a.hi, a.lo));
    t -= len;
  }
  return std::nextafter(arcs.back().hi, arcs.back().lo);  // u * total rounded up to the total
}

// ---- a uniform grid of point indices (singly linked per cell) over a rectangle; points outside it are
// kept in the border cells, which keeps neighbor queries exact ----

class PointGrid {
 public:
  PointGrid(double x0, double y0, double x1, double y1, double cell)
      : x0_(x0), y0_(y0), cell_(cell), nx_(count(x1 - x0, cell)), ny_(count(y1 - y0, cell)), head_(nx_ * ny_, -1) {}

  void insert(int index, Vec2 p) {
    if (size_t(index) >= next_.size()) next_.resize(size_t(index) + 1, -1);
    int& h = head_[size_t(cy(p.y) * nx_ + cx(p.x))];
    next_[size_t(index)] = h;
    h = index;
  }

  // Calls f(index) for the points in the cells within `reach` cells of p's, nearer rings of cells first,
  // until f returns false.
  template <class F>
  bool visit(Vec2 p, int reach, F&& f) const {
    int cx0 = cx(p.x), cy0 = cy(p.y);
    for (int ring = 0; ring <= reach; ++ring) {
      for (int y = std::max(0, cy0 - ring); y <= std::min(ny_ - 1, cy0 + ring); ++y) {
        bool edge_row = y == cy0 - ring || y == cy0 + ring;
        for (int x = std::max(0, cx0 - ring); x <= std::min(nx_ - 1, cx0 + ring); ++x) {
          if (!edge_row && x != cx0 - ring && x != cx0 + ring) continue;  // an inner ring's cell
          for (int i = head_[size_t(y * nx_ + x)]; i >= 0; i = next_[size_t(i)])
            if (!f(i)) return false;
        }
      }
    }
    return true;
  }

 private:
  static int count(double extent, double cell) { return int(std::floor(std::max(0.0, extent) / cell)) + 1; }
  static int clamp_cell(double c, int n) { return c >= 0 ? int(std::min(c, double(n - 1))) : 0; }
  int cx(double x) const { return clamp_cell(std::floor((x - x0_) / cell_), nx_); }
  int cy(double y) const { return clamp_cell(std::floor((y - y0_) / cell_), ny_); }

  double x0_, y0_, cell_;
  int nx_, ny_;
  std::vector<int> head_, next_;
};

// ---- the lattice of spacing <= d/4 over the rectangle (both edges included), scanned row-major ----

struct Lattice {
  Lattice(const PoissonRegion& r, double d)
      : x0(r.x0),
        y0(r.y0),
        x1(r.x1),
        y1(r.y1),
        nx(steps(x1 - x0, d / 4)),
        ny(steps(y1 - y0, d / 4)),
        sx(nx ? (x1 - x0) / nx : 0),
        sy(ny ? (y1 - y0) / ny : 0) {}

  static int steps(double extent, double spacing) { return int(std::ceil(extent / spacing)); }
  Vec2 at(int i, int j) const { return {i == nx ? x1 : x0 + sx * i, j == ny ? y1 : y0 + sy * j}; }

  // The first column after i (on row j) whose point is not within r of c; point i is within r of c.
  int past_chord(Vec2 c, double r, int i) const {
    double dy = at(i, j).y - c.y, half = std::sqrt(std::max(0.0, r * r - dy * dy));
    int k = sx > 0 ? int(std::floor((c.x + half - x0) / sx)) : nx;  // the last column within the chord
    k = std::min(k, nx);
    while (k > i && dist2(at(k, j), c) > r * r) --k;  // rounding of the chord's end
    return std::max(k, i) + 1;
  }

  double x0, y0, x1, y1;
  int nx, ny;  // nx + 1 by ny + 1 points
  double sx, sy;
  int i = 0, j = 0;  // the scan's position
};

class Filler {
 public:
  Filler(const std::vector<Vec2>& existing, const PoissonRegion& region, double d, const CounterRng& rng,
         uint64_t& counter)
      : region_(region),
        d_(d),
        rng_(rng),
        counter_(counter),
        existing_(existing.size()),
        points_(existing),
        // Cells slightly wider than d: neighbors within 2d are 2 cells away at most, points within
        // d (1 + kTolerance) 1 cell away.
        grid_(region.x0, region.y0, region.x1, region.y1, d * (1 + 1e-6)) {}

  std::vector<Vec2> run() {
    for (size_t i = 0; i < existing_; ++i) grid_.insert(int(i), points_[i]);
    for (size_t i = 0; i < existing_; ++i) arcs_.push_back(free_arcs(i));
    Lattice lattice(region_, d_);
    size_t cursor = 0;
    for (;;) {
      grow(cursor);
      Vec2 seed;
      if (!next_seed(lattice, seed)) break;
      add_point(seed);
    }
    return {points_.begin() + std::ptrdiff_t(existing_), points_.end()};
  }

 private:
  // Boundary sampling (Dunbar & Humphreys): the work list is the points from `cursor` on, in
  // order; each draws new points on its free arcs until it has none (arcs only shrink, so the points
  // before `cursor` never need another look).
  void grow(size_t& cursor) {
    for (; cursor < points_.size(); ++cursor) {
      while (!arcs_[cursor].empty()) {
        double theta = draw_angle(arcs_[cursor], rng_.uniform(counter_++));
        Vec2 q = on_circle(points_[cursor], d_, theta);
        if (region_.contains(q)) {
          add_point(q);
        } else {
          carve_outside(cursor, theta);
        }
      }
    }
  }

  void add_point(Vec2 q) {
    size_t index = points_.size();
    points_.push_back(q);
    grid_.insert(int(index), q);
    arcs_.push_back(free_arcs(index));
    grid_.visit(q, 2, [&](int j) {
      if (size_t(j) != index) remove_disk(arcs_[size_t(j)], points_[size_t(j)], q);
      return true;
    });
  }

  // Removes from the circle of p the arc inside the radius-d disk of o: centred on the direction of o,
  // half-width acos(D / 2d) for 0 < D = |o - p| < 2d.
  void remove_disk(ArcSet& arcs, Vec2 p, Vec2 o) const {
    if (arcs.empty()) return;
    double D2 = dist2(p, o);
    if (!(D2 > 0 && D2 < 4 * d_ * d_)) return;
    double D = std::sqrt(D2);
    if (!(D < 2 * d_)) return;
    double phi = std::atan2(o.y - p.y, o.x - p.x), half = std::acos(D / (2 * d_));
    subtract(arcs, phi - half, phi + half);
  }

  // The arcs of point i's circle covered by no other disk and inside the region.
  ArcSet free_arcs(size_t i) {
    Vec2 p = points_[i];
    ArcSet arcs;
    arcs.reserve(4);
    arcs.push_back({0, kTwoPi});
    grid_.visit(p, 2, [&](int j) {
      if (size_t(j) != i) remove_disk(arcs, p, points_[size_t(j)]);
      return !arcs.empty();
    });
    if (arcs.empty() || circle_in_rectangle(p)) return arcs;
    return intersect(arcs, inside_arcs(p));
  }

  bool circle_in_rectangle(Vec2 p) const {
    return !region_.inside && p.x - d_ >= region_.x0 && p.x + d_ <= region_.x1 && p.y - d_ >= region_.y0 &&
           p.y + d_ <= region_.y1;
  }

  bool inside_at(Vec2 p, double theta) const { return region_.contains(on_circle(p, d_, theta)); }

  // The unit vectors of the circle samples, k * kSampleStep for k = 0 .. kCircleSamples (the same values
  // as std::cos and std::sin of those angles, so a sample and a bisection agree).
  static const std::array<Vec2, kCircleSamples + 1>& sample_directions() {
    static const std::array<Vec2, kCircleSamples + 1> table = [] {
      std::array<Vec2, kCircleSamples + 1> t;
      for (int k = 0; k <= kCircleSamples; ++k) t[size_t(k)] = on_circle({0, 0}, 1, k * kSampleStep);
      return t;
    }();
    return table;
  }

  // Bisection between an angle whose circle point is in the region and one whose point is not; returns
  // the last angle found in the region.
  double crossing(Vec2 p, double in, double out) const {
    for (int k = 0; k < kBisections; ++k) {
      double mid = 0.5 * (in + out);
      (inside_at(p, mid) ? in : out) = mid;
    }
    return in;
  }

  // The part of p's circle in the region: the circle is sampled at kCircleSamples angles, and a sample
  // interval with one end out has its crossing located by bisection. A part that leaves the region between
  // two samples in it is found when a point is drawn there (carve_outside).
  ArcSet inside_arcs(Vec2 p) const {
    std::array<bool, kCircleSamples + 1> in;
    const auto& dirs = sample_directions();
    for (size_t k = 0; k <= kCircleSamples; ++k) in[k] = region_.contains({p.x + d_ * dirs[k].x, p.y + d_ * dirs[k].y});
    ArcSet arcs;
    for (int k = 0; k < kCircleSamples; ++k) {
      double a = k * kSampleStep, b = (k + 1) * kSampleStep;
      bool in_a = in[size_t(k)], in_b = in[size_t(k) + 1];
      if (!in_a && !in_b) continue;
      double lo = in_a ? a : crossing(p, b, a), hi = in_b ? b : crossing(p, a, b);
      if (!arcs.empty() && arcs.back().hi == lo) {
        arcs.back().hi = hi;
      } else {
        arcs.push_back({lo, hi});
      }
    }
    drop_slivers(arcs);
    return arcs;
  }

  // theta, on a free arc of point i, gives a point outside the region: the circle leaves the region between
  // two samples in it. Removes the excursion, bounded by bisection towards the neighboring samples.
  void carve_outside(size_t i, double theta) {
    Vec2 p = points_[i];
    double a = std::clamp(std::floor(theta / kSampleStep), 0.0, kCircleSamples - 1.0) * kSampleStep;
    double b = a + kSampleStep;
    double lo = inside_at(p, a) ? crossing(p, a, theta) : a;
    double hi = inside_at(p, b) ? crossing(p, b, theta) : b;
    subtract(arcs_[i], std::min(lo, theta), std::max(hi, std::nextafter(theta, kTwoPi)));
  }

  // A point within d of v (up to rounding), or -1.
  int cover(Vec2 v) const {
    double r2 = d_ * d_ * (1 + kTolerance) * (1 + kTolerance);
    int found = -1;
    grid_.visit(v, 1, [&](int j) {
      if (!(dist2(points_[size_t(j)], v) <= r2)) return true;
      found = j;
      return false;
    });
    return found;
  }

  // The first lattice point from the scan's position on that lies in the region and is farther than d from
  // every point: the seed of a region the arcs did not reach. Earlier lattice points stay covered (points are
  // only added), so resuming the scan finds the same point as a scan from the start. The lattice points of a
  // row inside the disk of the point covering one of them are skipped at once.
  bool next_seed(Lattice& lattice, Vec2& seed) const {
    for (; lattice.j <= lattice.ny; ++lattice.j, lattice.i = 0) {
      while (lattice.i <= lattice.nx) {
        Vec2 v = lattice.at(lattice.i, lattice.j);
        int c = cover(v);
        if (c < 0) {
          if (region_.contains(v)) {
            seed = v;
            return true;
          }
          ++lattice.i;
          continue;
        }
        lattice.i = lattice.past_chord(points_[size_t(c)], d_, lattice.i);
      }
    }
    return false;
  }

  const PoissonRegion& region_;
  double d_;
  const CounterRng& rng_;
  uint64_t& counter_;
  size_t existing_;
  std::vector<Vec2> points_;
  std::vector<ArcSet> arcs_;
  PointGrid grid_;
};

}  // namespace

std::vector<Vec2> poisson_fill(const std::vector<Vec2>& existing, const PoissonRegion& region, double d,
                               const CounterRng& rng, uint64_t& counter) {
  bool finite = std::isfinite(d) && std::isfinite(region.x0) && std::isfinite(region.y0) && std::isfinite(region.x1) &&
                std::isfinite(region.y1);
  if (!finite || !(d > 0) || !(region.x1 >= region.x0) || !(region.y1 >= region.y0)) return {};
  return Filler(existing, region, d, rng, counter).run();
}

std::vector<size_t> poisson_cull(const std::vector<Vec2>& points, double min_distance) {
  std::vector<size_t> culled;
  if (points.empty() || !(min_distance > 0)) return culled;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  double x0 = kInf, y0 = kInf, x1 = -kInf, y1 = -kInf;
  for (const Vec2& p : points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;  // never closer than anything: kept
    x0 = std::min(x0, p.x), x1 = std::max(x1, p.x);
    y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
  }
  if (x0 > x1) x0 = x1 = y0 = y1 = 0;
  // Cells of at least min_distance (neighbors are then one cell away), widened when the points are spread
  // thin so that the grid holds O(n) cells.
  double n = double(points.size()), w = x1 - x0, h = y1 - y0;
  double cell = std::max({min_distance, std::sqrt(w * h / n), std::max(w, h) / n});
  PointGrid grid(x0, y0, x1, y1, cell);
  double r2 = min_distance * min_distance;
  for (size_t i = 0; i < points.size(); ++i) {
    Vec2 p = points[i];
    bool clear = grid.visit(p, 1, [&](int j) { return !(dist2(points[size_t(j)], p) < r2); });
    if (clear) {
      grid.insert(int(i), p);
    } else {
      culled.push_back(i);
    }
  }
  return culled;
}

}  // namespace squall::textures
