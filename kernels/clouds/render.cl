// Cloud ray marcher (appendix A, "The Ray March Algorithm", of J. Tessendorf and M. Kowalski, "Resolution
// Independent Volumes" (SIGGRAPH course notes 2010/2011), reproduced as App. D of J. Tessendorf, "Gilligan: A
// Prototype Framework for Simulating and Rendering Maritime Environments" (2017)) over NanoVDB grids read
// through PNanoVDB.h.
// Single scattering plus emission:  per sub-step of length h at density rho,
//   dT = exp(-kappa rho h);  L += C^T T (1 - dT) / kappa;  T *= dT           (eqs A.22-A.26; A.24 is "+=")
//   C^T = C^E + C^S C^I,  C^S = albedo kappa,  C^I = sum_i E_i T_i^L P(n . n_i^L)   (A.3, A.4, A.7)
//   C^E = (1 - albedo) kappa B_lambda(T(x))   (Kirchhoff; Gilligan sec. 7.2.2)
// Steps: each step [s, s + h] (h = step, clipped to node boundaries and the ray's end) is cut at N_s - 1
// sorted uniform offsets r_1 < ... < r_{N_s-1}, with r_0 = 0 and r_{N_s} = 1 (the printed sub-step update
// advances x by r_j h and stops at r_{N_s-1}; here x advances by (r_j - r_{j-1}) h and the last sub-interval
// is kept); each sub-interval is sampled at a uniformly jittered point, where the directional lights are
// sampled too; a point light, whose 1 / d^2 peaks along the ray, is sampled by sub-step at points of its own
// (sq_point_light_inscatter: equiangular, lights.h). The optical depth estimate is
// unbiased for any step; it is exact, whatever the step, where the density is constant over each step
// (steps end at leaf and tile boundaries and at the grid's bounding box, so e.g. nearest-voxel density that
// is constant over each leaf it fills).
// Empty-space skipping: the ray walks the NanoVDB tree node by node (the hierarchical DDA of NanoVDB's
// HDDA: the node's level and value from pnanovdb_readaccessor_get_value_address_and_level, its exit from
// the ray's inverse direction); the primary ray marches only through leaves and tiles of nonzero density.
// A tile's density is one value: the primary ray reads it without a lookup, and a shadow ray adds value x
// length where its steps would sum to that (sq_tile_column: a nearest-voxel tile, a trilinear tile's core
// or a tile inside uniform density), crossing a lower node's tiles and leaves one after another from its
// table (CellRun). Inside a leaf the samples read the leaf's value table directly (a trilinear one's 2x2x2 block
// when its 8 voxels lie in the leaf), with no tree query per step.
// Index convention: voxel ijk is centred at index position ijk (OpenVDB); the walk uses "cell space"
// c = index + 0.5, where voxel ijk is the cell [ijk, ijk + 1). Ray parameters t are world metres, a primary
// ray's counted from where it enters the grid's box (sq_clip_root_from_entry), a shadow ray's from its point.
#include "clouds/pnanovdb_cl.h"
#include "clouds/render_params.h"
#include "clouds/phase.h"
#include "clouds/lights.h"

#include "clouds/node_walk.clh"

// The value of voxel ijk: from the leaf of `node`, which must hold it (no tree query), or with no node
// through the accessor.
static inline float sq_voxel(VdbVolume* v, const VdbNode* node, int3 ijk) {
  if (!node) return sq_vdb_value(v->buf, &v->acc, ijk);
  pnanovdb_coord_t c = {ijk.x, ijk.y, ijk.z};
  return pnanovdb_read_float(v->buf, pnanovdb_leaf_get_value_address(PNANOVDB_GRID_TYPE_FLOAT, v->buf, node->leaf, &c));
}

// The corner (n & 1, n >> 1 & 1, n >> 2) of the 8 voxels from i.
static inline int3 sq_corner(int3 i, int n) { return i + (int3)(n & 1, n >> 1 & 1, n >> 2); }

