// The procedural river velocity against the properties RIV09 claims for it (Q. Yu, F. Neyret,
// E. Bruneton, N. Holzschuch, "Scalable Real-Time Animation of Rivers", Eurographics 2009, sec. 4): the
// flux between two banks is the channel's flow rate, no flow through walls, zero divergence, locality,
// the wall law set by p (fig. 8), and flow past a cylinder against the closed-form potential flow.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <numeric>
#include <vector>

#include "support/expect_error.h"
#include "support/test_runtime.h"
#include "support/worst.h"
#include "textures/river.h"

namespace squall::test {
namespace {

using namespace squall::textures;

RiverEngine& river_engine() {
  static LimitGate gate{Limits{}};
  static RiverEngine engine(runtime(), gate);
  return engine;
}

std::vector<Point2> line(Point2 a, Point2 b, int points = 2) {
  std::vector<Point2> out;
  for (int k = 0; k < points; ++k) {
    const double t = double(k) / (points - 1);
    out.push_back({a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)});
  }
  return out;
}

// A straight channel along +x: right bank y = 0, left bank y = width, x in [0, length].
RiverSpec straight(double width, double length, double q, double p) {
  RiverSpec river;
  RiverChannelSpec c;
  c.left = line({0, width}, {length, width});
  c.right = line({0, 0}, {length, 0});
  c.flow_rate = q;
  river.channels.push_back(c);
  river.p = p;
  return river;
}

std::vector<Point2> circle(Point2 centre, double radius, int points) {
  std::vector<Point2> out;
  for (int k = 0; k < points; ++k) {
    const double a = 2 * std::numbers::pi * k / points;
    out.push_back({centre.x + radius * std::cos(a), centre.y + radius * std::sin(a)});
  }
  return out;
}

// Flux through the segment a -> b: the integral of v . n with n the segment's direction turned clockwise
// (from a on the right bank to b on the left bank, n points downstream), midpoint rule.
double flux(const RiverSpec& river, Point2 a, Point2 b, int samples = 1000) {
  std::vector<Point2> points;
  for (int k = 0; k < samples; ++k) {
    const double t = (k + 0.5) / samples;
    points.push_back({a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)});
  }
  const double len = std::hypot(b.x - a.x, b.y - a.y);
  const double nx = (b.y - a.y) / len, ny = -(b.x - a.x) / len;
  double sum = 0;
  for (const RiverSample& s : river_engine().sample(river, points, "river")) sum += s.u * nx + s.v * ny;
  return sum * len / samples;
}

// A Y junction: channel 0 (width 2) splits at x = 2 into channel 1 (left, widening to the upper right) and
// channel 2 (right, to the lower right), each of width 1 at the fork, separated by a wedge of land.
RiverSpec y_junction(double q0) {
  RiverSpec river;
  RiverChannelSpec main, left, right;
  main.left = line({0, 2}, {2, 2});
  main.right = line({0, 0}, {2, 0});
  main.flow_rate = q0;
  left.left = line({2, 2}, {5, 3.5});
  left.right = line({2, 1}, {5, 2.5});
  right.left = line({2, 1}, {5, -0.5});
  right.right = line({2, 0}, {5, -1.5});
  river.channels = {main, left, right};
  river.junctions.push_back({{0}, {1, 2}});
  river.search_radius = 2;
  return river;
}

TEST(RiverNetwork, JunctionSplitsTheFlowByCrossSectionsAndBanksShareValues) {
  RiverSpec river = y_junction(3);
  river.channels[2].cross_section = 2;  // twice channel 1's: gets 2/3 of the flow
  const RiverNetwork n = solve_network(river, "river");
  EXPECT_NEAR(n.flow_rate[1], 1.0, 1e-12);
  EXPECT_NEAR(n.flow_rate[2], 2.0, 1e-12);
  EXPECT_EQ(n.left_psi[0], n.left_psi[1]);    // outer left bank continues
  EXPECT_EQ(n.right_psi[0], n.right_psi[2]);  // outer right bank continues
  EXPECT_EQ(n.right_psi[1], n.left_psi[2]);   // the inner bank is one boundary
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(n.left_psi[c] - n.right_psi[c], n.flow_rate[c], 1e-12);
  EXPECT_EQ(n.boundary_psi.size(), 3u);
}

