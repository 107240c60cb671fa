// Poisson-disk maintenance of the particles (Yu, Neyret, Bruneton, Holzschuch, "Lagrangian Texture
// Advection", TVCG 2011, sec. 3.3.1): the filled sets are checked by brute force against the two properties
// the advection relies on (no two points closer than d, no point of the region farther than d from a point),
// and against the density of maximal Poisson-disk sets.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <vector>

#include "textures/poisson.h"

namespace squall::textures {
namespace {

constexpr double kD = 0.05;
constexpr double kTol = 1e-9;

double distance(Vec2 a, Vec2 b) { return std::hypot(a.x - b.x, a.y - b.y); }

double min_pair_distance(const std::vector<Vec2>& pts) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < pts.size(); ++i)
    for (size_t j = i + 1; j < pts.size(); ++j) best = std::min(best, distance(pts[i], pts[j]));
  return best;
}

// The smallest distance from a point of `b` to a point of `a`.
double min_cross_distance(const std::vector<Vec2>& a, const std::vector<Vec2>& b) {
  double best = std::numeric_limits<double>::infinity();
  for (Vec2 p : a)
    for (Vec2 q : b) best = std::min(best, distance(p, q));
  return best;
}

// The largest distance from a point of a lattice of spacing d/10 over the region to the nearest point, and
// the number of lattice points in the region.
struct Coverage {
  double worst = 0;
  int lattice_points = 0;
};

Coverage coverage(const std::vector<Vec2>& pts, const PoissonRegion& region, double d) {
  Coverage c;
  int nx = int(std::ceil((region.x1 - region.x0) / (d / 10))), ny = int(std::ceil((region.y1 - region.y0) / (d / 10)));
  for (int j = 0; j <= ny; ++j) {
    for (int i = 0; i <= nx; ++i) {
      Vec2 v{region.x0 + (region.x1 - region.x0) * i / nx, region.y0 + (region.y1 - region.y0) * j / ny};
      if (!region.contains(v)) continue;
      ++c.lattice_points;
      double nearest = std::numeric_limits<double>::infinity();
      for (Vec2 p : pts) nearest = std::min(nearest, distance(p, v));
      c.worst = std::max(c.worst, nearest);
    }
  }
  return c;
}