// Trilinear interpolation between the 8 values k[n] at sq_corner(i, n), at fractions w from corner 0.
static inline float sq_mix8(const float* k, float3 w) {
  float c00 = mix(k[0], k[1], w.x), c10 = mix(k[2], k[3], w.x), c01 = mix(k[4], k[5], w.x), c11 = mix(k[6], k[7], w.x);
  return mix(mix(c00, c10, w.y), mix(c01, c11, w.y), w.z);
}

// Density at index-space position p: the nearest voxel, or trilinear between the 8 around it, each
// through the accessor.
static inline float sq_sample(VdbVolume* v, float3 p, int trilinear) {
  if (!trilinear) return sq_voxel(v, 0, convert_int3_rtn(p + 0.5f));
  float3 f = floor(p);
  float k[8];
  for (int n = 0; n < 8; ++n) k[n] = sq_voxel(v, 0, sq_corner(convert_int3(f), n));
  return sq_mix8(k, p - f);
}

// The value of voxel ijk, from the ray's current node where it holds the voxel (a tile's value, or the
// leaf's table; no tree query), through the accessor elsewhere.
static inline float sq_node_voxel(VdbVolume* v, const VdbNode* node, int3 ijk) {
  if (any(ijk < node->lo) || any(ijk >= node->lo + node->dim)) return sq_voxel(v, 0, ijk);
  return node->tile >= 0.0f ? node->tile : sq_voxel(v, node, ijk);
}

// Trilinear density at cell-space point c of the ray's current node. Where the 8 voxels around c lie in
// the node: a tile's value, or the leaf's 2x2x2 block from one address (its table holds voxel (x, y, z) at
// float x << 6 | y << 3 | z); elsewhere each voxel read as sq_node_voxel does, so that a sample across a
// leaf's face queries the tree only for the voxels beyond it (the accessor then caches the neighbour,
// not two leaves in turn). Not inlined: inlined into the marches it made the nearest-voxel shadow rays
// 9% slower.
__attribute__((noinline)) static float sq_node_trilinear(VdbVolume* v, const VdbNode* node, float3 c) {
  const float3 p = c - 0.5f, f = floor(p);
  const int3 i = convert_int3(f);
  const bool inside = all(i >= node->lo) && all(i <= node->lo + node->dim - 2);
  if (node->tile >= 0.0f && (inside || node->interior)) return node->tile;
  float k[8];
  if (inside) {
    pnanovdb_coord_t ijk = {i.x, i.y, i.z};
    const pnanovdb_address_t at =
        pnanovdb_leaf_get_value_address(PNANOVDB_GRID_TYPE_FLOAT, v->buf, node->leaf, &ijk);
    for (int n = 0; n < 8; ++n)
      k[n] = pnanovdb_read_float(v->buf, pnanovdb_address_offset(at, 4u * ((n & 1) << 6 | (n >> 1 & 1) << 3 | n >> 2)));
  } else {
    for (int n = 0; n < 8; ++n) k[n] = sq_node_voxel(v, node, sq_corner(i, n));
  }
  return sq_mix8(k, p - f);
}

// Density at cell-space point c of the ray's current node: trilinear (sq_node_trilinear), or the nearest
// voxel: a tile's value, or a leaf's read from its own value table, c clamped into the leaf (rounding may
// put a step on the face it leaves through).
static inline float sq_node_density(VdbVolume* v, const VdbNode* node, float3 c, int trilinear) {
  if (trilinear) return sq_node_trilinear(v, node, c);
  if (node->tile >= 0.0f) return node->tile;
  return sq_voxel(v, node, clamp(convert_int3_rtn(c), node->lo, node->lo + 7));
}