TEST(RiverNetwork, TrifurcationAndConfluence) {
  // Channel 0 splits into 1, 2, 3 (left to right), which join again into 4.
  RiverSpec river;
  for (int c = 0; c < 5; ++c) {
    RiverChannelSpec ch;
    ch.left = line({double(c), 1}, {c + 1.0, 1});
    ch.right = line({double(c), 0}, {c + 1.0, 0});
    river.channels.push_back(ch);
  }
  river.channels[4].flow_rate = 6;
  river.channels[1].cross_section = 1;
  river.channels[2].cross_section = 2;
  river.channels[3].cross_section = 3;
  river.junctions.push_back({{0}, {1, 2, 3}});
  river.junctions.push_back({{1, 2, 3}, {4}});
  const RiverNetwork n = solve_network(river, "river");
  EXPECT_NEAR(n.flow_rate[0], 6, 1e-12);  // from the confluence, then split again
  EXPECT_NEAR(n.flow_rate[1], 1, 1e-12);
  EXPECT_NEAR(n.flow_rate[2], 2, 1e-12);
  EXPECT_NEAR(n.flow_rate[3], 3, 1e-12);
  EXPECT_NEAR(n.right_psi[0], 0, 1e-12);
  EXPECT_NEAR(n.left_psi[3], 3, 1e-12);  // psi falls left to right by each branch's Q
  EXPECT_NEAR(n.left_psi[2], 5, 1e-12);
  EXPECT_NEAR(n.left_psi[1], 6, 1e-12);
}

TEST(RiverNetwork, BadNetworksNameTheField) {
  RiverSpec river = y_junction(3);
  river.channels[0].flow_rate.reset();
  expect_error(Code::InvalidArgument, "river.channels[0].flow_rate is unset", [&] { solve_network(river, "river"); });
  river = y_junction(3);
  river.channels[1].flow_rate = 1;
  river.channels[2].flow_rate = 1;
  expect_error(Code::InvalidArgument, "river.junctions[0]: flow in 3", [&] { solve_network(river, "river"); });
  // Q = 10 between banks at psi 1e9 and 1e9 - 10, which float32 rounds to one value: no flow was baked.
  river = y_junction(1e9);
  river.channels[1].flow_rate = 10;
  river.channels[2].flow_rate = 1e9 - 10;
  expect_error(Code::InvalidArgument, "river.channels[1]: its flow rate 10 du^2/s is lost in float32",
               [&] { solve_network(river, "river"); });
  river.channels[1].flow_rate = 1e6;  // 1e-3 of the largest: float32's spacing of 64 is 6.4e-5 of it
  river.channels[2].flow_rate = 1e9 - 1e6;
  EXPECT_NO_THROW(solve_network(river, "river"));
}

TEST(River, FluxBetweenTheBanksIsTheFlowRate) {
  for (double p : {0.9, 1.0, 1.2}) {
    const RiverSpec river = straight(1, 4, 2, p);
    EXPECT_NEAR(flux(river, {2, 0}, {2, 1}), 2.0, 0.02) << "p = " << p;
    EXPECT_NEAR(flux(river, {1, 0}, {1.5, 1}), 2.0, 0.02) << "slanted section, p = " << p;
  }
  const RiverSpec y = y_junction(3);
  const double q0 = flux(y, {1, 0}, {1, 2}), q1 = flux(y, {3.5, 1.75}, {3.5, 2.75}),
               q2 = flux(y, {3.5, -0.75}, {3.5, 0.25});
  EXPECT_NEAR(q0, 3.0, 0.03);
  EXPECT_NEAR(q1, 1.5, 0.015);  // equal cross-sections: half each
  EXPECT_NEAR(q2, 1.5, 0.015);
  EXPECT_NEAR(q1 + q2, q0, 0.03);
}

TEST(River, IslandSplitsTheFlowAtItsCentreValue) {
  RiverSpec river = straight(2, 6, 4, 1);
  river.obstacles.push_back({circle({3, 0.8}, 0.3, 48), {}});  // below the axis: less water under it
  river.search_radius = 3;
  const RiverBake bake = river_engine().bake(river, {4, 4, 0, 0, 6, 2}, "river");
  ASSERT_EQ(bake.obstacle_psi.size(), 1u);
  const double psi_island = bake.obstacle_psi[0];
  EXPECT_GT(psi_island, 0.0);
  EXPECT_LT(psi_island, 4.0);
  const double below = flux(river, {3, 0}, {3, 0.5}), above = flux(river, {3, 1.1}, {3, 2});
  EXPECT_NEAR(below, psi_island, 0.01 * 4);
  EXPECT_NEAR(above, 4 - psi_island, 0.01 * 4);
  EXPECT_NEAR(below + above, 4.0, 0.04);
}

