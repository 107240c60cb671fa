// squall-build-options: -cl-single-precision-constant
// The spectral ocean (J. Tessendorf, "Gilligan: A Prototype Framework for Simulating and Rendering Maritime
// Environments" (2017), sec. 2 and 5.3.3, and its App. A, J. Tessendorf, "Simulating Ocean Water", sec.
// 4.3-4.6; bare equation numbers below are Gilligan's, "App A eq" ones the course notes'). Grid and sign
// conventions: server/ocean/ocean_params.h. Per layer: ocean_h0 (cached), then per frame ocean_evolveN -> inverse FFTs
// -> ocean_accumulate onto the output grid (a first layer on that grid is the sum as its FFT leaves it); then
// ocean_finalize derives the requested outputs.
#include "common/dispersion.h"
#include "common/sincos.h"
#include "common/surface_normal.h"
#include "ocean/params.h"
#include "ocean/spectra.h"

// Spectral channels, packed in pairs (re, im) of complex arrays for C2C inverse FFTs, in one of two layouts:
//   displaced:   pair 0: h, Dx        pair 1: Dy, eps_x      pair 2: eps_y, dDx/dx     pair 3: dDy/dy, dDx/dy
//   undisplaced: pair 0: h, eps_x     pair 1: eps_y, dDx/dx  pair 2: dDy/dy, dDx/dy
// with D = sum i k/|k| h~ e^{ik.x} (crest-sharpening sign for lambda > 0) and eps = grad h (App A eq 37).
// A tile that returns no displacement needs no Dx and Dy (the normals and J need only their derivatives):
// the undisplaced layout transforms one pair fewer.

// ---- counter-based Gaussian amplitudes, keyed by (seed, layer, n, m) ----
inline ulong mix64(ulong z) {  // splitmix64 finalizer
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9UL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBUL;
  return z ^ (z >> 31);
}

// Two independent N(0,1) numbers: Box-Muller of two uniforms ((b >> 41) + 1/2) 2^-23 in (0, 1) (23-bit
// integers plus a half: exact in float, so host and device draw identical uniforms).
inline float2 gaussian_pair(ulong seed, int layer, int n, int m) {
  ulong a = mix64(seed ^ mix64(0x9E3779B97F4A7C15UL * (ulong)(layer + 1)));
  ulong b = mix64(a ^ (((ulong)(uint)n << 32) | (ulong)(uint)m));
  ulong c = mix64(b + 0x9E3779B97F4A7C15UL);
  float u1 = ((float)(uint)(b >> 41) + 0.5f) * 0x1.0p-23f;
  float u2 = ((float)(uint)(c >> 41) + 0.5f) * 0x1.0p-23f;
  float r = sqrt(-2.0f * log(u1));
  float phi = 2.0f * (float)SQUALL_PI * u2;
  return (float2)(r * cos(phi), r * sin(phi));
}

inline SpectrumParams spectrum_of(__global const OceanLayer* L) {
  SpectrumParams p;
  p.spectrum = L->spectrum;
  p.spreading = L->spreading;
  p.partials = L->partials;
  p.pad = 0;
  p.g = L->g;
  p.wind_speed = L->wind_speed;
  p.alpha = L->alpha;
  p.omega_p = L->omega_p;
  p.gamma = L->gamma;
  p.sigma_a = L->sigma_a;
  p.sigma_b = L->sigma_b;
  p.depth = L->depth;
  p.theta0 = L->theta0;
  p.omega_mean = L->omega_mean;
  p.phillips_amplitude = L->phillips_amplitude;
  p.phillips_length = L->phillips_length;
  p.phillips_cutoff = L->phillips_cutoff;
  p.phillips_exponent = L->phillips_exponent;
  for (int i = 0; i < SQUALL_MAX_PARTIALS; ++i) {
    p.partial_omega_p[i] = L->partial_omega_p[i];
    p.partial_scale[i] = L->partial_scale[i];
    p.partial_a[i] = L->partial_a[i];
    p.partial_b[i] = L->partial_b[i];
    p.partial_c[i] = L->partial_c[i];
    p.partial_n[i] = L->partial_n[i];
    p.partial_m[i] = L->partial_m[i];
  }
  return p;
}