std::vector<Vec2> concat(std::vector<Vec2> a, const std::vector<Vec2>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

std::vector<Vec2> fill(const std::vector<Vec2>& existing, const PoissonRegion& region, uint64_t seed, uint64_t& counter,
                       double d = kD) {
  return poisson_fill(existing, region, d, CounterRng(seed, RngPurpose::PoissonAngle), counter);
}

std::vector<Vec2> fill_empty(const PoissonRegion& region, uint64_t seed) {
  uint64_t counter = 0;
  return fill({}, region, seed, counter);
}

TEST(PoissonRegion, ContainsIsInclusiveAndAppliesTheFluidTest) {
  PoissonRegion r{0, 0, 2, 1, {}};
  EXPECT_TRUE(r.contains({0, 0}));
  EXPECT_TRUE(r.contains({2, 1}));
  EXPECT_TRUE(r.contains({1, 0.5}));
  EXPECT_FALSE(r.contains({-1e-12, 0.5}));
  EXPECT_FALSE(r.contains({1, 1 + 1e-12}));
  r.inside = [](double x, double) { return x < 1; };
  EXPECT_TRUE(r.contains({0.5, 0.5}));
  EXPECT_FALSE(r.contains({1.5, 0.5}));
  EXPECT_FALSE(r.contains({3, 0.5}));  // the rectangle still applies
}

// Maximal Poisson-disk sets made by dart throwing (random sequential adsorption) hold about 0.68 / d^2 points
// per unit area (jamming at a packing fraction of 0.547). Boundary sampling, which puts every new point at
// exactly d from its parent and grows the set from the oldest point's free arcs, packs tighter: about
// 0.885 / d^2 away from the edges (0.862 to 0.901 over 200 seeds at d = 0.02 in [0.2, 0.8]^2; 0.88 to 0.89 at
// d = 0.01 and 0.005; choosing the parent at random instead of the oldest gives 0.835). Points along the
// edges of the region add to it: 0.890 to 0.956 over the whole square or a 2 x 1 rectangle for d = 0.02 to 0.07.
constexpr double kInteriorDensityMin = 0.84, kInteriorDensityMax = 0.93;
constexpr double kDensityMin = 0.85, kDensityMax = 1.0;  // with the edges, for regions 14 d or more across

TEST(PoissonFill, EmptyStartCoversTheSquareAsAMaximalSet) {
  PoissonRegion square;
  uint64_t counter = 0;
  std::vector<Vec2> pts = fill({}, square, 7, counter);
  ASSERT_FALSE(pts.empty());
  // One seed (the first lattice point: no draw), then one draw per point: on a rectangle no draw misses.
  EXPECT_EQ(counter, pts.size() - 1);
  EXPECT_GE(min_pair_distance(pts), kD * (1 - kTol));
  Coverage c = coverage(pts, square, kD);
  EXPECT_EQ(c.lattice_points, 201 * 201);
  EXPECT_LE(c.worst, kD * (1 + kTol));
  EXPECT_GT(c.worst, 0.8 * kD);  // maximal, not denser than needed
  for (Vec2 p : pts) EXPECT_TRUE(square.contains(p)) << p.x << " " << p.y;
  double density = pts.size() * kD * kD;
  std::printf("%zu points, %.4f / d^2 per unit area\n", pts.size(), density);
  EXPECT_GT(density, kDensityMin);
  EXPECT_LT(density, kDensityMax);
}

TEST(PoissonFill, DensityAwayFromTheEdges) {
  PoissonRegion square;
  double d = 0.02;
  for (uint64_t seed : {1u, 2u}) {
    uint64_t counter = 0;
    std::vector<Vec2> pts = fill({}, square, seed, counter, d);
    auto interior = std::count_if(pts.begin(), pts.end(),
                                  [](Vec2 p) { return p.x >= 0.2 && p.x < 0.8 && p.y >= 0.2 && p.y < 0.8; });
    double density = interior * d * d / 0.36;
    EXPECT_GT(density, kInteriorDensityMin) << seed;
    EXPECT_LT(density, kInteriorDensityMax) << seed;
  }
}

TEST(PoissonFill, DensityOverSeveralSeedsAndSpacings) {
  PoissonRegion r{0, 0, 2, 1, {}};
  for (double d : {0.04, 0.07}) {
    for (uint64_t seed : {1u, 2u, 3u}) {
      uint64_t counter = 0;
      std::vector<Vec2> pts = fill({}, r, seed, counter, d);
      double density = pts.size() * d * d / 2;
      EXPECT_GT(density, kDensityMin) << d << " " << seed;
      EXPECT_LT(density, kDensityMax) << d << " " << seed;
      EXPECT_GE(min_pair_distance(pts), d * (1 - kTol));
    }
  }
}

TEST(PoissonFill, DeterministicForAGivenSeed) {
  PoissonRegion square;
  uint64_t c1 = 100, c2 = 100, c3 = 100;
  std::vector<Vec2> a = fill({}, square, 11, c1), b = fill({}, square, 11, c2), other = fill({}, square, 12, c3);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(std::bit_cast<uint64_t>(a[i].x), std::bit_cast<uint64_t>(b[i].x));
    EXPECT_EQ(std::bit_cast<uint64_t>(a[i].y), std::bit_cast<uint64_t>(b[i].y));
  }
  EXPECT_EQ(c1, c2);
  EXPECT_GT(c1, 100u);
  bool differs = a.size() != other.size();
  for (size_t i = 0; !differs && i < a.size(); ++i) differs = a[i].x != other[i].x || a[i].y != other[i].y;
  EXPECT_TRUE(differs);
  // The first seed is the first lattice point (no draw); the next point lies on its circle.
  EXPECT_EQ(a[0].x, 0);
  EXPECT_EQ(a[0].y, 0);
  EXPECT_NEAR(distance(a[0], a[1]), kD, 1e-15);
}

TEST(PoissonFill, ACounterOffsetGivesAnotherSet) {
  PoissonRegion square;
  uint64_t c1 = 0, c2 = 1;
  std::vector<Vec2> a = fill({}, square, 11, c1), b = fill({}, square, 11, c2);
  EXPECT_TRUE(a.size() != b.size() || a[1].x != b[1].x || a[1].y != b[1].y);
}