// The largest |v . n| at points `off` from a wall (n the wall's normal), relative to the mean speed U of
// the channel, and the largest |v . n| / |v| where |v| > U / 2 (away from stagnation points).
std::pair<double, double> worst_penetration(const RiverSpec& river, const std::vector<Point2>& wall_points,
                                            const std::vector<Point2>& normals, double off, double mean_speed) {
  std::vector<Point2> points;
  for (size_t k = 0; k < wall_points.size(); ++k)
    points.push_back({wall_points[k].x + normals[k].x * off, wall_points[k].y + normals[k].y * off});
  const std::vector<RiverSample> s = river_engine().sample(river, points, "river");
  double worst = 0, worst_relative = 0;
  for (size_t k = 0; k < s.size(); ++k) {
    EXPECT_TRUE(s[k].fluid) << k;
    const double speed = std::hypot(s[k].u, s[k].v), normal = std::abs(s[k].u * normals[k].x + s[k].v * normals[k].y);
    worst = squall::test::worse(worst, normal / mean_speed);
    if (speed > mean_speed / 2) worst_relative = squall::test::worse(worst_relative, normal / speed);
  }
  return {worst, worst_relative};
}

TEST(River, NoFlowThroughBanksAndObstacles) {
  // A channel 2 wide (U = Q / 2 = 2) with a round island on its axis. The normal velocity vanishes at
  // every wall, linearly with the distance d: a nearby boundary's pull is d / d_other of the wall's own.
  // It is largest at the island's stagnation points, where the tangential flow vanishes too.
  RiverSpec river = straight(2, 6, 4, 1);
  river.obstacles.push_back({circle({3, 1}, 0.4, 96), {}});
  river.search_radius = 3;
  std::vector<Point2> walls, normals;
  for (int k = 0; k < 48; ++k) {
    const double a = 2 * std::numbers::pi * (k + 0.5) / 48;
    const double r = 0.4 * std::cos(std::numbers::pi / 96);  // the polygon's edge midpoints
    walls.push_back({3 + r * std::cos(a), 1 + r * std::sin(a)});
    normals.push_back({std::cos(a), std::sin(a)});
  }
  for (double x = 1; x < 5.5; x += 0.5) {
    walls.push_back({x, 0});
    normals.push_back({0, 1});
    walls.push_back({x, 2});
    normals.push_back({0, -1});
  }
  const double U = 2;
  const auto [at_half_percent, relative] = worst_penetration(river, walls, normals, 0.01, U);  // 0.5% of the width
  const auto [at_twentieth, relative_closer] = worst_penetration(river, walls, normals, 0.001, U);
  EXPECT_LT(at_half_percent, 0.03) << "max |v . n| / U at 0.5% of the width";
  EXPECT_LT(at_twentieth, 0.004) << "max |v . n| / U at 0.05% of the width";
  EXPECT_GT(at_half_percent / at_twentieth, 7.0) << "|v . n| ~ d";
  EXPECT_LT(relative, 0.05) << "max |v . n| / |v| where |v| > U / 2, at 0.5% of the width";
  RecordProperty("normal_over_U", std::to_string(at_half_percent) + " " + std::to_string(at_twentieth));
}