// Signed mode number of array index i on an n-point axis: -n/2 < mode < n/2, and -n/2 at i = n/2 (Nyquist).
inline int mode_number(int i, int n) { return i < n / 2 ? i : i - n; }

// B(k) of eq 56 (the count of layers whose band holds k: sec. 2.6 calls it the square of that number, but
// with Pi = 0 or 1 eq 56 is the count).
inline float band_count(float kx, float ky, __global const float4* bands, int nbands) {
  float count = 0.0f;
  float ax = fabs(kx), ay = fabs(ky);
  for (int a = 0; a < nbands; ++a) {
    float4 b = bands[a];
    int inside = ax < b.z && ay < b.w && !(ax < b.x && ay < b.y);
    count += inside ? 1.0f : 0.0f;
  }
  return count;
}

// The spectrum of a layer, planar: H0_PLANES planes of nx * ny floats, mode (i, j) at i + nx * j of each, so
// that mode_phase reads every value of a mode with one wide load per plane (a record of four floats, or
// the mode of -k at a mirrored index, would be an AVX-512 gather on a CPU device).
#define H0_RE 0        // Re h0(k)
#define H0_IM 1        // Im h0(k)
#define H0_FREQUENCY_HI 2  // f(k) = omega(k) / 2 pi = hi + lo, turns per second, from the host in double
#define H0_FREQUENCY_LO 3  // (mode_frequencies in server/ocean/spectrum_setup.h)
#define H0_MINUS_RE 4      // Re h0(-k)
#define H0_MINUS_IM 5      // Im h0(-k)
#define H0_PLANES 6

// h0(k) of App A eq 42, with the discrete normalization sqrt(P dkx dky / 2) and B(k)^-1/2 (eq 57): planes H0_RE
// and H0_IM (ocean_h0_mirror fills H0_MINUS_RE and H0_MINUS_IM, the host the frequency planes).
__kernel void ocean_h0(__global const OceanLayer* layer, __global const float4* bands, const int nbands,
                       __global float* h0) {
  int i = get_global_id(0), j = get_global_id(1);
  int nx = layer->nx, ny = layer->ny;
  if (i >= nx || j >= ny) return;
  int n = mode_number(i, nx), m = mode_number(j, ny);
  float kx = n * layer->dkx, ky = m * layer->dky;
  float k = sqrt(kx * kx + ky * ky);
  Dispersion d = layer->dispersion;
  float w = dispersion_omega(k, d);
  float cell_a, cell_b;  // the mode's angular cell
  sq_mode_cell(kx, ky, layer->dkx, layer->dky, &cell_a, &cell_b);
  float P = sq_spatial_spectrum(spectrum_of(layer), kx, ky, w, dispersion_group_velocity(k, d), cell_a, cell_b);
  int nyquist = (2 * i == nx) || (2 * j == ny);  // the Nyquist row and column stay 0
  int outside = k < layer->k_min || (layer->k_max > 0.0f && k > layer->k_max);
  if (nyquist || outside || !(P > 0.0f)) P = 0.0f;
  if (nbands > 0 && P > 0.0f) {
    float B = band_count(kx, ky, bands, nbands);
    P = B > 0.0f ? P / B : 0.0f;
  }
  ulong seed = ((ulong)layer->seed_hi << 32) | (ulong)layer->seed_lo;
  float2 xi = gaussian_pair(seed, layer->layer_index, n, m);
  float amplitude = sqrt(0.5f * P * layer->dkx * layer->dky);
  size_t at = i + (size_t)nx * j, cells = (size_t)nx * ny;
  h0[H0_RE * cells + at] = xi.x * amplitude;
  h0[H0_IM * cells + at] = xi.y * amplitude;
}

// Planes H0_MINUS_RE and H0_MINUS_IM: h0 of the mode of -k, stored at k.
__kernel void ocean_h0_mirror(__global float* h0, const int nx, const int ny) {
  int i = get_global_id(0), j = get_global_id(1);
  if (i >= nx || j >= ny) return;
  int mi = i == 0 ? 0 : nx - i, mj = j == 0 ? 0 : ny - j;
  size_t at = i + (size_t)nx * j, minus = mi + (size_t)nx * mj, cells = (size_t)nx * ny;
  h0[H0_MINUS_RE * cells + at] = h0[H0_RE * cells + minus];
  h0[H0_MINUS_IM * cells + at] = h0[H0_IM * cells + minus];
}

