/* The stream function of a river and its velocity (Q. Yu, F. Neyret, E. Bruneton, N. Holzschuch,
 * "Scalable Real-Time Animation of Rivers", Eurographics 2009, sec. 4):
 *   psi(P) = sum_i w(d_i) psi_i / sum_i w(d_i)                  (eq. 1)
 *   w(d)   = d^-p f(1 - d / s)  for 0 < d <= s, 0 beyond        (eq. 2)
 *   f(t)   = 6 t^5 - 15 t^4 + 10 t^3                            (eq. 3)
 *   v      = curl psi = (d psi / dy, -d psi / dx)               (sec. 4)
 * d_i is the distance from P to boundary i (the nearest of its segments). The velocity is psi's exact
 * gradient, grad psi = sum_i (psi_i - psi) w'(d_i) grad d_i / sum_i w(d_i), instead of the paper's finite
 * differences: no step to choose, no stencil across a wall, and v stays tangent to the walls. Within 2^-20
 * of its search radius of a wall d_i is held at that distance (stream_sample): there v is the gradient at
 * the band's edge, still tangent, and continuous. */
#include "textures/river_geometry.h"

typedef struct RiverNear {
  int n;
  int id[SQUALL_RIVER_NEAR];
  float d[SQUALL_RIVER_NEAR];
  float2 g[SQUALL_RIVER_NEAR]; /* grad d_i: the unit vector from the nearest point of boundary i to P */
} RiverNear;

static float smoothstep5(float t) { return t * t * t * (t * (6.0f * t - 15.0f) + 10.0f); } /* eq. 3 */
static float smoothstep5_derivative(float t) { return 30.0f * t * t * (t - 1.0f) * (t - 1.0f); }

/* Keeps the nearest distance to boundary `id`, and the nearest SQUALL_RIVER_NEAR boundaries. */
static void near_update(RiverNear* near, int id, float d, float2 g) {
  int farthest = 0;
  for (int k = 0; k < near->n; ++k) {
    if (near->id[k] == id) {
      if (d < near->d[k]) {
        near->d[k] = d;
        near->g[k] = g;
      }
      return;
    }
    if (near->d[k] > near->d[farthest]) farthest = k;
  }
  int slot = near->n;
  if (near->n == SQUALL_RIVER_NEAR) {
    if (d >= near->d[farthest]) return;
    slot = farthest;
  } else {
    near->n++;
  }
  near->id[slot] = id;
  near->d[slot] = d;
  near->g[slot] = g;
}

/* The boundaries (id < limit) within their search radius of P, each at its nearest segment. */
static RiverNear near_boundaries(float2 P, RiverGeometry geo, __global const float4* segments,
                                 __global const int* segment_boundary, __global const int* bin_start,
                                 __global const int* bin_items, __global const float* boundary_s, int limit) {
  RiverNear near;
  near.n = 0;
  // Saturated: a node (finite) far from the river's bins would overflow an int; the range is then empty.
  const int bx0 = max(convert_int_sat(floor((P.x - geo.s_max - geo.bin_x0) / geo.bin_size)), 0);
  const int by0 = max(convert_int_sat(floor((P.y - geo.s_max - geo.bin_y0) / geo.bin_size)), 0);
  const int bx1 = min(convert_int_sat(floor((P.x + geo.s_max - geo.bin_x0) / geo.bin_size)), geo.bins_x - 1);
  const int by1 = min(convert_int_sat(floor((P.y + geo.s_max - geo.bin_y0) / geo.bin_size)), geo.bins_y - 1);
  for (int by = by0; by <= by1; ++by) {
    for (int bx = bx0; bx <= bx1; ++bx) {
      const int bin = by * geo.bins_x + bx;
      for (int k = bin_start[bin]; k < bin_start[bin + 1]; ++k) {
        const int s = bin_items[k];
        const int id = segment_boundary[s];
        if (id >= limit) continue;
        const float2 a = segments[s].xy, b = segments[s].zw, ab = b - a;
        const float len2 = dot(ab, ab);
        const float t = len2 > 0.0f ? clamp(dot(P - a, ab) / len2, 0.0f, 1.0f) : 0.0f;
        const float2 r = P - (a + t * ab);
        const float d = length(r);
        if (d > boundary_s[id]) continue;
        near_update(&near, id, d, d > 0.0f ? r / d : (float2)(0.0f, 0.0f));
      }
    }
  }
  return near;
}