TEST(River, DivergenceFree) {
  // Central differences of the baked velocity: div v h / |v| is the truncation error, O(h^2).
  const RiverSpec river = y_junction(3);
  const int n = 401;
  const RiverBake bake = river_engine().bake(river, {n, n, 0, -1.5, 5, 3.5}, "river");
  const double hx = 5.0 / (n - 1), hy = 5.0 / (n - 1);
  std::vector<double> relative;
  for (int j = 2; j < n - 2; ++j) {
    for (int i = 2; i < n - 2; ++i) {
      bool water = true;  // the 5 x 5 block around the node all water (no stencil across a wall)
      for (int b = -2; b <= 2; ++b)
        for (int a = -2; a <= 2; ++a) water &= bake.fluid[(j + b) * n + i + a] != 0;
      if (!water) continue;
      const size_t k = size_t(j) * n + i;
      const double div = (bake.u[k + 1] - bake.u[k - 1]) / (2 * hx) + (bake.v[k + n] - bake.v[k - n]) / (2 * hy);
      relative.push_back(std::abs(div) * hx / std::hypot(bake.u[k], bake.v[k]));
    }
  }
  ASSERT_GT(relative.size(), 10000u);
  std::sort(relative.begin(), relative.end());
  const double median = relative[relative.size() / 2], p90 = relative[relative.size() * 9 / 10];
  // Against the velocity's own gradient scale |grad v| h / |v| ~ h / width ~ 1e-2: a thousand times below.
  EXPECT_LT(median, 1e-4) << "median |div| h / |v|";
  EXPECT_LT(p90, 1e-3) << "90th percentile (kinks of the distance on medial axes)";
}

TEST(River, LocalityFarObstacleLeavesVelocityBitwiseUnchanged) {
  RiverSpec river = straight(1, 20, 1, 1);
  river.search_radius = 1;
  river.obstacles.push_back({circle({15, 0.5}, 0.2, 24), {}});
  const BakeGrid near_region{32, 16, 1, 0, 4, 1};  // 11 du from the obstacle, s = 1
  const RiverBake before = river_engine().bake(river, near_region, "river");
  river.obstacles[0].outline = circle({16, 0.4}, 0.25, 24);  // moved and grown
  const RiverBake after = river_engine().bake(river, near_region, "river");
  EXPECT_EQ(before.u, after.u);
  EXPECT_EQ(before.v, after.v);
  // ... while the flow near the obstacle changes.
  const BakeGrid at_obstacle{32, 16, 14, 0, 17, 1};
  river.obstacles[0].outline = circle({15, 0.5}, 0.2, 24);
  const RiverBake there_before = river_engine().bake(river, at_obstacle, "river");
  river.obstacles[0].outline = circle({16, 0.4}, 0.25, 24);
  EXPECT_NE(there_before.u, river_engine().bake(river, at_obstacle, "river").u);
}

// The least-squares slope of log |u| against log d over the wall distances.
double wall_slope(double p) {
  const RiverSpec river = straight(1, 4, 1, p);
  std::vector<Point2> points;
  std::vector<double> lx, ly;
  for (int k = 0; k < 12; ++k) {
    const double d = 0.005 * std::pow(10.0, k / 11.0);  // 0.5% .. 5% of the width
    points.push_back({2, d});
    lx.push_back(std::log(d));
  }
  for (const RiverSample& s : river_engine().sample(river, points, "river")) ly.push_back(std::log(std::abs(s.u)));
  const double mx = std::accumulate(lx.begin(), lx.end(), 0.0) / lx.size();
  const double my = std::accumulate(ly.begin(), ly.end(), 0.0) / ly.size();
  double sxy = 0, sxx = 0;
  for (size_t k = 0; k < lx.size(); ++k) {
    sxy += (lx[k] - mx) * (ly[k] - my);
    sxx += (lx[k] - mx) * (lx[k] - mx);
  }
  return sxy / sxx;
}

TEST(River, WallLawSlopeIsPMinusOne) {
  // psi - psi_wall ~ d^p near a wall, so the tangential speed goes as d^(p - 1): p < 1 slip (the speed
  // grows towards the wall), p > 1 no-slip (it falls to 0), RIV09 fig. 8.
  // The fitted slopes share a bias of about +0.07 (measured -0.240, -0.027, 0.079, 0.287 at p = 0.7, 0.9, 1,
  // 1.2): each is held to 0.1 of p - 1, and its difference from p = 1's, which the bias leaves, to 0.03.
  const double at_1 = wall_slope(1.0);
  EXPECT_NEAR(at_1, 0.0, 0.1);
  for (double p : {0.7, 0.9, 1.2}) {
    const double slope = wall_slope(p);
    EXPECT_NEAR(slope, p - 1, 0.1) << "p = " << p;
    EXPECT_NEAR(slope - at_1, p - 1, 0.03) << "p = " << p;
  }
}