// 1 - e^{-x} for x >= 0, the opacity of a sub-step: its Taylor series to x^6 below x = 1/4 (relative error
// below x^6/7! = 5e-8 there), 1 - exp(-x) above (exp's 3 ulp, OpenCL's bound, are below 1e-6 of the
// result there). Within float noise of -expm1(-x), which PoCL runs as a call into SLEEF's scalar expm1:
// 40% of the render kernel's time in a profile of small renders.
static inline float sq_opacity(float x) {
  if (x >= 0.25f) return 1.0f - exp(-x);
  return x * (1.0f - x / 2.0f * (1.0f - x / 3.0f * (1.0f - x / 4.0f * (1.0f - x / 5.0f * (1.0f - x / 6.0f)))));
}

// T *= 1 - opacity, a sub-step's attenuation (A.25). Below opacity 1/2 as T -= T opacity with Kahan's
// compensated summation, *lost carrying what the last subtraction rounded away: 1 - opacity would round
// by up to half an ulp of 1, the same way every step (a slab crossed in 1.6e5 steps of opacity 6e-6 kept
// 0.2% too much light). From 1/2 up as the product, where 1 - opacity is exact (Sterbenz's lemma) and T
// stays at or above 0. (Radiance, summed plainly, was off by 2e-5 in the same march.)
static inline void sq_attenuate(float* T, float* lost, float opacity) {
  if (opacity < 0.5f) {
    const float y = -*T * opacity - *lost, t = *T + y;
    *lost = (t - *T) - y;
    *T = t;
    return;
  }
  *T = (*T - *lost) * (1.0f - opacity);
  *lost = 0.0f;
}

// The step from s that float takes when asked for h: (s + h) - s, exact (Sterbenz's lemma), so that the
// steps' lengths sum to the span marched. Asked for h, a step of a few ulps of s rounds by up to half an
// ulp: at the finest step admitted, 8 ulps of the box's diagonal, a slab's optical depth was off by 2e-3.
static inline float sq_float_step(float s, float h) { return (s + h) - s; }

static inline uint sq_hash(uint x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}
static inline float sq_uniform(uint* state) {
  *state = sq_hash(*state + 0x9e3779b9U);
  return (float)(*state >> 8) * (1.0f / 16777216.0f);
}

// N_s sorted offsets r_0 = 0 < r_1 < ... < r_{N_s} = 1 of one step.
static inline void sq_substep_offsets(int n, uint* rng, float* r) {
  r[0] = 0.0f;
  for (int j = 1; j < n; ++j) {
    float u = sq_uniform(rng);
    int k = j;
    while (k > 1 && r[k - 1] > u) {
      r[k] = r[k - 1];
      --k;
    }
    r[k] = u;
  }
  r[n] = 1.0f;
}

// The column density of [s, e) of a shadow ray (cell space o + t d) in `node`, added to *column: jittered
// steps of p->shadow_step, until *column passes p->shadow_column_max.
static void sq_march_column(VdbVolume* v, const VdbNode* node, float3 o, float3 d, float s, float e,
                            __private const CloudRenderParams* p, uint* rng, float* column) {
  while (s < e && *column <= p->shadow_column_max) {
    float h = sq_float_step(s, fmin(p->shadow_step, e - s));
    *column += sq_node_density(v, node, o + (s + sq_uniform(rng) * h) * d, p->shadow_interpolation) * h;
    s += h;
  }
}

// Clips [*a, *b] to the span of the ray inside the box [lo, hi] (cell space, seen from `from`; inv_d = 1 / d);
// false when nothing is left. An axis the ray runs parallel to leaves the span whole where `from` lies in
// its slab, and empty where not.
static inline bool sq_clip_slabs(float3 lo, float3 hi, float3 from, float3 inv_d, float* a, float* b) {
  const float3 t_lo = (lo - from) * inv_d, t_hi = (hi - from) * inv_d;
  const int3 parallel = isinf(inv_d), in_slab = isgreaterequal(from, lo) & islessequal(from, hi);
  const float3 inf = (float3)(INFINITY);
  const float3 near = select(fmin(t_lo, t_hi), select(inf, -inf, in_slab), parallel);
  const float3 far = select(fmax(t_lo, t_hi), select(-inf, inf, in_slab), parallel);
  *a = fmax(*a, fmax(fmax(near.x, near.y), near.z));
  *b = fmin(*b, fmin(fmin(far.x, far.y), far.z));
  return *a < *b;
}