// Shift every point (dropping those that leave the square), cull, refill: the union keeps the invariants.
void check_refill(const std::vector<Vec2>& moved_in, const PoissonRegion& region, size_t expect_culled_at_least) {
  std::vector<Vec2> moved;
  for (Vec2 p : moved_in)
    if (region.contains(p)) moved.push_back(p);
  std::vector<size_t> culled = poisson_cull(moved, 0.75 * kD);
  EXPECT_GE(culled.size(), expect_culled_at_least);
  std::vector<Vec2> kept;
  for (size_t i = 0, c = 0; i < moved.size(); ++i) {
    if (c < culled.size() && culled[c] == i) {
      ++c;
    } else {
      kept.push_back(moved[i]);
    }
  }
  EXPECT_GE(min_pair_distance(kept), 0.75 * kD);
  uint64_t counter = 5000;
  std::vector<Vec2> added = fill(kept, region, 3, counter);
  EXPECT_FALSE(added.empty());
  std::vector<Vec2> all = concat(kept, added);
  EXPECT_GE(min_pair_distance(all), 0.75 * kD * (1 - kTol));
  EXPECT_GE(min_pair_distance(added), kD * (1 - kTol));
  EXPECT_GE(min_cross_distance(kept, added), kD * (1 - kTol));
  for (Vec2 p : added) EXPECT_TRUE(region.contains(p));
  EXPECT_LE(coverage(all, region, kD).worst, kD * (1 + kTol));
}

TEST(PoissonFill, RefillAfterATranslation) {
  PoissonRegion square;
  std::vector<Vec2> pts = fill_empty(square, 21);
  for (Vec2& p : pts) p.x += 0.3 * kD;
  check_refill(pts, square, 0);  // a translation brings no two points closer
}

TEST(PoissonFill, RefillAfterACompression) {
  PoissonRegion square;
  std::vector<Vec2> pts = fill_empty(square, 22);
  for (Vec2& p : pts) p.x *= 0.6;  // distances shrink to 0.6 d along x: some pairs are culled
  check_refill(pts, square, 1);
}

TEST(PoissonFill, AnnulusRegion) {
  PoissonRegion annulus{0, 0, 1, 1, [](double x, double y) {
                          double r = std::hypot(x - 0.5, y - 0.5);
                          return r > 0.15 && r < 0.45;
                        }};
  std::vector<Vec2> pts = fill_empty(annulus, 31);
  ASSERT_FALSE(pts.empty());
  for (Vec2 p : pts) EXPECT_TRUE(annulus.contains(p)) << p.x << " " << p.y;
  EXPECT_GE(min_pair_distance(pts), kD * (1 - kTol));
  Coverage c = coverage(pts, annulus, kD);
  EXPECT_GT(c.lattice_points, 20000);
  EXPECT_LE(c.worst, kD * (1 + kTol));
  // Two circular edges: more perimeter per area than the square (0.906 to 0.999 over 200 seeds).
  double area = std::numbers::pi * (0.45 * 0.45 - 0.15 * 0.15);
  double density = pts.size() * kD * kD / area;
  EXPECT_GT(density, kDensityMin);
  EXPECT_LT(density, 1.05);
}

// The points that lie at distance d from no earlier point: the lattice seeds (every other point was drawn
// on the circle of an earlier one).
size_t count_seeds(const std::vector<Vec2>& pts) {
  size_t seeds = 0;
  for (size_t i = 0; i < pts.size(); ++i) {
    bool drawn = false;
    for (size_t j = 0; j < i && !drawn; ++j) drawn = std::abs(distance(pts[i], pts[j]) - kD) < 1e-12;
    seeds += !drawn;
  }
  return seeds;
}