// Stores a + i b for two Hermitian spectra a, b at `at` of a float2 array: the inverse FFT then gives
// the two real fields in (re, im).
inline void store_pack(__global float* out, size_t at, float a_re, float a_im, float b_re, float b_im) {
  out[2 * at] = a_re - b_im;
  out[2 * at + 1] = a_im + b_re;
}

// Mode `at` of h0: a = h0(k) and b = h0(-k) as (re, im), and its phase wt at time t = t_hi + t_lo as c = cos wt,
// s = sin wt, w = 2 pi f(k). The phases are counted in turns (common/sincos.h): f t with f = f_hi + f_lo and
// t = t_hi + t_lo, two floats each. Complex values are pairs of floats, read and written as floats: PoCL
// vectorizes a kernel across work-items only when it computes with no OpenCL vector (float2, float4) values,
// which LLVM's loop vectorizer cannot widen (nor a struct of two floats, passed as a float2).
__attribute__((always_inline)) static void mode_phase(__global const float* h0, size_t at, size_t cells, float t_hi,
                                                      float t_lo, float* a_re, float* a_im, float* b_re, float* b_im,
                                                      float* c, float* s, float* w) {
  *a_re = h0[H0_RE * cells + at], *a_im = h0[H0_IM * cells + at];
  *b_re = h0[H0_MINUS_RE * cells + at], *b_im = h0[H0_MINUS_IM * cells + at];
  float f_hi = h0[H0_FREQUENCY_HI * cells + at], f_lo = h0[H0_FREQUENCY_LO * cells + at];
  *w = f_hi * (2.0f * M_PI_F);
  sq_sincos_turns(f_hi, f_lo, t_hi, t_lo, s, c);
}

// (re, im) times e^{-i k.U_D t}, the drift U_D's shift of mode (i, j): k.U_D t / 2 pi = n s.x + m s.y turns for
// the mode numbers (n, m) and the shift s = U_D t / (Lx, Ly) in periods of the layer, reduced to [0, 1] on the
// host. Nothing where there is no drift.
__attribute__((always_inline)) static void drift(int i, int j, int nx, int ny, float2 shift, float* re, float* im) {
  const float shift_x = shift.x, shift_y = shift.y;
  if (shift_x == 0.0f && shift_y == 0.0f) return;  // the same for every work-item: most layers have no drift
  float shift_c, shift_s;
  float turns = sq_product_turns((float)mode_number(i, nx), shift_x) +  // k.U_D t / 2 pi
                sq_product_turns((float)mode_number(j, ny), shift_y);
  sq_sincos_turn(-turns, &shift_s, &shift_c);  // -k.U_D t
  float rotated_re = *re * shift_c - *im * shift_s;
  *im = *re * shift_s + *im * shift_c, *re = rotated_re;
}

// The two halves of mode (i, j) of eq 1 / 43 at time t = t_hi + t_lo, shifted by the drift U_D:
// plus = h0(k) e^{-iwt} e^{-i k.U_D t} and minus = conj(h0(-k)) e^{iwt} e^{-i k.U_D t}, as (re, im).
__attribute__((always_inline)) static void evolve_halves(__global const float* h0, int i, int j, int nx, int ny,
                                                         float t_hi, float t_lo, float2 shift, float* plus_re,
                                                         float* plus_im, float* minus_re, float* minus_im, float* w) {
  float a_re, a_im, b_re, b_im, c, s;
  mode_phase(h0, i + (size_t)nx * j, (size_t)nx * ny, t_hi, t_lo, &a_re, &a_im, &b_re, &b_im, &c, &s, w);
  *plus_re = a_re * c + a_im * s, *plus_im = a_im * c - a_re * s;    // (a_re + i a_im)(c - i s)
  *minus_re = b_re * c + b_im * s, *minus_im = b_re * s - b_im * c;  // (b_re - i b_im)(c + i s)
  drift(i, j, nx, ny, shift, plus_re, plus_im);
  drift(i, j, nx, ny, shift, minus_re, minus_im);
}