// The column density of [s, e) of a shadow ray through a tile, added to *column. Nearest voxels: value x
// length, what jittered steps would sum to. Trilinear: value x length over the tile's core, the points whose
// 8 voxels all lie in the tile ([lo + 1/2, lo + dim - 1/2) in cell space), or over all of [s, e) in a tile
// inside uniform density (interior); jittered steps over the rest, its half-voxel shell, where the tile's
// value meets its neighbours'. An empty tile adds nothing: the marches skip empty nodes, and with them
// the density trilinear interpolation spills into them, up to half a voxel past a face (none at a cloud's
// edge, where density falls to zero).
static void sq_tile_column(VdbVolume* v, const VdbNode* tile, float3 o, float3 d, float3 inv_d, float s, float e,
                           __private const CloudRenderParams* p, uint* rng, float* column) {
  if (!p->shadow_interpolation || tile->interior || tile->tile == 0.0f) {
    *column += tile->tile * (e - s);
    return;
  }
  const float3 base_cell = floor(o + s * d), lo = convert_float3(tile->lo) - base_cell;
  float a = s, b = e;
  if (!sq_clip_slabs(lo + 0.5f, lo + (tile->dim - 0.5f), o - base_cell, inv_d, &a, &b)) {
    sq_march_column(v, tile, o, d, s, e, p, rng, column);
    return;
  }
  sq_march_column(v, tile, o, d, s, a, p, rng, column);
  *column += tile->tile * (b - a);
  sq_march_column(v, tile, o, d, b, e, p, rng, column);
}

// The column through the cells of a lower node from `node`, a leaf or a tile of it (dim 8) that sq_node
// found at t, crossed one after another from the node's table (CellRun), with no tree query: tiles as
// sq_tile_column takes them, leaves in jittered steps. Up to t_end, the node's edge or a column past
// p->shadow_column_max; returns the ray parameter reached, where the walk goes on: at least
// min(node->exit, t_end).
static float sq_cell_run_column(VdbVolume* v, const VdbNode* node, float3 o, float3 d, float3 inv_d, float t,
                                float t_end, __private const CloudRenderParams* p, uint* rng, float* column) {
  CellRun run = sq_cell_run_begin(v, o, d, inv_d, t, t_end, node);
  do {
    if (run.cell.tile >= 0.0f)
      sq_tile_column(v, &run.cell, o, d, inv_d, run.enter, run.cell.exit, p, rng, column);
    else
      sq_march_column(v, &run.cell, o, d, run.enter, run.cell.exit, p, rng, column);
  } while (*column <= p->shadow_column_max && sq_cell_run_next(v, inv_d, &run));
  return run.cell.exit;
}

// Column density (integral of rho ds, m) from world point x along unit direction dir over [0, tmax], in
// jittered steps of p->shadow_step clipped to the tree's nodes, sampling the nearest voxel or trilinear
// (p->shadow_interpolation); through tiles as sq_tile_column takes them, and a lower node's cells one after
// another from its table (sq_cell_run_column). The march stops once the column passes
// p->shadow_column_max: the light's transmittance is then below min_transmittance at every wavelength, and
// the estimate keeps at most that much light (the bias of early termination).
static float sq_column_density(VdbVolume* v, float3 x, float3 dir, float tmax, __private const CloudRenderParams* p,
                               uint* rng) {
  float3 o = sq_world_to_index(v, x) + 0.5f;
  float3 d = sq_world_to_index_dir(v, dir);
  float t0 = 0.0f, t1 = tmax;
  if (!sq_clip_root(v, o, d, &t0, &t1)) return 0.0f;
  float nudge = 1e-4f / length(d);
  float3 inv_d = 1.0f / d;
  float column = 0.0f;
  for (float t = t0; t < t1 && column <= p->shadow_column_max;) {
    VdbNode node;
    sq_node(v, o, d, inv_d, t, nudge, &node);
    if (node.dim == 8) {  // a leaf, or a tile of a lower node
      t = sq_cell_run_column(v, &node, o, d, inv_d, t, t1, p, rng, &column);
    } else {  // a tile of an upper node or of the root
      const float exit = fmin(node.exit, t1);
      sq_tile_column(v, &node, o, d, inv_d, t, exit, p, rng, &column);
      t = exit;
    }
  }
  return column;
}

