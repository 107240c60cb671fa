/* Lagrangian texture advection: Q. Yu, F. Neyret, E. Bruneton, N. Holzschuch, "Lagrangian Texture
 * Advection: Preserving both Spectrum and Velocity Field", IEEE TVCG 17(11), 2011. Particles carry
 * G x G grids whose vertices follow the flow (sec. 3.3.2); each output pixel blends every grid covering
 * it with the weights of eqs. 5-8 (computed on the host) by eq. 4 or eq. 3 (direct reconstruction,
 * sec. 3.5.1, as a deterministic per-pixel gather over the grids binned into its tile). */
#include "textures/texture.clh"
#include "textures/velocity.clh"

#define SQUALL_BLEND_VARIANCE_PRESERVING 0
#define SQUALL_BLEND_NORMALIZED 1

/* Carries every grid vertex over the step [0, dt] (times from the step's start, as the velocity's) in
 * `substeps` RK4 steps. */
__kernel void lagrangian_advect(__global float2* positions, int count, VelocityField velocity,
                                __global const float2* grid, float dt, int substeps) {
  int i = get_global_id(0);
  if (i >= count) return;
  float2 x = positions[i];
  float h = dt / (float)substeps;
  for (int s = 0; s < substeps; ++s) x = rk4_step(&velocity, grid, x, (float)s * h, h);
  positions[i] = x;
}

/* Barycentric coordinates of p in triangle (a, b, c); all >= -eps when p is inside. A triangle whose area is
 * below float32's resolution of its edges (relative, so that grids of any size are sampled) holds no point. */
static float3 barycentric(float2 p, float2 a, float2 b, float2 c) {
  float2 e0 = b - a, e1 = c - a, q = p - a;
  float det = e0.x * e1.y - e0.y * e1.x;
  if (!(fabs(det) > 1e-6f * (dot(e0, e0) + dot(e1, e1)))) return (float3)(-1.0f);
  float l1 = (q.x * e1.y - q.y * e1.x) / det, l2 = (e0.x * q.y - e0.y * q.x) / det;
  return (float3)(1.0f - l1 - l2, l1, l2);
}

/* Whether p lies in box (xmin, ymin, xmax, ymax), edges included. */
static bool box_holds(float4 box, float2 p) { return !(p.x < box.x || p.y < box.y || p.x > box.z || p.y > box.w); }

/* The texture coordinate and weight at p of the quad whose corner (a, b) is vertex i00, if one of its two
 * triangles (split along its (0,0)-(1,1) diagonal) holds p. */
static bool quad_sample(__global const float2* positions, __global const float2* uvs, __global const float* weights,
                        int i00, int res, float2 p, float2* u, float* w) {
  const float eps = -1e-5f;
  int i10 = i00 + 1, i01 = i00 + res, i11 = i01 + 1;
  float2 v00 = positions[i00], v10 = positions[i10], v01 = positions[i01], v11 = positions[i11];
  float2 lo = fmin(fmin(v00, v10), fmin(v01, v11)), hi = fmax(fmax(v00, v10), fmax(v01, v11));
  if (!box_holds((float4)(lo, hi), p)) return false;
  int3 tri = (int3)(i00, i10, i11);
  float3 l = barycentric(p, v00, v10, v11);
  if (min(l.x, min(l.y, l.z)) < eps) {
    tri = (int3)(i00, i11, i01);
    l = barycentric(p, v00, v11, v01);
    if (min(l.x, min(l.y, l.z)) < eps) return false;
  }
  *u = l.x * uvs[tri.x] + l.y * uvs[tri.y] + l.z * uvs[tri.z];
  *w = max(0.0f, l.x * weights[tri.x] + l.y * weights[tri.y] + l.z * weights[tri.z]);
  return true;
}

/* The texture coordinate and weight at p of grid g, whose bounds box[0] hold p: those of the first quad
 * (rows b, then a, ascending) of its deformed lattice with a triangle holding p; false when none does.
 * Only the quads listed in p's bucket are tested: n x n buckets, n = min(2 (res - 1), 16), tile the
 * bounds (box[1] holds their inverse size) and each lists, by first vertex (a + res b < 256) and in that
 * order, every quad whose own bounds meet it (lagrangian.cpp): the others' bounds do not hold p. */