// h~(k, t) of eq 1 / 43, plus + minus of evolve_halves summed before the products: the same sum in fewer
// operations, and none that LLVM's SLP vectorizer pairs into float2 values ahead of PoCL's work-item
// vectorization (as it paired plus_re with minus_re where only h is stored).
__attribute__((always_inline)) static void evolve_height(__global const float* h0, int i, int j, int nx, int ny,
                                                         float t_hi, float t_lo, float2 shift, float* h_re,
                                                         float* h_im) {
  float a_re, a_im, b_re, b_im, c, s, w;
  mode_phase(h0, i + (size_t)nx * j, (size_t)nx * ny, t_hi, t_lo, &a_re, &a_im, &b_re, &b_im, &c, &s, &w);
  *h_re = (a_re + b_re) * c + (a_im + b_im) * s, *h_im = (a_im - b_im) * c - (a_re - b_re) * s;
  drift(i, j, nx, ny, shift, h_re, h_im);
}

// Eq 1 / 43 at absolute time t: h~(k,t) (evolve_height), and its derived channels, packed
// into `pairs` complex arrays of nx*ny each, in the displaced or the undisplaced layout. t = t_hi + t_lo
// (two floats). Kernels ocean_evolve1 to 4 (displaced) and ocean_evolve_undisplaced2 and 3 run it with
// `pairs` and `displaced` constants, launched over exactly nx x ny work-items: with no store under a
// condition, the packed stores vectorize as wide stores, not as scatters.
__attribute__((always_inline)) static void evolve_pairs(__global const float* h0, int nx, int ny, float dkx, float dky,
                                                        float t_hi, float t_lo, float2 shift, const int pairs,
                                                        const int displaced, __global float* outf) {
  int i = get_global_id(0), j = get_global_id(1);
  float kx = mode_number(i, nx) * dkx, ky = mode_number(j, ny) * dky;
  float h_re, h_im;
  evolve_height(h0, i, j, nx, ny, t_hi, t_lo, shift, &h_re, &h_im);
  float k = sqrt(kx * kx + ky * ky);
  float inv_k = k > 0.0f ? 1.0f / k : 0.0f;
  size_t cells = (size_t)nx * ny, at = i + (size_t)nx * j;
  float kx_k = kx * inv_k, ky_k = ky * inv_k;
  float xx = -kx * kx_k, yy = -ky * ky_k, xy = -kx * ky_k;
  // i h times each factor: (-h_im, h_re) f
  if (displaced) {
    store_pack(outf, at, h_re, h_im, -h_im * kx_k, h_re * kx_k);                                     // h, D_x
    if (pairs > 1) store_pack(outf, cells + at, -h_im * ky_k, h_re * ky_k, -h_im * kx, h_re * kx);  // D_y, eps_x
    if (pairs > 2) store_pack(outf, 2 * cells + at, -h_im * ky, h_re * ky, h_re * xx, h_im * xx);  // eps_y, D_xx
    if (pairs > 3) store_pack(outf, 3 * cells + at, h_re * yy, h_im * yy, h_re * xy, h_im * xy);   // D_yy, D_xy
  } else {
    store_pack(outf, at, h_re, h_im, -h_im * kx, h_re * kx);                                     // h, eps_x
    if (pairs > 1) store_pack(outf, cells + at, -h_im * ky, h_re * ky, h_re * xx, h_im * xx);  // eps_y, D_xx
    if (pairs > 2) store_pack(outf, 2 * cells + at, h_re * yy, h_im * yy, h_re * xy, h_im * xy);  // D_yy, D_xy
  }
}