// Trilinear interpolation of the deep shadow map of light `light` at world point x.
static float sq_dsm_column(__global const float* dsm, int light, float3 x, __private const CloudRenderParams* p) {
  int3 n = (int3)(p->dsm_n[0], p->dsm_n[1], p->dsm_n[2]);
  float3 lo = (float3)(p->dsm_min[0], p->dsm_min[1], p->dsm_min[2]);
  float3 hi = (float3)(p->dsm_max[0], p->dsm_max[1], p->dsm_max[2]);
  float3 g = clamp((x - lo) / (hi - lo), 0.0f, 1.0f) * convert_float3(n - 1);
  int3 i = min(convert_int3(floor(g)), n - 2);
  float3 w = g - convert_float3(i);
  __global const float* base = dsm + (size_t)light * n.x * n.y * n.z;
#define SQUALL_DSM(a, b, c) base[((size_t)(i.z + (c)) * n.y + (i.y + (b))) * n.x + (i.x + (a))]
  float c00 = mix(SQUALL_DSM(0, 0, 0), SQUALL_DSM(1, 0, 0), w.x),
        c10 = mix(SQUALL_DSM(0, 1, 0), SQUALL_DSM(1, 1, 0), w.x);
  float c01 = mix(SQUALL_DSM(0, 0, 1), SQUALL_DSM(1, 0, 1), w.x),
        c11 = mix(SQUALL_DSM(0, 1, 1), SQUALL_DSM(1, 1, 1), w.x);
#undef SQUALL_DSM
  return mix(mix(c00, c10, w.y), mix(c01, c11, w.y), w.z);
}

// Deep shadow map: column density toward each light at the nodes of a box grid (log T^L = -kappa column).
// Sparse: nodes with needed[node] == 0 (farther than one map cell from any density) are skipped. Entry
// id of the map: node id % nodes toward light id / nodes.
static void sq_shadow_map_entry(size_t id, __global const uint* density, __global const uint* interior,
                                __private const CloudRenderParams* p,
                                __global const uchar* needed, __global float* dsm) {
  int3 n = (int3)(p->dsm_n[0], p->dsm_n[1], p->dsm_n[2]);
  size_t nodes = (size_t)n.x * n.y * n.z;
  if (id >= nodes * p->n_lights) return;
  int light = (int)(id / nodes);
  size_t node = id % nodes;
  if (!needed[node]) {
    dsm[id] = 0.0f;
    return;
  }
  int3 i = (int3)(node % n.x, (node / n.x) % n.y, node / ((size_t)n.x * n.y));
  float3 lo = (float3)(p->dsm_min[0], p->dsm_min[1], p->dsm_min[2]);
  float3 hi = (float3)(p->dsm_max[0], p->dsm_max[1], p->dsm_max[2]);
  float3 x = lo + (hi - lo) * convert_float3(i) / convert_float3(n - 1);
  VdbVolume v = sq_volume_open(density, interior);
  uint rng = sq_hash((uint)id ^ sq_hash((uint)p->seed + 17u));
  float dist, scale;
  float3 dir = sq_to_light(p, light, x, &dist, &scale);
  dsm[id] = sq_column_density(&v, x, dir, dist, p, &rng);
}