static bool grid_sample(__global const float2* positions, __global const float2* uvs, __global const float* weights,
                        __global const float4* box, __global const int* bucket_offsets,
                        __global const uchar* bucket_quads, int g, int res, float2 p, float2* u, float* w) {
  int n = min(2 * (res - 1), 16);
  float2 cell = floor((p - box[0].xy) * box[1].xy);
  int bucket = g * n * n + clamp((int)cell.x, 0, n - 1) + n * clamp((int)cell.y, 0, n - 1);
  for (int k = bucket_offsets[bucket]; k < bucket_offsets[bucket + 1]; ++k)
    if (quad_sample(positions, uvs, weights, g * res * res + bucket_quads[k], res, p, u, w)) return true;
  return false;
}

/* One pixel of the direct reconstruction: out holds final planes, raw planes R', then the auxiliary
 * planes sum w, sum w^2, the number of grids blended (-1 on solid pixels), 0 (no layer) and the texture
 * coordinate of the grid with the largest weight (0 where none). grid_boxes holds 2 float4 per grid and
 * bucket_offsets (CSR into bucket_quads) n^2 buckets per grid, as grid_sample reads them. */
__kernel void lagrangian_reconstruct(__global float* out, OutputGrid frame, __global const int* tile_offsets,
                                     __global const int* tile_grids, __global const float4* grid_boxes,
                                     __global const int* bucket_offsets, __global const uchar* bucket_quads,
                                     __global const float2* positions, __global const float2* uvs,
                                     __global const float* weights, int grid_res, int blend, TextureSource texture,
                                     __global const float* image, __global const float* scalar,
                                     __global const float* lut, VelocityField velocity, __global const uchar* mask) {
  int px = get_global_id(0), py = get_global_id(1);
  if (px >= frame.width || py >= frame.height) return;
  float2 p = (float2)(frame.x0 + ((float)px + 0.5f) * frame.pixel_x, frame.y0 + ((float)py + 0.5f) * frame.pixel_y);
  size_t plane = (size_t)frame.width * (size_t)frame.height, pixel = (size_t)px + (size_t)frame.width * (size_t)py;

  float s1[SQUALL_TEXTURE_MAX_CHANNELS];
  for (int c = 0; c < texture.channels; ++c) s1[c] = 0.0f;
  float s0 = 0.0f, s2 = 0.0f, w_max = 0.0f;
  float2 u_max = (float2)(0.0f);
  int n = 0;
  int fluid = velocity_fluid_at(&velocity, mask, p.x, p.y);
  float angle[SQUALL_TEXTURE_MAX_CHANNELS]; /* the bands' turns, the same for every grid */
  for (int c = 0; c < texture.channels; ++c) angle[c] = band_angle(&texture, c, 0.0f);
  int tile = px / frame.tile + frame.tiles_x * (py / frame.tile);
  for (int k = tile_offsets[tile]; fluid && k < tile_offsets[tile + 1]; ++k) {
    int g = tile_grids[k];
    __global const float4* box = grid_boxes + 2 * (size_t)g;
    if (!box_holds(box[0], p)) continue;
    float2 u;
    float w;
    if (!grid_sample(positions, uvs, weights, box, bucket_offsets, bucket_quads, g, grid_res, p, &u, &w) || w <= 0.0f)
      continue;
    if (w > w_max) w_max = w, u_max = u;
    for (int c = 0; c < texture.channels; ++c) {
      float r = texture_channel_at(&texture, image, c, u, angle[c]);
      s1[c] += w * (blend == SQUALL_BLEND_VARIANCE_PRESERVING ? r - texture.mean[c] : r);
    }
    s0 += w;
    s2 += w * w;
    ++n;
  }

  float r[SQUALL_TEXTURE_MAX_CHANNELS];
  float norm = blend == SQUALL_BLEND_VARIANCE_PRESERVING ? sqrt(s2) : s0;
  for (int c = 0; c < texture.channels; ++c) {
    if (s2 < 1e-12f)
      r[c] = texture.mean[c];
    else if (blend == SQUALL_BLEND_VARIANCE_PRESERVING)
      r[c] = s1[c] / norm + texture.mean[c]; /* eq. 4 */
    else
      r[c] = s1[c] / norm; /* eq. 3 */
  }
  write_texture_planes(&texture, scalar, lut, p, r, out, plane, pixel);
  int aux = final_channels(&texture) + texture.channels;
  out[(size_t)aux * plane + pixel] = s0;
  out[(size_t)(aux + 1) * plane + pixel] = s2;
  out[(size_t)(aux + 2) * plane + pixel] = fluid ? (float)n : -1.0f;
  out[(size_t)(aux + 3) * plane + pixel] = 0.0f;
  out[(size_t)(aux + 4) * plane + pixel] = u_max.x;
  out[(size_t)(aux + 5) * plane + pixel] = u_max.y;
}