TEST(River, FlowPastACylinderNearPotentialFlow) {
  // A channel 8 wide (walls at y = +-4) with a free stream U = 1 past a cylinder of radius a = 0.5: far
  // from the walls, potential flow is psi = U y (1 - a^2 / r^2). RIV09 fig. 7 compares with a potential
  // solver only by eye; the tolerances below are this model's measured agreement, kept as regression bounds.
  const double a = 0.5, H = 4;
  RiverSpec river;
  RiverChannelSpec c;
  c.left = line({-10, H}, {10, H});
  c.right = line({-10, -H}, {10, -H});
  c.flow_rate = 2 * H;
  river.channels.push_back(c);
  river.obstacles.push_back({circle({0, 0}, a, 128), {}});
  river.search_radius = 2 * H;
  const double radii[] = {1.2 * a, 1.6 * a, 2.2 * a, 3 * a};
  std::vector<Point2> points;
  for (int k = 0; k < 64; ++k)
    for (double r : radii) {
      const double t = 2 * std::numbers::pi * (k + 0.5) / 64;
      points.push_back({r * std::cos(t), r * std::sin(t)});
    }
  const std::vector<RiverSample> s = river_engine().sample(river, points, "river");
  std::vector<double> angle_error, speed_ratio[4];  // |u| / |u_potential| on each circle
  for (size_t k = 0; k < points.size(); ++k) {
    const double x = points[k].x, y = points[k].y, r2 = x * x + y * y, a2 = a * a;
    const double ux = 1 - a2 * (x * x - y * y) / (r2 * r2), uy = -2 * a2 * x * y / (r2 * r2);
    const double dot = s[k].u * ux + s[k].v * uy, cross = s[k].u * uy - s[k].v * ux;
    angle_error.push_back(std::abs(std::atan2(cross, dot)) * 180 / std::numbers::pi);
    speed_ratio[k % 4].push_back(std::hypot(s[k].u, s[k].v) / std::hypot(ux, uy));
  }
  std::sort(angle_error.begin(), angle_error.end());
  EXPECT_LT(angle_error[angle_error.size() / 2], 10.0) << "median angle error, degrees";
  EXPECT_LT(angle_error.back(), 25.0) << "largest angle error, degrees";  // measured 6.0 and 16.3 on PoCL
  // The island sits on the axis: psi there is the mean of the banks', so half the flow passes each side.
  EXPECT_NEAR(river_engine().bake(river, {2, 2, -1, -1, 1, 1}, "river").obstacle_psi[0], H, 1e-3 * H);
  RecordProperty("angle_error_median_max_deg",
                 std::to_string(angle_error[angle_error.size() / 2]) + " " + std::to_string(angle_error.back()));
  // The speed is the model's weak point: RIV09 interpolates psi, it does not solve Laplace's equation, and
  // near the cylinder the flow is slower than potential flow's. The median ratio on each circle, measured
  // 0.284, 0.483, 0.734 and 0.992 at 1.2, 1.6, 2.2 and 3 a, rises to 1 away from the cylinder.
  double previous = 0;
  for (int c = 0; c < 4; ++c) {
    std::sort(speed_ratio[c].begin(), speed_ratio[c].end());
    const double median = speed_ratio[c][speed_ratio[c].size() / 2];
    std::printf("r = %.1f a: median speed ratio %.3f\n", radii[c] / a, median);
    EXPECT_GT(median, previous + 0.1) << "r = " << radii[c] / a << " a";
    previous = median;
  }
  EXPECT_NEAR(previous, 1.0, 0.1) << "at 3 a";
}

TEST(River, UndefinedWhereNoBoundaryIsNear) {
  RiverSpec river = straight(10, 10, 1, 1);
  river.search_radius = 2;  // the channel's middle is farther than s from both banks
  const std::vector<RiverSample> s = river_engine().sample(river, {{5, 5}, {5, 1}}, "river");
  EXPECT_TRUE(s[0].fluid);
  EXPECT_TRUE(s[0].undefined);
  EXPECT_EQ(s[0].u, 0.0);
  EXPECT_FALSE(s[1].undefined);
}