// The phase function between the view direction dir and the direction nl toward a light.
static inline float sq_phase_toward(__private const CloudRenderParams* p, float3 dir, float3 nl) {
  const float3 diff = dir - nl, sum = dir + nl;
  return phase_function(p, dot(dir, nl), 0.25f * dot(diff, diff), 0.25f * dot(sum, sum));
}

// The column density (m) from x toward light i (direction nl, at distance dist), as the shadow mode has it.
static inline float sq_light_column(VdbVolume* v, __global const float* dsm, __private const CloudRenderParams* p,
                                    int i, float3 x, float3 nl, float dist, uint* rng) {
  return p->shadow == SQUALL_SHADOW_DSM      ? sq_dsm_column(dsm, i, x, p)
         : p->shadow == SQUALL_SHADOW_DIRECT ? sq_column_density(v, x, nl, dist, p, rng)
                                             : 0.0f;
}

// Point light i's in-scatter over the sub-step [t0, t0 + len] of the primary ray entry + t dir (density rho
// there), added to own[w]: the integral over the sub-step of I g(t) p T^L exp(-kappa rho (t - t0)), g the
// capped inverse square. Equiangular samples (lights.h), stratified: one per pi / SQUALL_CLOUD_POINT_LIGHT_STRATA
// of the sub-step's angle seen from the light (max(b, r) G), each with its own phase and column toward the
// light, which vary across the peak as fast as g does (with one sample a sub-step, a ray passing a light at
// a voxel's distance at one-voxel steps was 5-40% off the exact radiance; with 64 a half turn 1-2%).
static void sq_point_light_inscatter(VdbVolume* v, __global const float* dsm, __private const CloudRenderParams* p,
                                     int i, float3 entry, float3 dir, float t0, float len, float rho, uint* rng,
                                     float* own) {
  const LightSpan span = sq_light_span(p, i, entry, dir, t0, len);
  const int most = SQUALL_CLOUD_POINT_LIGHT_STRATA;
  const int strata = clamp(convert_int_sat(ceil(span.angle * (most / M_PI_F))), 1, most);
  const float share = span.integral / strata;  // of G, a sample's
  for (int n = 0; n < strata; ++n) {
    const float delay = sq_light_span_point(&span, (n + sq_uniform(rng)) / strata);
    const float3 x = entry + (t0 + delay) * dir;
    float dist, scale;
    const float3 nl = sq_to_light(p, i, x, &dist, &scale);
    const float lit = share * sq_phase_toward(p, dir, nl), column = sq_light_column(v, dsm, p, i, x, nl, dist, rng);
    for (int w = 0; w < p->n_wavelengths; ++w)
      own[w] += p->lights[i].intensity[w] * lit * exp(-p->extinction[w] * (column + rho * delay));
  }
}

