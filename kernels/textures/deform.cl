/* Content-aware texture deformation (G. Guingo, F. Larue, B. Sauvage, N. Lutz, J.-M. Dischler, M.-P. Cani,
 * "Content-aware texture deformation with dynamic control", Computers & Graphics 91, 2020).
 *
 * Texture space in texels: texel (i, j) has its centre at (i + 0.5, j + 0.5) and index t = i + W j. Every
 * per-texel buffer is x fastest, one value (or one float2) per texel:
 *   flow      float2 [W H]   v, texels per unit of d mu (0 on the fixed texels)
 *   warp      float2 [W H]   w = W_t(u) - u
 *   reference float  [W H]   t*, the texel's sum of d mu (eq. 11)
 *   residual  float2 [W H]   w* = W*_r(u) - u, the stack's residual warp (eq. 12)
 *   level     int    [W H]   h, the stack level in -L..L
 *   images    float  [(2L + 1) channels W H]   level h + L, then channel, then texel; level 0 is C itself
 * The flow solve works on `real` (double where the device has fp64): texel vectors real2 [W H], dual-cell
 * vectors real [(W - 1)(H - 1)], cell (i, j) between texels i, i + 1 and j, j + 1. */
#ifdef cl_khr_fp64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double real;
typedef double2 real2;
#else
typedef float real;
typedef float2 real2;
#endif

/* Items per work-item of the reductions (kDeformChunk on the host). */
#define DEFORM_CHUNK 64

/* DeformControlKind on the host. */
#define DEFORM_CONSTANT 0
#define DEFORM_MAP 1
#define DEFORM_ISOTROPIC 2
#define DEFORM_ANISOTROPIC 3
#define DEFORM_BRUSH 4

/* ---- Flow solve: min |D v - R_dual|^2 over the free texels by CGLS (sec. 4, eq. 6) ---- */

__kernel void deform_real_bytes(__global int* out) { out[0] = (int)sizeof(real); }

/* q = D p on the dual cells, eq. 6 discretized at h = 1 texel:
 *   div = [(vx[i+1,j] + vx[i+1,j+1]) - (vx[i,j] + vx[i,j+1])] / 2 + [(vy[i,j+1] + vy[i+1,j+1]) - (vy[i,j] + vy[i+1,j])] / 2
 * partial[c + chunks j] = the sum of q^2 over the chunk c of row j. */
__kernel void deform_cgls_d(__global const real2* p, __global real* q, int width, int height, __global real* partial) {
  const int c = get_global_id(0), j = get_global_id(1);
  const int cells = width - 1, chunks = (cells + DEFORM_CHUNK - 1) / DEFORM_CHUNK;
  if (c >= chunks || j >= height - 1) return;
  const real one_half = (real)0.5;
  real sum = 0;
  for (int i = c * DEFORM_CHUNK; i < min((c + 1) * DEFORM_CHUNK, cells); ++i) {
    const real2 a = p[i + width * j], b = p[i + 1 + width * j];
    const real2 d = p[i + width * (j + 1)], e = p[i + 1 + width * (j + 1)];
    const real div = one_half * ((b.x + e.x) - (a.x + d.x)) + one_half * ((d.y + e.y) - (a.y + b.y));
    q[i + cells * j] = div;
    sum += div * div;
  }
  partial[c + chunks * j] = sum;
}

/* s = D^T r on the free texels (0 on the fixed ones, which are never on the border); partial per chunk of
 * a row holds the sum of |s|^2. */
__kernel void deform_cgls_dt(__global const real* r, __global const uchar* free_texel, __global real2* s, int width,
                             int height, __global real* partial) {
  const int c = get_global_id(0), j = get_global_id(1);
  const int cells = width - 1, chunks = (width + DEFORM_CHUNK - 1) / DEFORM_CHUNK;
  if (c >= chunks || j >= height) return;
  const real one_half = (real)0.5;
  real sum = 0;
  for (int i = c * DEFORM_CHUNK; i < min((c + 1) * DEFORM_CHUNK, width); ++i) {
    const int t = i + width * j;
    real2 g = (real2)(0, 0);
    if (free_texel[t]) {
      const real a = r[i - 1 + cells * (j - 1)], b = r[i + cells * (j - 1)];
      const real d = r[i - 1 + cells * j], e = r[i + cells * j];
      g = (real2)(one_half * ((a + d) - (b + e)), one_half * ((a + b) - (d + e)));
    }
    s[t] = g;
    sum += g.x * g.x + g.y * g.y;
  }
  partial[c + chunks * j] = sum;
}