TEST(PoissonFill, SlitsThinnerThanTheSampleSpacingAreCarvedOut) {
  // Nine vertical slits of width d/25, narrower than the spacing of the circle samples (d 2 pi / 64):
  // circles cross them between two samples in the region, so some draws land in a slit and miss, and the
  // slit is then carved out of the arcs by bisection. Points still hop across the slits (the arcs beyond a
  // slit are in the region).
  PoissonRegion slits{0, 0, 1, 1, [](double x, double) {
                        double f = 10 * x - std::round(10 * x);
                        return std::abs(f) > 0.01 || x < 0.05 || x > 0.95;
                      }};
  uint64_t misses = 0;
  for (uint64_t seed = 0; seed < 5; ++seed) {
    uint64_t counter = 0;
    std::vector<Vec2> pts = fill({}, slits, seed, counter);
    misses += counter - (pts.size() - count_seeds(pts));
    for (Vec2 p : pts) EXPECT_TRUE(slits.contains(p)) << p.x << " " << p.y;
    EXPECT_GE(min_pair_distance(pts), kD * (1 - kTol));
    EXPECT_LE(coverage(pts, slits, kD).worst, kD * (1 + kTol));
  }
  EXPECT_GT(misses, 0u);
}

TEST(PoissonFill, TwoDisconnectedDisksAreBothSeeded) {
  auto in_disk = [](double x, double y, double cx) { return std::hypot(x - cx, y - 0.5) < 0.2; };
  PoissonRegion disks{0, 0, 1, 1, [&](double x, double y) { return in_disk(x, y, 0.25) || in_disk(x, y, 0.75); }};
  std::vector<Vec2> pts = fill_empty(disks, 41);
  for (Vec2 p : pts) EXPECT_TRUE(disks.contains(p)) << p.x << " " << p.y;
  EXPECT_GE(min_pair_distance(pts), kD * (1 - kTol));
  size_t left = std::count_if(pts.begin(), pts.end(), [&](Vec2 p) { return in_disk(p.x, p.y, 0.25); });
  EXPECT_GT(left, 10u);
  EXPECT_GT(pts.size() - left, 10u);
  EXPECT_LE(coverage(pts, disks, kD).worst, kD * (1 + kTol));
}

TEST(PoissonFill, ThinRegionsAndTinyRectangles) {
  // A strip thinner than d, and a rectangle smaller than d: each is covered by few points.
  PoissonRegion strip{0, 0, 1, 0.01, {}};
  std::vector<Vec2> pts = fill_empty(strip, 51);
  EXPECT_GE(min_pair_distance(pts), kD * (1 - kTol));
  EXPECT_LE(coverage(pts, strip, kD).worst, kD * (1 + kTol));
  EXPECT_GE(pts.size(), 10u);
  EXPECT_LE(pts.size(), 21u);
  PoissonRegion tiny{0.3, 0.3, 0.31, 0.32, {}};
  EXPECT_EQ(fill_empty(tiny, 52).size(), 1u);
  PoissonRegion none{0, 0, 1, 1, [](double, double) { return false; }};
  EXPECT_TRUE(fill_empty(none, 53).empty());
}

TEST(PoissonFill, ExistingPointsOutsideTheRegionDoNotBreakIt) {
  PoissonRegion square;
  double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<Vec2> outside = {{-0.02, 0.5}, {1.5, 1.5}, {-100, 3}, {0.5, 1.04}, {nan, nan}, {0, nan}};
  uint64_t counter = 0;
  std::vector<Vec2> added = fill(outside, square, 61, counter);
  outside.resize(4);  // the finite ones
  EXPECT_GE(min_pair_distance(concat(outside, added)), kD * (1 - kTol));
  EXPECT_LE(coverage(concat(outside, added), square, kD).worst, kD * (1 + kTol));
}

TEST(PoissonFill, ACoveringSetNeedsNothingAndDrawsNothing) {
  PoissonRegion square;
  std::vector<Vec2> pts = fill_empty(square, 71);
  uint64_t counter = 1234;
  EXPECT_TRUE(fill(pts, square, 72, counter).empty());
  EXPECT_EQ(counter, 1234u);
  // A triangular lattice of spacing d (covering radius d / sqrt 3) reaching past the square.
  std::vector<Vec2> lattice;
  for (int j = -1; j * kD * std::sqrt(0.75) < 1 + kD; ++j)
    for (int i = -1; i * kD < 1 + kD; ++i) lattice.push_back({(i + 0.5 * (j & 1)) * kD, j * kD * std::sqrt(0.75)});
  EXPECT_TRUE(fill(lattice, square, 73, counter).empty());
  EXPECT_EQ(counter, 1234u);
}