// Pixel (px, py) of the image into out: channel-major planes of width*height floats: radiance per
// wavelength (n_wavelengths planes), transmittance per wavelength (n_wavelengths), then depth (the distance
// in m at which the transmittance of the first wavelength falls below 0.5; -1 where it never does).
static void sq_render_pixel(int px, int py, __global const uint* density, __global const uint* interior,
                            __global const uint* temperature,
                            __global const float* dsm, CloudRenderParams p, __global float* out) {
  size_t pixel = (size_t)py * p.width + px;
  size_t plane = (size_t)p.width * p.height;
  int nw = p.n_wavelengths;
  float aspect = (float)p.width / (float)p.height;
  float sx = (2.0f * (px + 0.5f) / p.width - 1.0f) * p.tan_half_fov_y * aspect;
  float sy = (1.0f - 2.0f * (py + 0.5f) / p.height) * p.tan_half_fov_y;
  float3 eye = (float3)(p.eye[0], p.eye[1], p.eye[2]);
  float3 dir = normalize((float3)(p.forward[0], p.forward[1], p.forward[2]) +
                         sx * (float3)(p.right[0], p.right[1], p.right[2]) + sy * (float3)(p.up[0], p.up[1], p.up[2]));
  float L[SQUALL_CLOUD_MAX_WAVELENGTHS], T[SQUALL_CLOUD_MAX_WAVELENGTHS];
  float lost_T[SQUALL_CLOUD_MAX_WAVELENGTHS];  // sq_attenuate's
  for (int w = 0; w < nw; ++w) {
    L[w] = 0.0f;
    T[w] = 1.0f;
    lost_T[w] = 0.0f;
  }
  float depth = -1.0f;
  uint rng = sq_hash((uint)pixel ^ sq_hash((uint)p.seed));
  VdbVolume v = sq_volume_open(density, interior);
  VdbVolume tv = sq_volume_open(p.has_temperature ? temperature : density, 0);
  float3 o = sq_world_to_index(&v, eye) + 0.5f;
  float3 d = sq_world_to_index_dir(&v, dir);
  float base = 0.0f, t0, t1;  // the march counts t from the ray's entry into the volume, base from the eye
  bool hit = sq_clip_root_from_entry(&v, &o, d, &base, &t0, &t1);
  const float3 entry = sq_index_to_world(&v, o - 0.5f);  // world point at t = 0
  float nudge = 1e-4f / length(d);
  float3 inv_d = 1.0f / d;
  float r[SQUALL_CLOUD_MAX_SUBSTEPS + 1];
  int ns = clamp(p.substeps, 1, SQUALL_CLOUD_MAX_SUBSTEPS);
  bool done = !hit;
  for (float t = t0; !done && t < t1;) {
    VdbNode node;
    bool occupied = sq_node(&v, o, d, inv_d, t, nudge, &node);
    float exit = fmin(node.exit, t1);
    for (float s = t; occupied && !done && s < exit;) {
      float h = sq_float_step(s, fmin(p.step, exit - s));
      sq_substep_offsets(ns, &rng, r);
      for (int j = 1; j <= ns; ++j) {
        float len = (r[j] - r[j - 1]) * h;
        float at = s + (r[j - 1] + sq_uniform(&rng) * (r[j] - r[j - 1])) * h;
        float3 c = o + at * d;
        float rho = sq_node_density(&v, &node, c, p.interpolation);
        if (!(rho > 0.0f) || len <= 0.0f) continue;
        float3 x = entry + at * dir;
        float temp = p.has_temperature ? sq_sample(&tv, c - 0.5f, p.interpolation) : 0.0f;
        // Directional lights: irradiance scale, phase and column density toward each from x. Point lights:
        // their in-scatter over the sub-step, per wavelength (sq_point_light_inscatter).
        float irr[SQUALL_CLOUD_MAX_LIGHTS], phase[SQUALL_CLOUD_MAX_LIGHTS], column[SQUALL_CLOUD_MAX_LIGHTS];
        float own[SQUALL_CLOUD_MAX_WAVELENGTHS];
        for (int w = 0; w < nw; ++w) own[w] = 0.0f;
        for (int i = 0; i < p.n_lights; ++i) {
          if (p.lights[i].kind == SQUALL_LIGHT_POINT) {
            sq_point_light_inscatter(&v, dsm, &p, i, entry, dir, s + r[j - 1] * h, len, rho, &rng, own);
            continue;
          }
          float dist;
          float3 nl = sq_to_light(&p, i, x, &dist, &irr[i]);
          phase[i] = sq_phase_toward(&p, dir, nl);
          column[i] = sq_light_column(&v, dsm, &p, i, x, nl, dist, &rng);
        }
        for (int w = 0; w < nw; ++w) {
          float kappa = p.extinction[w];
          float opacity = sq_opacity(kappa * rho * len);               // 1 - dT (A.26)
          float weight = kappa > 0.0f ? opacity / kappa : rho * len;  // (1 - dT)/kappa
          float ci = 0.0f;
          for (int i = 0; i < p.n_lights; ++i)
            if (p.lights[i].kind != SQUALL_LIGHT_POINT)
              ci += p.lights[i].intensity[w] * irr[i] * exp(-kappa * column[i]) * phase[i];              // A.4, A.7
          float ct = p.albedo[w] * kappa * ci;                                                           // C^S C^I
          if (p.has_temperature) ct += (1.0f - p.albedo[w]) * kappa * blackbody(p.wavelength[w], temp);  // C^E
          L[w] += ct * T[w] * weight;                                                                    // A.24 (L +=)
          if (own[w] > 0.0f) L[w] += p.albedo[w] * kappa * own[w] * rho * T[w];
          sq_attenuate(&T[w], &lost_T[w], opacity);                                                      // A.25
        }
        if (depth < 0.0f && T[0] < 0.5f) depth = base + at;
      }
      s += h;
      float tmax = 0.0f;
      for (int w = 0; w < nw; ++w) tmax = fmax(tmax, T[w]);
      done = tmax < p.min_transmittance;
    }
    t = exit;
  }
  for (int w = 0; w < nw; ++w) {
    out[w * plane + pixel] = L[w];
    out[(nw + w) * plane + pixel] = T[w];
  }
  out[2 * nw * plane + pixel] = depth;
}