__kernel void ocean_evolve1(__global const float* h0, const int nx, const int ny, const float dkx, const float dky,
                            const float t_hi, const float t_lo, const float2 shift, __global float* out) {
  evolve_pairs(h0, nx, ny, dkx, dky, t_hi, t_lo, shift, 1, 1, out);
}
__kernel void ocean_evolve2(__global const float* h0, const int nx, const int ny, const float dkx, const float dky,
                            const float t_hi, const float t_lo, const float2 shift, __global float* out) {
  evolve_pairs(h0, nx, ny, dkx, dky, t_hi, t_lo, shift, 2, 1, out);
}
__kernel void ocean_evolve3(__global const float* h0, const int nx, const int ny, const float dkx, const float dky,
                            const float t_hi, const float t_lo, const float2 shift, __global float* out) {
  evolve_pairs(h0, nx, ny, dkx, dky, t_hi, t_lo, shift, 3, 1, out);
}
__kernel void ocean_evolve4(__global const float* h0, const int nx, const int ny, const float dkx, const float dky,
                            const float t_hi, const float t_lo, const float2 shift, __global float* out) {
  evolve_pairs(h0, nx, ny, dkx, dky, t_hi, t_lo, shift, 4, 1, out);
}

__kernel void ocean_evolve_undisplaced2(__global const float* h0, const int nx, const int ny, const float dkx,
                                         const float dky, const float t_hi, const float t_lo, const float2 shift,
                                         __global float* out) {
  evolve_pairs(h0, nx, ny, dkx, dky, t_hi, t_lo, shift, 2, 0, out);
}
__kernel void ocean_evolve_undisplaced3(__global const float* h0, const int nx, const int ny, const float dkx,
                                         const float dky, const float t_hi, const float t_lo, const float2 shift,
                                         __global float* out) {
  evolve_pairs(h0, nx, ny, dkx, dky, t_hi, t_lo, shift, 3, 0, out);
}

// G / w of mode k of a layer of dispersion d (dispersion_restoring): phi~ = -i (G/w) (plus - minus).
static inline float restoring_over_omega(float kx, float ky, float w, Dispersion d) {
  return w > 0.0f ? dispersion_restoring(sqrt(kx * kx + ky * ky), d) / w : 0.0f;
}

// The surface height and its linear-theory velocity potential at z = 0, packed as one pair (h, phi) for
// the eWave engine's ambient and initial fields (server/ewave). With h~ = plus + minus as in evolve_pairs,
// phi~ = -i (G/w) (plus - minus) (0 where w = 0): each e^{-iwt} part then obeys dh/dt = (w^2/G) phi, i.e.
// eWave's exact propagator h' = cos(w dt) h + (w/G) sin(w dt) phi maps it to h0 e^{-iw(t+dt)} (eqs 64-65).
__kernel void ocean_evolve_potential(__global const float* h0, const int nx, const int ny, const float dkx,
                                     const float dky, const float t_hi, const float t_lo, const float2 shift,
                                     const Dispersion d, __global float2* out) {
  int i = get_global_id(0), j = get_global_id(1);  // launched over exactly nx x ny
  float kx = mode_number(i, nx) * dkx, ky = mode_number(j, ny) * dky;
  float plus_re, plus_im, minus_re, minus_im, w;
  evolve_halves(h0, i, j, nx, ny, t_hi, t_lo, shift, &plus_re, &plus_im, &minus_re, &minus_im, &w);
  float G_over_w = restoring_over_omega(kx, ky, w, d);
  float d_re = G_over_w * (plus_re - minus_re), d_im = G_over_w * (plus_im - minus_im);
  // phi~ = -i (d_re + i d_im) = (d_im, -d_re)
  store_pack((__global float*)out, i + (size_t)nx * j, plus_re + minus_re, plus_im + minus_im, d_im, -d_re);
}

// The horizontal current at the surface, u = grad phi of the potential above, packed as one pair (u, v)
// for the textures that follow the waves (server/textures): u~ = i kx phi~ = kx (G/w) (plus - minus), and
// ky for v~ (exact spectral derivatives; the drift U_D is added by the host).
__kernel void ocean_evolve_current(__global const float* h0, const int nx, const int ny, const float dkx,
                                   const float dky, const float t_hi, const float t_lo, const float2 shift,
                                   const Dispersion d, __global float2* out) {
  int i = get_global_id(0), j = get_global_id(1);  // launched over exactly nx x ny
  float kx = mode_number(i, nx) * dkx, ky = mode_number(j, ny) * dky;
  float plus_re, plus_im, minus_re, minus_im, w;
  evolve_halves(h0, i, j, nx, ny, t_hi, t_lo, shift, &plus_re, &plus_im, &minus_re, &minus_im, &w);
  float G_over_w = restoring_over_omega(kx, ky, w, d);
  float d_re = G_over_w * (plus_re - minus_re), d_im = G_over_w * (plus_im - minus_im);  // phi~ = -i d
  store_pack((__global float*)out, i + (size_t)nx * j, kx * d_re, kx * d_im, ky * d_re, ky * d_im);
}

