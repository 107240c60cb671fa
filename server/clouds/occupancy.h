// Where a volume's density is, coarsely: a grid of at most kCells cells a side over a box, a cell marked
// when an occupied box (an active leaf or tile) overlaps it. A render estimates from it, before marching,
// how much of each ray lies in density (its cost under empty-space skipping), to size its slices.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "clouds/noise.h"

namespace squall::clouds {

struct CoarseOccupancy {
  static constexpr int kCells = 32;  // along the box's longest side

  Vec3d min{0, 0, 0};             // the grid's lower corner, m
  double cell = 1;                // cell side, m (cubic cells)
  std::array<int, 3> n{0, 0, 0};  // cells per axis, 1..kCells
  std::vector<uint8_t> marked;    // n[0] * n[1] * n[2], x fastest: 1 where a box overlaps

  // Over the box [lo, hi] (m), marking the cells that `boxes` (min x, y, z, max x, y, z; m) overlap.
  static CoarseOccupancy of(const Vec3d& lo, const Vec3d& hi, const std::vector<std::array<double, 6>>& boxes);

  // Length (m) of the ray origin + t * direction (t >= 0, direction of unit length) inside marked cells,
  // sampled every half cell.
  double marked_length(const Vec3d& origin, const Vec3d& direction) const;
};

}  // namespace squall::clouds
