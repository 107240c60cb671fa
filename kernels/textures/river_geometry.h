/* A river's walls on the device, shared by host C++ and OpenCL C (Q. Yu, F. Neyret, E. Bruneton,
 * N. Holzschuch, "Scalable Real-Time Animation of Rivers", Eurographics 2009, sec. 4.4: the boundary
 * segments binned so that a point visits only those within the search radius; a uniform grid of bins
 * stands in for the paper's quadtree).
 *
 * Buffers that go with it (lengths in du):
 *   segments          float4 per wall segment: (a.x, a.y, b.x, b.y)
 *   segment_boundary  int per segment: the boundary it belongs to (banks joined through junctions are one
 *                     boundary; each obstacle is one)
 *   bin_start         int per bin + 1: bin b holds bin_items[bin_start[b] .. bin_start[b + 1] - 1]
 *   bin_items         int: segment indices (a segment is in every bin it passes through)
 *   boundary_psi      float per boundary: psi on it, du^2/s
 *   boundary_s        float per boundary: its search radius s, du
 *   polygon_start     int per polygon + 1: polygon k is polygon_points[polygon_start[k] .. polygon_start[k + 1] - 1]
 *   polygon_points    float2: per polygon its bounding box (lower corner, upper corner), then its points
 *                     (closed); the channels' water first, then the obstacles' land */
#ifndef SQUALL_TEXTURES_RIVER_GEOMETRY_H
#define SQUALL_TEXTURES_RIVER_GEOMETRY_H

/* At most this many boundaries act on a point: the nearest ones. */
#define SQUALL_RIVER_NEAR 16

/* Layout (48 bytes, every member 4 bytes, no padding):
 *   offset  0  int   segments, boundaries
 *   offset  8  int   channel_polygons, obstacle_polygons
 *   offset 16  float bin_x0, bin_y0    lower corner of bin (0, 0), du
 *   offset 24  float bin_size          du
 *   offset 28  int   bins_x, bins_y
 *   offset 36  float p                 the boundary exponent of RIV09 eq. 2
 *   offset 40  float s_max             the largest search radius, du
 *   offset 44  int   reserved */
typedef struct RiverGeometry {
  int segments, boundaries;
  int channel_polygons, obstacle_polygons;
  float bin_x0, bin_y0;
  float bin_size;
  int bins_x, bins_y;
  float p;
  float s_max;
  int reserved;
} RiverGeometry;

/* The flags of a sample (the w of river_points' and river_bake's float4 output). */
#define SQUALL_RIVER_FLUID 1     /* in a channel and outside every obstacle */
#define SQUALL_RIVER_UNDEFINED 2 /* no boundary within the search radius: psi undefined, v = 0 */

#endif