/* (u, v, psi, flags) at P from its near boundaries: eqs. 1-3 and the exact curl. */
static float4 stream_sample(const RiverNear* near, float p, __global const float* boundary_psi,
                            __global const float* boundary_s) {
  float d_min = INFINITY;
  int nearest = 0;
  for (int k = 0; k < near->n; ++k) {
    if (near->d[k] < d_min) {
      d_min = near->d[k];
      nearest = k;
    }
  }
  if (near->n == 0) return (float4)(0.0f, 0.0f, 0.0f, (float)SQUALL_RIVER_UNDEFINED);
  if (d_min <= 0.0f) return (float4)(0.0f, 0.0f, boundary_psi[near->id[nearest]], 0.0f);
  /* Each distance is taken at no less than 2^-20 of its boundary's search radius: for p < 1 the speed grows
   * as d^(p - 1) toward a wall (Yu et al., fig. 8), and within float's reach of one its terms would overflow. */
  float dk[SQUALL_RIVER_NEAR];
  d_min = INFINITY;
  for (int k = 0; k < near->n; ++k) {
    const float d = near->d[k], least = 0x1p-20f * boundary_s[near->id[k]];
    dk[k] = d > least ? d : least;
    d_min = dk[k] < d_min ? dk[k] : d_min;
  }
  /* The weights are scaled by d_min^p, which cancels in eq. 1 and in its gradient: no overflow near a wall. */
  float sum_w = 0.0f, sum_w_psi = 0.0f;
  float w[SQUALL_RIVER_NEAR], dw[SQUALL_RIVER_NEAR];
  for (int k = 0; k < near->n; ++k) {
    const float s = boundary_s[near->id[k]], d = dk[k], t = 1.0f - d / s;
    const float a = pow(d_min / d, p);
    w[k] = a * smoothstep5(t);                                         /* eq. 2 */
    dw[k] = -p * w[k] / d - a * smoothstep5_derivative(t) / s;        /* dw / dd */
    sum_w += w[k];
    sum_w_psi += w[k] * boundary_psi[near->id[k]];
  }
  if (!(sum_w > 0.0f)) return (float4)(0.0f, 0.0f, 0.0f, (float)SQUALL_RIVER_UNDEFINED);
  const float psi = sum_w_psi / sum_w; /* eq. 1 */
  float2 grad = (float2)(0.0f, 0.0f);
  for (int k = 0; k < near->n; ++k) grad += (boundary_psi[near->id[k]] - psi) * dw[k] * near->g[k];
  grad /= sum_w;
  return (float4)(grad.y, -grad.x, psi, 0.0f); /* v = curl psi */
}

/* Crossing-number test of polygon points[begin .. end - 1] (closed). */
static bool in_polygon(float2 P, __global const float2* points, int begin, int end) {
  bool inside = false;
  for (int i = begin, j = end - 1; i < end; j = i++) {
    const float2 a = points[i], b = points[j];
    if ((a.y > P.y) != (b.y > P.y) && P.x < (b.x - a.x) * (P.y - a.y) / (b.y - a.y) + a.x) inside = !inside;
  }
  return inside;
}

/* Polygon k (its bounding box, then its points: river_geometry.h) contains P. */
static bool polygon_contains(float2 P, __global const int* polygon_start, __global const float2* polygon_points,
                             int k) {
  const int begin = polygon_start[k], end = polygon_start[k + 1];
  const float2 lo = polygon_points[begin], hi = polygon_points[begin + 1];
  if (P.x < lo.x || P.y < lo.y || P.x > hi.x || P.y > hi.y) return false;
  return in_polygon(P, polygon_points, begin + 2, end);
}

/* In a channel and outside every obstacle. */
static bool in_water(float2 P, RiverGeometry geo, __global const int* polygon_start,
                     __global const float2* polygon_points) {
  bool water = false;
  for (int k = 0; k < geo.channel_polygons && !water; ++k)
    water = polygon_contains(P, polygon_start, polygon_points, k);
  for (int k = geo.channel_polygons; k < geo.channel_polygons + geo.obstacle_polygons && water; ++k)
    water = !polygon_contains(P, polygon_start, polygon_points, k);
  return water;
}

static float4 river_at(float2 P, RiverGeometry geo, __global const float4* segments,
                       __global const int* segment_boundary, __global const int* bin_start,
                       __global const int* bin_items, __global const float* boundary_psi,
                       __global const float* boundary_s, __global const int* polygon_start,
                       __global const float2* polygon_points, int limit) {
  const RiverNear near =
      near_boundaries(P, geo, segments, segment_boundary, bin_start, bin_items, boundary_s, limit);
  float4 sample = stream_sample(&near, geo.p, boundary_psi, boundary_s);
  if (in_water(P, geo, polygon_start, polygon_points)) sample.w += (float)SQUALL_RIVER_FLUID;
  else sample.xy = (float2)(0.0f, 0.0f);
  return sample;
}

/* (u, v, psi, flags) at each point; only boundaries < limit act (an obstacle's psi from the banks alone). */
__kernel void river_points(__global float4* out, __global const float2* points, int count, RiverGeometry geo,
                           __global const float4* segments, __global const int* segment_boundary,
                           __global const int* bin_start, __global const int* bin_items,
                           __global const float* boundary_psi, __global const float* boundary_s,
                           __global const int* polygon_start, __global const float2* polygon_points, int limit) {
  const int i = get_global_id(0);
  if (i >= count) return;
  out[i] = river_at(points[i], geo, segments, segment_boundary, bin_start, bin_items, boundary_psi, boundary_s,
                    polygon_start, polygon_points, limit);
}

/* (u, v, psi, flags) at the nodes (i, j) of a grid, at (x0 + i hx, y0 + j hy), x fastest. */
__kernel void river_bake(__global float4* out, int nx, int ny, float x0, float y0, float hx, float hy,
                         RiverGeometry geo, __global const float4* segments, __global const int* segment_boundary,
                         __global const int* bin_start, __global const int* bin_items,
                         __global const float* boundary_psi, __global const float* boundary_s,
                         __global const int* polygon_start, __global const float2* polygon_points) {
  const int i = get_global_id(0), j = get_global_id(1);
  if (i >= nx || j >= ny) return;
  const float2 P = (float2)(x0 + i * hx, y0 + j * hy);
  out[j * nx + i] = river_at(P, geo, segments, segment_boundary, bin_start, bin_items, boundary_psi, boundary_s,
                             polygon_start, polygon_points, geo.boundaries);
}
