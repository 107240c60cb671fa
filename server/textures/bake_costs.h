// The estimated device time of each 8 x 8-node tile of a river's bake, for slicing it (runtime/slices.h). A
// node scans the wall segments binned within s_max of it (river.cl's near_boundaries) and tests the points
// of every polygon whose box holds it (in_water), so a tile costs about 1 + those segments + those points
// per node. Only the ratios matter: they let a slice of cheap land tiles stop before the river's costly ones.
#pragma once

#include <cstddef>
#include <vector>

#include "runtime/opencl.h"
#include "runtime/slices.h"
#include "textures/river_geometry.h"
#include "textures/river_spec.h"

namespace squall::textures {

// A polygon's bounding box (du) and the points its crossing test reads.
struct PolygonBox {
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  double points = 0;
};

// Per tile of `tiles` (row order, tile (i, j) holding nodes 8i .. 8i + 7 along x): `bin_start` is the
// geometry's segment bins (bin b holds bin_start[b + 1] - bin_start[b] segments).
std::vector<double> bake_tile_costs(const RiverGeometry& geo, const std::vector<cl_int>& bin_start,
                                    const std::vector<PolygonBox>& polygons, const BakeGrid& grid,
                                    const TileGrid& tiles);

// Per point, what river_points scans for it as a bake's node: 1 + the segments binned within s_max of it +
// the points of every polygon whose box holds it.
std::vector<double> point_costs(const RiverGeometry& geo, const std::vector<cl_int>& bin_start,
                                const std::vector<PolygonBox>& polygons, const std::vector<Point2>& points);

}  // namespace squall::textures
