// A procedural river (Q. Yu, F. Neyret, E. Bruneton, N. Holzschuch, "Scalable Real-Time Animation of
// Rivers", Eurographics 2009, sec. 4): channels between bank polylines, junctions, obstacles, and the
// parameters of the stream function's interpolation, validated by RiverEngine::validate(spec, path).
// Lengths in domain units (du), flow rates in du^2/s.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

namespace squall::textures {

struct Point2 {
  double x = 0, y = 0;
};

// A channel: its banks drawn from upstream to downstream, left and right looking downstream.
struct RiverChannelSpec {
  std::vector<Point2> left, right;      // 2.. points each
  std::optional<double> flow_rate;      // Q; unset: from the junctions
  std::optional<double> cross_section;  // w; unset: |left[0] - right[0]|
};

// Channel indices ending (upstream) and starting (downstream) at a junction, each left to right.
struct RiverJunctionSpec {
  std::vector<uint32_t> upstream, downstream;  // as sent: an index past the channels is named as given
};

// A closed polygon (the last point joins the first), an island or a moving obstacle.
struct RiverObstacleSpec {
  std::vector<Point2> outline;          // 3.. points
  std::optional<double> search_radius;  // unset: the river's
};

struct RiverSpec {
  std::vector<RiverChannelSpec> channels;
  std::vector<RiverJunctionSpec> junctions;
  std::vector<RiverObstacleSpec> obstacles;
  double p = 1;                         // boundary exponent of eq. 2
  std::optional<double> search_radius;  // s; unset: twice the largest cross-section
};

// Nodes (i, j) at (x0 + i (x1 - x0) / (nx - 1), y0 + j (y1 - y0) / (ny - 1)).
struct BakeGrid {
  int64_t nx = 2, ny = 2;  // 2..4096, held as sent
  double x0 = 0, y0 = 0, x1 = 1, y1 = 1;
};

}  // namespace squall::textures