// Adds one layer's real fields (the inverse FFT of evolve_pairs: `pairs` complex arrays of nx * ny values)
// at the output grid points: output point (i, j) sits at layer cell coordinates (i * scale.x, j * scale.y),
// periodic; bilinear between layer points (exact where they coincide). accum holds `pairs` complex channel
// pairs of onx * ony cells, written (first) or added to, in one of two layouts: interleaved as an inverse
// FFT leaves them (ocean_finalize's input), or as two planes of floats a pair (the real parts, then the
// imaginary ones). One work-item a cell: its coordinates and weights serve every pair. On a CPU device the
// kernel stays scalar: vectorized, its reads become AVX-512 gathers, which took 1.3 times the scalar
// loop's time on an AMD EPYC.
__kernel void ocean_accumulate(__global const float2* fields, const int nx, const int ny, const int pairs,
                               const float2 scale, const int onx, const int ony, const int first,
                               const int interleaved, __global float* accum) {
  int i = get_global_id(0), j = get_global_id(1);  // launched over exactly onx x ony
  float u = i * scale.x, v = j * scale.y;
  u -= nx * floor(u / nx);
  v -= ny * floor(v / ny);
  int i0 = min((int)u, nx - 1), j0 = min((int)v, ny - 1);
  float fu = u - i0, fv = v - j0;
  int i1 = i0 + 1 == nx ? 0 : i0 + 1, j1 = j0 + 1 == ny ? 0 : j0 + 1;
  size_t cells = (size_t)nx * ny, ocells = (size_t)onx * ony, at = i + (size_t)onx * j;
  size_t cell_stride = interleaved ? 2 : 1, im_offset = interleaved ? 1 : ocells;
  for (int p = 0; p < pairs; ++p) {
    __global const float2* f = fields + p * cells;
    float2 value = (1.0f - fv) * ((1.0f - fu) * f[i0 + nx * j0] + fu * f[i1 + nx * j0]) +
                   fv * ((1.0f - fu) * f[i0 + nx * j1] + fu * f[i1 + nx * j1]);
    __global float* re = accum + 2 * p * ocells + cell_stride * at;
    __global float* im = re + im_offset;
    *re = first ? value.x : *re + value.x;
    *im = first ? value.y : *im + value.y;
  }
}

// Channel pair k (channels 2k and 2k + 1) at cell `at` of the summed fields, interleaved complex arrays as
// the inverse FFT of evolve_pairs leaves them. Floats, not a float2: see store_pack.
__attribute__((always_inline)) static void channel_pair(__global const float* sums, int k, int cells, int at,
                                                        float* first, float* second) {
  *first = sums[2 * ((size_t)k * cells + at)];
  *second = sums[2 * ((size_t)k * cells + at) + 1];
}

// Output planes of ocean_finalize (each onx * ony floats).
#define OUT_HEIGHT 0
#define OUT_DISP_X 1
#define OUT_DISP_Y 2
#define OUT_SLOPE_X 3
#define OUT_SLOPE_Y 4
#define OUT_NORMAL_X 5
#define OUT_NORMAL_Y 6
#define OUT_NORMAL_Z 7
#define OUT_J 8
#define OUT_J_MINUS 9
#define OUT_J_PLUS 10
#define OUT_WHITECAP 11
#define OUT_SCRATCH 12  // where the outputs not asked for go

// Plane `plane`'s element `at`, or the scratch plane's when the output is not asked for. Every store of
// ocean_finalize is unconditional: a vectorized `if (flag) out[...] = v` is a masked store, and its
// masked-out lanes on pages never written (the planes no request asked for) cost a microcode assist
// each on an x86 CPU (ocean_finalize ran 8x slower).
inline size_t out_at(int plane, int wanted, int cells, int at) {
  return (size_t)(wanted ? plane : OUT_SCRATCH) * cells + at;
}