// The kernels: an entry of the map, or a pixel, per work-item (a GPU's way); or, on a CPU device, a
// work-item per thread, each taking runs of SQ_SHARED_RUN entries or pixels from a counter the work-items
// share (*next, 0 at launch), so that the threads share the work however unevenly its cost is spread
// (PoCL's pthread device deals each thread a fixed run of work-groups: on two threads 64, or half of what
// is left of a small launch). A run takes one atomic add for 8 items (a tile's row of pixels).
#define SQ_SHARED_RUN 8u

__kernel void cloud_shadow_map(__global const uint* density, __global const uint* interior, CloudRenderParams p,
                               __global const uchar* needed, __global float* dsm) {
  sq_shadow_map_entry(get_global_id(0), density, interior, &p, needed, dsm);
}

// Entries first .. first + count - 1 of the map.
__kernel void cloud_shadow_map_shared(__global const uint* density, __global const uint* interior,
                                      CloudRenderParams p, __global const uchar* needed, __global float* dsm,
                                      uint first, uint count, volatile __global uint* next) {
  for (uint run = atomic_add(next, SQ_SHARED_RUN); run < count; run = atomic_add(next, SQ_SHARED_RUN))
    for (uint i = run; i < min(run + SQ_SHARED_RUN, count); ++i)
      sq_shadow_map_entry(first + i, density, interior, &p, needed, dsm);
}

__kernel void cloud_render(__global const uint* density, __global const uint* interior,
                           __global const uint* temperature, __global const float* dsm, CloudRenderParams p,
                           __global float* out) {
  int px = get_global_id(0), py = get_global_id(1);
  if (px < p.width && py < p.height) sq_render_pixel(px, py, density, interior, temperature, dsm, p, out);
}

// The pixels of tiles first_tile .. first_tile + tiles - 1 of the image's 8x8 tiles (row order, tiles_x a
// row).
__kernel void cloud_render_shared(__global const uint* density, __global const uint* interior,
                                  __global const uint* temperature, __global const float* dsm, CloudRenderParams p,
                                  __global float* out, uint first_tile, uint tiles, uint tiles_x,
                                  volatile __global uint* next) {
  for (uint run = atomic_add(next, SQ_SHARED_RUN); run < tiles * 64; run = atomic_add(next, SQ_SHARED_RUN))
    for (uint i = run; i < min(run + SQ_SHARED_RUN, tiles * 64); ++i) {
      const uint tile = first_tile + i / 64, k = i % 64;
      const int px = (tile % tiles_x) * 8 + k % 8, py = (tile / tiles_x) * 8 + k / 8;
      if (px < p.width && py < p.height) sq_render_pixel(px, py, density, interior, temperature, dsm, p, out);
    }
}
