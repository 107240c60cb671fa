// Procedural river velocity on the device (Q. Yu, F. Neyret, E. Bruneton, N. Holzschuch, "Scalable
// Real-Time Animation of Rivers", Eurographics 2009, sec. 4): the network's boundary values of the stream
// function (river_network.h), the obstacles' values from the banks (sec. 4.3), the walls binned for the
// distance queries (sec. 4.4), and psi and v = curl psi evaluated at points or baked on a grid
// (kernels/textures/river.cl). No gRPC in here.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/cancel.h"
#include "common/limits.h"
#include "runtime/kernel.h"
#include "runtime/runtime.h"
#include "textures/river_geometry.h"
#include "textures/river_network.h"
#include "textures/river_spec.h"
#include "textures/texture_spec.h"

SQUALL_KERNEL_STRUCT(RiverGeometry)

namespace squall::textures {

// The river at one point.
struct RiverSample {
  double u = 0, v = 0;     // du/s; 0 outside the water and where psi is undefined
  double psi = 0;          // du^2/s (also outside the water)
  bool fluid = false;      // in a channel, outside every obstacle
  bool undefined = false;  // no boundary within the search radius
};

// A river baked on a grid: nx * ny nodes, x fastest.
struct RiverBake {
  BakeGrid grid;
  std::vector<float> u, v, psi, fluid;  // du/s, du/s, du^2/s, 1 = water
  int64_t undefined = 0;                // water nodes with no boundary within the search radius
  RiverNetwork network;
  std::vector<double> obstacle_psi;
};

// RiverEngine::validate without an engine.
void validate_river(const RiverSpec& river, const std::string& path);
void validate_bake_grid(const BakeGrid& grid, const LimitGate& gate, const std::string& path,
                        const std::string& prefix = "", const std::string& region_note = "");

class RiverEngine {
 public:
  RiverEngine(Runtime& runtime, LimitGate& gate);

  // Every field in range: INVALID_ARGUMENT naming "<path>.channels[c].left_bank.points[k].x", ...
  void validate(const RiverSpec& river, const std::string& path) const;
  // nx, ny in 2..4096 and within --max-grid-cells (RESOURCE_EXHAUSTED); the region finite, x1 > x0,
  // y1 > y0. Messages name "<path>.<prefix>nx", "<path>.<prefix>region.x1", ...; a region too fine for
  // its nodes adds `region_note` (where the region came from).
  void validate(const BakeGrid& grid, const std::string& path, const std::string& prefix = "",
                const std::string& region_note = "") const;

  // A validated river on a validated grid. The network and the obstacles' psi may still fail
  // (INVALID_ARGUMENT naming the field under `path`). Runs in slices; CANCELLED between them once `cancel`
  // is requested.
  RiverBake bake(const RiverSpec& river, const BakeGrid& grid, const std::string& path,
                 const Cancellation& cancel = {});
  // The host and device bytes a bake on `grid` holds: its result on the device, read back, and as planes.
  static uint64_t bake_bytes(const BakeGrid& grid) { return 3 * sizeof(cl_float4) * uint64_t(grid.nx) * grid.ny; }
  // The river at each point.
  std::vector<RiverSample> sample(const RiverSpec& river, const std::vector<Point2>& points, const std::string& path);

 private:
  struct Geometry;  // the river's walls and polygons on the device (river.cpp)
  Geometry upload(const RiverSpec& river, const std::string& path);
  // The river at `points`, only boundaries < limit acting.
  std::vector<RiverSample> run_points(const Geometry& geometry, const std::vector<Point2>& points, int limit);

  Runtime& runtime_;
  LimitGate& gate_;
  // out, points, count, geometry, segments, segment_boundary, bin_start, bin_items, boundary_psi,
  // boundary_s, polygon_start, polygon_points, limit
  Kernel<cl::Buffer, cl::Buffer, cl_int, RiverGeometry, cl::Buffer, cl::Buffer, cl::Buffer, cl::Buffer, cl::Buffer,
         cl::Buffer, cl::Buffer, cl::Buffer, cl_int>
      points_;
  // out, nx, ny, x0, y0, hx, hy, geometry, segments, segment_boundary, bin_start, bin_items, boundary_psi,
  // boundary_s, polygon_start, polygon_points
  Kernel<cl::Buffer, cl_int, cl_int, cl_float, cl_float, cl_float, cl_float, RiverGeometry, cl::Buffer, cl::Buffer,
         cl::Buffer, cl::Buffer, cl::Buffer, cl::Buffer, cl::Buffer, cl::Buffer>
      bake_;
};

// The baked river as an advection's velocity: one grid frame, solid nodes filled from the water by
// push-pull. A speed past kMaxVelocityParam (a narrow channel of a large flow rate; near a wall when p < 1)
// is INVALID_ARGUMENT naming `path`, the river's field.
VelocitySpec velocity_grid(const RiverBake& bake, const std::string& path);

}  // namespace squall::textures