// From the summed channels: displacement lambda D, slopes, normals (eq 94), J and its eigenvalues (App A
// eqs 45-47), whitecaps (section 5.3.3: 1 where J- < threshold, else W * decay; decay = exp(-dt/T), or 0
// for a frame without history). flags: bit 0 height, 1 displacement, 2 slopes, 3 normals, 4 Jacobian,
// 5 whitecaps. The sums are interleaved complex channel pairs (an inverse FFT's output, or ocean_accumulate's
// in that layout). The channel layout (displaced or not) only picks which pair a load reads, the same for
// every work-item.
__kernel void ocean_finalize(__global const float* sums, const int cells, const int channels, const int displaced,
                             const float lambda, const int flags, const float threshold, const float decay,
                             __global float* whitecap, __global float* out) {
  int at = get_global_id(0);  // launched over exactly `cells` work-items
  // channels is 2, 4, 6 or 8: the leading pairs of the displaced or undisplaced layout (top of this file);
  // the missing channels are 0. Read as scalars, not a private array: PoCL then keeps them in registers and
  // vectorizes across work-items.
  // The pairs not computed read pair 0 (present: no masked loads, see out_at) and count as 0.
  const int pairs = channels / 2, none = 4;  // a layout's index of each pair; none: not in the layout
  const int dy_ex = displaced ? 1 : none, ey_dxx = displaced ? 2 : 1, dyy_dxy = displaced ? 3 : 2;
  float h, second, Dy, ex, ey, Dxx, Dyy, Dxy;
  channel_pair(sums, 0, cells, at, &h, &second);  // (h, Dx) displaced, (h, ex) undisplaced
  channel_pair(sums, dy_ex < pairs ? dy_ex : 0, cells, at, &Dy, &ex);
  channel_pair(sums, ey_dxx < pairs ? ey_dxx : 0, cells, at, &ey, &Dxx);
  channel_pair(sums, dyy_dxy < pairs ? dyy_dxy : 0, cells, at, &Dyy, &Dxy);
  const float Dx = displaced ? second : 0.0f;
  if (!displaced) Dy = 0.0f, ex = second;
  else if (dy_ex >= pairs) Dy = ex = 0.0f;
  if (ey_dxx >= pairs) ey = Dxx = 0.0f;
  if (dyy_dxy >= pairs) Dyy = Dxy = 0.0f;
  out[out_at(OUT_HEIGHT, flags & 1, cells, at)] = h;
  out[out_at(OUT_DISP_X, flags & 2, cells, at)] = lambda * Dx;
  out[out_at(OUT_DISP_Y, flags & 2, cells, at)] = lambda * Dy;
  out[out_at(OUT_SLOPE_X, flags & 4, cells, at)] = ex;
  out[out_at(OUT_SLOPE_Y, flags & 4, cells, at)] = ey;
  float Jxx = 1.0f + lambda * Dxx, Jyy = 1.0f + lambda * Dyy, Jxy = lambda * Dxy;
  float n_x, n_y, n_z;
  sq_surface_normal(Jxx, Jyy, Jxy, ex, ey, &n_x, &n_y, &n_z);  // eq 94
  out[out_at(OUT_NORMAL_X, flags & 8, cells, at)] = n_x;
  out[out_at(OUT_NORMAL_Y, flags & 8, cells, at)] = n_y;
  out[out_at(OUT_NORMAL_Z, flags & 8, cells, at)] = n_z;
  float mean = 0.5f * (Jxx + Jyy), diff = 0.5f * (Jxx - Jyy);
  float radius = sqrt(diff * diff + Jxy * Jxy);
  float Jminus = mean - radius, Jplus = mean + radius;                   // App A eq 47
  out[out_at(OUT_J, flags & 16, cells, at)] = Jxx * Jyy - Jxy * Jxy;  // App A eq 45
  out[out_at(OUT_J_MINUS, flags & 16, cells, at)] = Jminus;
  out[out_at(OUT_J_PLUS, flags & 16, cells, at)] = Jplus;
  float w = Jminus < threshold ? 1.0f : whitecap[at] * decay;  // history: garbage without whitecaps, unused
  whitecap[at] = w;
  out[out_at(OUT_WHITECAP, flags & 32, cells, at)] = w;
}