/* y += a x over n reals; a = hi + lo (a double split in two floats). */
__kernel void deform_cgls_axpy(__global real* y, __global const real* x, float2 a, int n) {
  const int k = get_global_id(0);
  if (k < n) y[k] += ((real)a.x + (real)a.y) * x[k];
}

/* p = s + b p over n reals; b = hi + lo. */
__kernel void deform_cgls_xpby(__global real* p, __global const real* s, float2 b, int n) {
  const int k = get_global_id(0);
  if (k < n) p[k] = s[k] + ((real)b.x + (real)b.y) * p[k];
}

__kernel void deform_flow_store(__global const real2* x, __global float2* flow, int n) {
  const int t = get_global_id(0);
  if (t < n) flow[t] = (float2)((float)x[t].x, (float)x[t].y);
}

/* ---- Sampling ---- */

/* a (1 - f) + b f: exactly a at f = 0 and b at f = 1, so a texel centre reads its own value bitwise. */
static float lerp1(float a, float b, float f) { return a * (1.0f - f) + b * f; }
static float2 lerp2(float2 a, float2 b, float f) { return a * (1.0f - f) + b * f; }

/* The bilinear cell of position p (texels), clamped at the texture's border: base texel and fractions. */
static int2 cell_of(float2 p, int width, int height, float2* f) {
  const float x = clamp(p.x - 0.5f, 0.0f, (float)(width - 1)), y = clamp(p.y - 0.5f, 0.0f, (float)(height - 1));
  const int i = min((int)x, width - 2), j = min((int)y, height - 2);
  *f = (float2)(x - (float)i, y - (float)j);
  return (int2)(i, j);
}

static float2 flow_at(__global const float2* flow, int width, int height, float2 p) {
  float2 f;
  const int2 c = cell_of(p, width, height, &f);
  const int t = c.x + width * c.y;
  return lerp2(lerp2(flow[t], flow[t + 1], f.x), lerp2(flow[t + width], flow[t + width + 1], f.x), f.y);
}

static float plane_at(__global const float* plane, int width, int height, float2 p) {
  float2 f;
  const int2 c = cell_of(p, width, height, &f);
  const int t = c.x + width * c.y;
  return lerp1(lerp1(plane[t], plane[t + 1], f.x), lerp1(plane[t + width], plane[t + width + 1], f.x), f.y);
}

static float2 centre_of(int t, int width) { return (float2)((float)(t % width) + 0.5f, (float)(t / width) + 0.5f); }

/* ---- Per frame ---- */

/* d mu of texel t (sec. 5). `tensor` is T - I as (xx, xy, yx, yy); kappa includes the paper's dt when asked. */
static float d_mu_of(int t, float2 u, float2 w, __global const float2* flow, int width, int height, int kind,
                     float d_mu, float kappa, float4 tensor, __global const float* map, __global const float4* strokes,
                     int stroke_count) {
  if (kind == DEFORM_MAP) return kappa * map[t];
  if (kind == DEFORM_BRUSH) {
    float sum = 0.0f;
    for (int k = 0; k < stroke_count; ++k) {
      const float2 d = u - strokes[k].xy;
      sum += strokes[k].w * exp(-dot(d, d) / (2.0f * strokes[k].z * strokes[k].z)); /* sec. 5.2 */
    }
    return sum;
  }
  if (kind == DEFORM_ANISOTROPIC) { /* eq. 8: kappa log(vb^T T vb), vb = v(W(u)) / |v(W(u))| */
    float2 vb = flow_at(flow, width, height, u + w);
    const float norm = length(vb);
    if (norm < 1e-6f) return 0.0f;
    vb /= norm;
    const float q1 = vb.x * (tensor.x * vb.x + tensor.y * vb.y) + vb.y * (tensor.z * vb.x + tensor.w * vb.y);
    return q1 > -1.0f ? kappa * log1p(q1) : 0.0f; /* vb^T T vb = 1 + q1 must be > 0 */
  }
  return d_mu; /* constant, and isotropic (eq. 7) computed on the host */
}

/* One frame of every texel: d mu from the control, then `substeps` explicit Euler steps of eq. 5,
 * w += (d mu / S) v(u + w), and t* += d mu (eq. 11). With the stack (levels = L > 0) the residual takes the
 * same steps from the unwarped u, and the level follows t* (App. B): h + 1 once t* >= h + 1, h - 1 once
 * t* <= h - 1, then w* = (t* - h) v(u); h stays in -L..L, past which the residual keeps growing. */