TEST(PoissonFill, CurvedRegionRefillDrawsNothingMore) {
  PoissonRegion disk{0, 0, 1, 1, [](double x, double y) { return std::hypot(x - 0.5, y - 0.5) < 0.4; }};
  std::vector<Vec2> pts = fill_empty(disk, 81);
  uint64_t counter = 0;
  std::vector<Vec2> more = fill(pts, disk, 82, counter);
  EXPECT_TRUE(more.empty());
  EXPECT_GE(min_pair_distance(concat(pts, more)), kD * (1 - kTol));
}

TEST(PoissonFill, InvalidSpacingOrRectangleGivesNothing) {
  PoissonRegion square;
  uint64_t counter = 0;
  EXPECT_TRUE(fill({}, square, 1, counter, 0).empty());
  EXPECT_TRUE(fill({}, square, 1, counter, -1).empty());
  EXPECT_TRUE(fill({}, square, 1, counter, std::numeric_limits<double>::quiet_NaN()).empty());
  EXPECT_TRUE(fill({}, PoissonRegion{1, 0, 0, 1, {}}, 1, counter).empty());
  EXPECT_EQ(counter, 0u);
}

TEST(PoissonCull, ThreeInALine) {
  // 0.5 d apart: the middle one is closer than d to the first; the last is exactly d from the first (not
  // closer) and only 0.5 d from the culled middle one, which no longer counts.
  std::vector<Vec2> line = {{0, 0}, {0.5 * kD, 0}, {kD, 0}};
  EXPECT_EQ(poisson_cull(line, kD), (std::vector<size_t>{1}));
  // The oldest survives whatever the order: here the middle point is the oldest.
  std::vector<Vec2> middle_first = {{0.5 * kD, 0}, {0, 0}, {kD, 0}};
  EXPECT_EQ(poisson_cull(middle_first, kD), (std::vector<size_t>{1, 2}));
  // With min_distance equal to the spacing nothing is closer than it: nothing is culled.
  EXPECT_TRUE(poisson_cull(line, 0.5 * kD).empty());
}

TEST(PoissonCull, SmallCases) {
  EXPECT_TRUE(poisson_cull({}, kD).empty());
  EXPECT_TRUE(poisson_cull({{0.5, 0.5}}, kD).empty());
  EXPECT_EQ(poisson_cull({{0.5, 0.5}, {0.5, 0.5}}, kD), (std::vector<size_t>{1}));  // duplicates: the younger
  EXPECT_TRUE(poisson_cull({{0, 0}, {1e6, -1e6}}, kD).empty());                     // far apart, a huge bounding box
  EXPECT_TRUE(poisson_cull({{0, 0}, {0, 0}}, 0).empty());
  // A point with a non-finite coordinate is closer to nothing: it is kept and culls nothing.
  double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(poisson_cull({{nan, 0}, {0, 0}, {0, 0}, {nan, nan}}, kD), (std::vector<size_t>{2}));
  // A cluster of four at 0.1 d around a point, and a point 1.5 d away: only the first of the cluster stays.
  std::vector<Vec2> cluster = {{0, 0}, {0.1 * kD, 0}, {0, 0.1 * kD}, {-0.1 * kD, 0}, {1.5 * kD, 0}};
  EXPECT_EQ(poisson_cull(cluster, kD), (std::vector<size_t>{1, 2, 3}));
}

TEST(PoissonCull, MatchesABruteForceReference) {
  std::vector<Vec2> pts;
  CounterRng rng(5, RngPurpose::PoissonSeed);
  for (uint64_t i = 0; i < 1500; ++i) pts.push_back({rng.uniform(2 * i), 0.5 * rng.uniform(2 * i + 1)});
  double md = 0.02;
  std::vector<size_t> expected, kept;
  for (size_t i = 0; i < pts.size(); ++i) {
    bool close = std::any_of(kept.begin(), kept.end(), [&](size_t k) { return distance(pts[k], pts[i]) < md; });
    (close ? expected : kept).push_back(i);
  }
  ASSERT_FALSE(expected.empty());
  EXPECT_EQ(poisson_cull(pts, md), expected);
}

}  // namespace
}  // namespace squall::textures