TEST(River, BadRiversNameTheField) {
  RiverEngine& e = river_engine();
  RiverSpec river = straight(1, 4, 1, 1);
  river.channels[0].left[1].x = NAN;
  expect_error(Code::InvalidArgument, "river.channels[0].left_bank.points[1].x", [&] { e.validate(river, "river"); });
  river = straight(1, 4, 1, 0);
  expect_error(Code::InvalidArgument, "river.p = 0", [&] { e.validate(river, "river"); });
  river = straight(1, 4, -1, 1);
  expect_error(Code::InvalidArgument, "river.channels[0].flow_rate", [&] { e.validate(river, "river"); });
  river = straight(1, 4, 3e38, 1);  // psi and the velocities were infinite
  expect_error(Code::InvalidArgument, "river.channels[0].flow_rate = 3e+38", [&] { e.validate(river, "river"); });
  river = straight(1, 4, 1, 1);
  river.search_radius = 1e39;  // past float32: every node was undefined
  expect_error(Code::InvalidArgument, "river.search_radius = 1e+39", [&] { e.validate(river, "river"); });
  // Speeds scale with Q / s: lengths below 1e-6 du are refused, the banks' own distance included.
  river.search_radius = 1e-7;
  expect_error(Code::InvalidArgument, "river.search_radius = 1e-07", [&] { e.validate(river, "river"); });
  river = straight(1e-7, 4, 1, 1);
  expect_error(Code::InvalidArgument, "river.channels[0]: the banks start less than 1e-06 du apart",
               [&] { e.validate(river, "river"); });
  river.channels[0].cross_section = 1e-7;
  expect_error(Code::InvalidArgument, "river.channels[0].cross_section = 1e-07", [&] { e.validate(river, "river"); });
  river = y_junction(3);
  river.junctions[0].downstream = {1, 7};
  expect_error(Code::InvalidArgument, "river.junctions[0].downstream[1] = 7", [&] { e.validate(river, "river"); });
  river = straight(1, 4, 1, 1);
  river.obstacles.push_back({line({1, 0.5}, {2, 0.5}), {}});
  expect_error(Code::InvalidArgument, "river.obstacles[0].outline.points size", [&] { e.validate(river, "river"); });
  river = straight(1, 40, 1, 1);
  river.search_radius = 1;
  river.obstacles.push_back({circle({30, 10}, 0.2, 8), {}});  // 9.5 du off the channel
  e.validate(river, "river");
  expect_error(Code::InvalidArgument, "river.obstacles[0]: no bank", [&] {
    e.bake(river, {2, 2, 0, 0, 1, 1}, "river");
  });
  // A bank and four obstacles that zigzag across 2e7 du 4095 times each, with a search radius of 1 du: each
  // segment crosses some 2000 of the million bins, 40 million entries in all, past the bound.
  river = straight(1, 4, 1, 1);
  river.search_radius = 1;
  std::vector<Point2> zigzag;
  for (int k = 0; k < 4096; ++k) zigzag.push_back(k % 2 ? Point2{1e7, 1e7 - k} : Point2{-1e7, -1e7 + k});
  river.channels[0].left = zigzag;
  for (int o = 0; o < 4; ++o) river.obstacles.push_back({zigzag, {}});
  e.validate(river, "river");
  expect_error(Code::ResourceExhausted, "river: its walls cross more than 16777216 bins", [&] {
    e.bake(river, {2, 2, 0, 0, 1, 1}, "river");
  });
  Limits small;
  small.max_grid_cells = 1000;
  LimitGate gate(small);
  const RiverEngine limited(runtime(), gate);
  expect_error(Code::ResourceExhausted, "grid", [&] { limited.validate(BakeGrid{40, 40, 0, 0, 1, 1}, "grid"); });
  expect_error(Code::InvalidArgument, "grid.region.x1", [&] { e.validate(BakeGrid{4, 4, 0, 0, 0, 1}, "grid"); });
  // A baked grid is a velocity grid: its nodes at least 1e-6 du apart.
  expect_error(Code::InvalidArgument, "grid.bake_region spans 0.0001 du along x over 128 nodes", [&] {
    e.validate(BakeGrid{128, 4, 0, 0, 1e-4, 1}, "grid", "bake_");
  });
  // Nodes placed in float32: 4096 nodes over 1 du at x = 1e6 (float32's step there is 0.0625 du) are refused;
  // their spacing must be at least 2^-19 of the coordinate, 1.9 du.
  expect_error(Code::InvalidArgument,
               "grid.region spans 1 du along x over 4096 nodes: their spacing must be at least 1.9", [&] {
                 e.validate(BakeGrid{4096, 4, 1e6, 0, 1e6 + 1, 1}, "grid");
               });
  e.validate(BakeGrid{4096, 4, 1e6, 0, 1e6 + 8000, 1}, "grid");
}

}  // namespace
}  // namespace squall::test