__kernel void deform_step(__global const float2* flow, int width, int height, __global float2* warp,
                          __global float* reference, int substeps, int kind, float d_mu, float kappa, float4 tensor,
                          __global const float* map, __global const float4* strokes, int stroke_count, int levels,
                          __global float2* residual, __global int* level) {
  const int t = get_global_id(0);
  if (t >= width * height) return;
  const float2 u = centre_of(t, width);
  float2 w = warp[t];
  const float mu = d_mu_of(t, u, w, flow, width, height, kind, d_mu, kappa, tensor, map, strokes, stroke_count);
  const float h = mu / (float)substeps;
  for (int s = 0; s < substeps; ++s) w += h * flow_at(flow, width, height, u + w); /* eq. 5 */
  warp[t] = w;
  const float ts = reference[t] + mu;
  reference[t] = ts;
  if (levels == 0) return;
  float2 r = residual[t];
  for (int s = 0; s < substeps; ++s) r += h * flow_at(flow, width, height, u + r);
  int l = level[t];
  const int before = l;
  while (ts >= (float)(l + 1) && l < levels) ++l;
  while (ts <= (float)(l - 1) && l > -levels) --l;
  if (l != before) r = (ts - (float)l) * flow[t];
  residual[t] = r;
  level[t] = l;
}

/* The colour planes: C(u + w) without the stack, C_h(u + w*) with it (eqs. 13-14), bilinear, clamped at the
 * border. images: the stack (level h at h + L), or C alone when levels = 0. */
__kernel void deform_color(__global const float* images, int channels, int width, int height,
                           __global const float2* warp, int levels, __global const float2* residual,
                           __global const int* level, __global float* out) {
  const int t = get_global_id(0);
  const int n = width * height;
  if (t >= n) return;
  const float2 u = centre_of(t, width);
  const int h = levels > 0 ? level[t] + levels : 0;
  const float2 p = u + (levels > 0 ? residual[t] : warp[t]);
  __global const float* src = images + (size_t)h * (size_t)channels * (size_t)n;
  for (int c = 0; c < channels; ++c) out[(size_t)c * n + t] = plane_at(src + (size_t)c * n, width, height, p);
}

/* The resampling stack (sec. 6.1, eqs. 9-10): C_h(u) = C(W*_h(u)), W*_h the flow of v for a reference time h
 * from u (backward for h < 0), `steps` midpoint (RK2) steps per unit. Level 0 (at index L) is C. */
__kernel void deform_stack_build(__global const float2* flow, int width, int height, int channels, int levels,
                                 int steps, __global float* images) {
  const int t = get_global_id(0);
  const int n = width * height;
  if (t >= n) return;
  __global const float* base = images + (size_t)levels * (size_t)channels * (size_t)n;
  for (int dir = -1; dir <= 1; dir += 2) {
    const float ds = (float)dir / (float)steps;
    float2 p = centre_of(t, width);
    for (int k = 1; k <= levels; ++k) {
      for (int s = 0; s < steps; ++s) {
        const float2 mid = p + 0.5f * ds * flow_at(flow, width, height, p);
        p += ds * flow_at(flow, width, height, mid);
      }
      __global float* dst = images + (size_t)(levels + dir * k) * (size_t)channels * (size_t)n;
      for (int c = 0; c < channels; ++c) dst[(size_t)c * n + t] = plane_at(base + (size_t)c * n, width, height, p);
    }
  }
}

/* Per chunk of DEFORM_CHUNK texels: (max |w|, max |w*|, min t*, max t*); |w*| is |w| without the stack. */
__kernel void deform_stats(__global const float2* warp, __global const float2* residual,
                           __global const float* reference, int n, int levels, __global float4* partial) {
  const int c = get_global_id(0);
  if (c * DEFORM_CHUNK >= n) return;
  float4 m = (float4)(0.0f, 0.0f, INFINITY, -INFINITY);
  for (int t = c * DEFORM_CHUNK; t < min((c + 1) * DEFORM_CHUNK, n); ++t) {
    const float warp_norm = length(warp[t]);
    m.x = max(m.x, warp_norm);
    m.y = max(m.y, levels > 0 ? length(residual[t]) : warp_norm);
    m.z = min(m.z, reference[t]);
    m.w = max(m.w, reference[t]);
  }
  partial[c] = m;
}
