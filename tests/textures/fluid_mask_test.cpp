// The fluid test of a masked velocity grid, on the host (the same code runs in the kernels).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "textures/fields.h"

namespace squall {
namespace {

// A 2 x 2 grid at 1 um whose right column is solid: points past its right edge, however far (1e4 m is
// 1e10 spacings, past an int), take the right column's nodes; points past its left edge the left column's.
TEST(FluidMask, FarPointsTakeTheNearestEdgeNode) {
  VelocityField f{};
  f.kind = SQUALL_VELOCITY_GRID;
  f.nx = f.ny = 2;
  f.hx = f.hy = 1e-6f;
  f.has_mask = 1;
  const unsigned char mask[4] = {1, 0, 1, 0};  // node (i, j) at i + nx j: column 0 fluid, column 1 solid
  EXPECT_EQ(velocity_fluid_at(&f, mask, 0.0f, 0.0f), 1);
  EXPECT_EQ(velocity_fluid_at(&f, mask, 1e-6f, 0.0f), 0);
  for (float x : {1e-3f, 5e3f, 1e4f, 1e30f}) EXPECT_EQ(velocity_fluid_at(&f, mask, x, 5e3f), 0) << "x = " << x;
  for (float x : {-1e-3f, -5e3f, -1e30f}) EXPECT_EQ(velocity_fluid_at(&f, mask, x, -5e3f), 1) << "x = " << x;
  EXPECT_EQ(nearest_node(std::numeric_limits<float>::quiet_NaN(), 1.0f, 2), 0);
  EXPECT_EQ(nearest_node(0.6f, 1.0f, 5), 1);
  EXPECT_EQ(nearest_node(3.6f, 1.0f, 5), 4);
}

}  // namespace
}  // namespace squall
