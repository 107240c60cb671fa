// The coarse occupancy a render sizes its slices by: a ray's length inside marked cells matches the
// geometry (a box's width along the ray, to a cell), and rays that miss or pass by the boxes have none.
#include <gtest/gtest.h>

#include <cmath>

#include "clouds/occupancy.h"

namespace squall::clouds {
namespace {

// A 32 m cube of 1 m cells with one occupied box, 8 m wide, at its centre.
CoarseOccupancy centred_box() { return CoarseOccupancy::of({0, 0, 0}, {32, 32, 32}, {{12, 12, 12, 20, 20, 20}}); }

TEST(CoarseOccupancy, ARayThroughABoxIsInsideForItsWidth) {
  const CoarseOccupancy grid = centred_box();
  EXPECT_EQ(grid.n, (std::array<int, 3>{32, 32, 32}));
  EXPECT_DOUBLE_EQ(grid.cell, 1.0);
  // Along x through the centre: the cells 12..20 are marked (the box's faces fall on cell boundaries, the far
  // face's cell included), 9 m, sampled every half cell.
  EXPECT_NEAR(grid.marked_length({-10, 16, 16}, {1, 0, 0}), 9.0, 0.5);
  // The diagonal through the centre: 9 cells of sqrt(3) m each.
  const double s = 1 / std::sqrt(3.0);
  EXPECT_NEAR(grid.marked_length({0, 0, 0}, {s, s, s}), 9 * std::sqrt(3.0), 1.0);
}

TEST(CoarseOccupancy, RaysThatMissTheBoxOrTheGridHaveNoLength) {
  const CoarseOccupancy grid = centred_box();
  EXPECT_EQ(grid.marked_length({-10, 4, 16}, {1, 0, 0}), 0.0);         // through the grid, beside the box
  EXPECT_EQ(grid.marked_length({-10, 40, 16}, {1, 0, 0}), 0.0);        // beside the grid
  EXPECT_EQ(grid.marked_length({-10, 16, 16}, {-1, 0, 0}), 0.0);       // the grid behind the origin
  EXPECT_NEAR(grid.marked_length({16, 16, 16}, {0, 0, 1}), 4.5, 0.5);  // from inside the box: half of it
}

TEST(CoarseOccupancy, ARayFromFarAwayEndsAndStillFindsTheBox) {
  const CoarseOccupancy grid = centred_box();
  // 1e12 m: t is exact to 1e-4 m, the box's 8 m (and the half-cell sampling) come out as near.
  EXPECT_NEAR(grid.marked_length({16, 16, 1e12}, {0, 0, -1}), 9.0, 0.5);
  // 1e17 m: doubles there are 16 m apart, so t0 + half a cell rounds back to t0. Steps counted from the
  // entry point still cross the grid's 32 m and find the box; steps added onto t would never leave t0.
  EXPECT_NEAR(grid.marked_length({16, 16, 1e17}, {0, 0, -1}), 9.0, 0.5);
  // 1e18 m: the grid's span itself rounds away (doubles 128 m apart): nothing is found, and the call ends.
  EXPECT_EQ(grid.marked_length({16, 16, 1e18}, {0, 0, -1}), 0.0);
}

TEST(CoarseOccupancy, AFlatBoxGetsCubicCellsOfItsLongestSideOver32AndAtLeastOneLayer) {
  const CoarseOccupancy grid = CoarseOccupancy::of({0, 0, 0}, {64, 8, 0}, {});
  EXPECT_EQ(grid.n, (std::array<int, 3>{32, 4, 1}));
  EXPECT_DOUBLE_EQ(grid.cell, 2.0);
}

}  // namespace
}  // namespace squall::clouds
