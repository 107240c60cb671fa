// Dynamic Poisson-disk distribution of particle centres, maintained on the host as in Q. Yu, F. Neyret,
// E. Bruneton, N. Holzschuch, "Lagrangian Texture Advection: Preserving both Spectrum and Velocity Field"
// (IEEE TVCG 2011), sec. 3.3.1: new points are put on the boundary of the union of the radius-d disks,
// after D. Dunbar and G. Humphreys, "A Spatial Data Structure for Fast Poisson-Disk Sample Generation"
// (SIGGRAPH 2006) (boundary sampling), so that no point of the region is farther than d from a sample;
// points closer than (1 - alpha) d are culled, youngest first (hysteresis between insertion and culling).
// Everything is deterministic: fixed iteration orders and a counter-based RNG.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "textures/counter_rng.h"

namespace squall::textures {

struct Vec2 {
  double x = 0, y = 0;
};

// The region to fill: a rectangle [x0, x1] x [y0, y1] (domain units), optionally intersected with a fluid
// test (inside(x, y) true in the fluid; empty means the whole rectangle).
struct PoissonRegion {
  double x0 = 0, y0 = 0, x1 = 1, y1 = 1;
  std::function<bool(double x, double y)> inside;

  bool contains(Vec2 p) const;
};

// The points to add to `existing` so that every point of `region` lies within d of a point, and no new
// point lies closer than d to another point (new or existing). Boundary sampling: each point keeps the
// arcs of its radius-d circle not covered by other disks nor outside the region; a new point is drawn
// uniformly on the remaining arcs of the first point (in order) that has some. Regions left uncovered
// (components holding no point, or pockets the arcs cannot reach) are found on a lattice of spacing d/4
// and seeded with their first uncovered lattice point, then filled the same way.
// `rng` draws with consecutive counters starting at `counter`, which is advanced past the last draw.
std::vector<Vec2> poisson_fill(const std::vector<Vec2>& existing, const PoissonRegion& region, double d,
                               const CounterRng& rng, uint64_t& counter);

// Indices (into `points`, which must be ordered oldest first) of the points to cull: a point is culled
// when it lies closer than min_distance to an older point that is kept. The oldest always survives.
std::vector<size_t> poisson_cull(const std::vector<Vec2>& points, double min_distance);

}  // namespace squall::textures
