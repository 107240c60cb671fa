/* The inputs of texture advection, shared by host C++ and OpenCL C: the velocity field and the reference
 * texture R = (a_0, a_1, ...) with its final function F (Q. Yu, F. Neyret, E. Bruneton, N. Holzschuch,
 * "Lagrangian Texture Advection: Preserving both Spectrum and Velocity Field", IEEE TVCG 2011, sec. 3.2:
 * T(x) = F(a_0(x), a_1(x), ...), channels blended linearly, F applied after blending).
 *
 * Conventions: the domain is [0, Lx] x [0, Ly] in domain units (du); velocities in du/s; times in s.
 * Texture coordinates are in texture periods (1 = one repeat of the tileable reference texture).
 *
 * The functions below compile as C++ (host) and OpenCL C (device), so that the fluid test the host's
 * particle maintenance uses is the one the kernels use. */
#ifndef SQUALL_TEXTURES_FIELDS_H
#define SQUALL_TEXTURES_FIELDS_H

#ifdef __OPENCL_VERSION__
#define SQUALL_GLOBAL __global
#else
#include <cmath>
#define SQUALL_GLOBAL
#endif

/* VelocityField.kind: analytic fields (parameters p[] below, positions in du, rates in 1/s) or a grid. */
#define SQUALL_VELOCITY_UNIFORM 0      /* v = (p0, p1) */
#define SQUALL_VELOCITY_ROTATION 1     /* solid rotation at omega = p0 about (p1, p2): v = omega (-(y-cy), x-cx) */
#define SQUALL_VELOCITY_SHEAR 2        /* v = (p0 (y - p1), 0) */
#define SQUALL_VELOCITY_SINK 3         /* v = -p0 (x - c) / (|x - c| + p3), c = (p1, p2) */
#define SQUALL_VELOCITY_VORTEX 4       /* Rankine vortex: circulation p0 (du^2/s), centre (p1, p2), core radius p3 */
#define SQUALL_VELOCITY_TAYLOR_GREEN 5 /* v = p0 (sin kx cos ky, -cos kx sin ky), k = 2 pi / p1 */
#define SQUALL_VELOCITY_CHANNEL 6      /* Poiseuille: u = p0 (1 - ((y - p1)/p2)^2) for |y - p1| < p2; walls outside */
#define SQUALL_VELOCITY_CYLINDER 7     /* potential flow p0 along x past a cylinder of centre (p1, p2), radius p3 */
#define SQUALL_VELOCITY_GRID 8         /* nodes on a grid, bilinear in space, linear in time between frames */
#define SQUALL_VELOCITY_KINDS 9

/* VelocityField.extrapolation: a grid sampled outside its nodes. */
#define SQUALL_EXTRAPOLATE_CLAMP 0 /* clamp to the edge nodes */
#define SQUALL_EXTRAPOLATE_ZERO 1  /* zero velocity outside the grid */
#define SQUALL_EXTRAPOLATE_WRAP 2  /* periodic: node nx is node 0 again, node ny node 0 */

#define SQUALL_VELOCITY_PARAMS 8
#define SQUALL_VELOCITY_WINDOW SQUALL_VELOCITY_PARAMS /* a grid's frames within one step's reach, at most */

/* Layout (96 bytes, every member 4 bytes, no padding):
 *   offset  0  int   kind            SQUALL_VELOCITY_*
 *   offset  4  int   nx, ny          grid nodes (grid only)
 *   offset 12  int   extrapolation   SQUALL_EXTRAPOLATE_* (grid only)
 *   offset 16  float origin_x, origin_y   position of node (0, 0), du
 *   offset 24  float hx, hy          node spacing, du
 *   offset 32  int   frames          grid only: the frames a step reaches (its window), 1..SQUALL_VELOCITY_WINDOW:
 *                                    the last at or before the step's start to the first at or after its end
 *   offset 36  int   frame_first     grid only: offset of the window's first frame in the grid array, in nodes
 *   offset 40  int   reserved0[2]
 *   offset 48  int   has_mask        1: the mask array marks fluid nodes (nearest node decides)
 *   offset 52  int   reserved[3]
 *   offset 64  float p[8]            analytic parameters; a grid's window frames' times, s after the start of
 *                                    the step the field is passed for: kernels take times from that start,
 *                                    so that float32 keeps them exact at any session time
 * The grid array holds frames of nx * ny (u, v) pairs, x fastest. */
typedef struct VelocityField {
  int kind;
  int nx, ny;
  int extrapolation;
  float origin_x, origin_y;
  float hx, hy;
  int frames, frame_first;
  int reserved0[2];
  int has_mask;
  int reserved[3];
  float p[SQUALL_VELOCITY_PARAMS];
} VelocityField;

/* TextureSource.kind */
#define SQUALL_TEXTURE_IMAGE 0 /* channels of an image, bilinear with wrap */
#define SQUALL_TEXTURE_NOISE 1 /* one channel per band of gradient noise b_j(2^j u) */

/* TextureSource.final_function: T = F(R'), after K. Perlin, "An Image Synthesizer" (SIGGRAPH 1985). */
#define SQUALL_FINAL_IDENTITY 0   /* T = R' (every channel) */
#define SQUALL_FINAL_SUM_BANDS 1  /* T = scale sum_j 2^-j a_j */
#define SQUALL_FINAL_TURBULENCE 2 /* T = scale sum_j 2^-j |2 a_j - 1| */
#define SQUALL_FINAL_RIDGED 3     /* T = scale sum_j 2^-j (1 - |2 a_j - 1|) */
#define SQUALL_FINAL_LUT 4        /* T = LUT(s(x) + scale sum_j 2^-j g(a_j)), g the shaping of lut_band_shape */
#define SQUALL_FINAL_FUNCTIONS 5

#define SQUALL_TEXTURE_MAX_CHANNELS 8
#define SQUALL_LUT_MAX_CHANNELS 4 /* output channels of the LUT (RGBA) */
#define SQUALL_LUT_MAX_ENTRIES 4096

/* Eulerian multi-layer advection (eulerian.cl): layers of 2 or 3 phases each, every (layer, phase) a slot. */
#define SQUALL_EULERIAN_MAX_LAYERS 6
#define SQUALL_EULERIAN_MAX_PHASES 3
#define SQUALL_EULERIAN_MAX_SLOTS (SQUALL_EULERIAN_MAX_LAYERS * SQUALL_EULERIAN_MAX_PHASES)

/* Layout (144 bytes, every member 4 bytes, no padding):
 *   offset  0  int   kind            SQUALL_TEXTURE_*
 *   offset  4  int   channels        image channels, or noise bands; 1..SQUALL_TEXTURE_MAX_CHANNELS
 *   offset  8  int   width, height   image pixels per period (image only)
 *   offset 16  uint  seed            noise gradients
 *   offset 20  float base_cells      noise lattice cells per period in band 0 (band j: base_cells 2^j)
 *   offset 24  float mean[8]         Rhat per channel (sec. 3.4, eq. 4)
 *   offset 56  float turn[8]         flow noise: the angle band c's gradients have turned by at the frame's time,
 *                                    rad in [0, 2 pi): spin 2^(2c/3) t, reduced on the host in double
 *   offset 88  int   final_function  SQUALL_FINAL_*
 *   offset 92  float final_scale     scale of F
 * SQUALL_FINAL_LUT only (Q. Yu, F. Neyret, E. Bruneton, N. Holzschuch, "Lagrangian Texture Advection",
 * IEEE TVCG 2011, sec. 3.2, the fire example: T = LUT(s(x) + final_scale sum_j 2^-j g(a_j))):
 *   offset 96  int   lut_entries     N, 2..SQUALL_LUT_MAX_ENTRIES
 *   offset 100 int   lut_channels    C, 1..SQUALL_LUT_MAX_CHANNELS: the final planes
 *   offset 104 float lut_min, lut_max     the input range of the table: entry k at lut_min + k (max - min) / (N - 1)
 *   offset 112 int   lut_band_shape  g: SQUALL_FINAL_SUM_BANDS (a), _TURBULENCE (|2a - 1|) or _RIDGED (1 - |2a - 1|)
 *   offset 116 int   scalar_nx, scalar_ny       nodes of the scalar field s (0: no field, s = 0)
 *   offset 124 float scalar_origin_x, scalar_origin_y   position of node (0, 0), du
 *   offset 132 float scalar_hx, scalar_hy       node spacing, du
 *   offset 140 int   reserved
 * The image array holds `channels` planes of width x height floats, x fastest. The LUT array holds N
 * entries of C floats (entry after entry); the scalar array nx * ny floats, x fastest, bilinear and
 * clamped to its edge nodes. */
typedef struct TextureSource {
  int kind;
  int channels;
  int width, height;
  unsigned int seed;
  float base_cells;
  float mean[SQUALL_TEXTURE_MAX_CHANNELS];
  float turn[SQUALL_TEXTURE_MAX_CHANNELS];
  int final_function;
  float final_scale;
  int lut_entries, lut_channels;
  float lut_min, lut_max;
  int lut_band_shape;
  int scalar_nx, scalar_ny;
  float scalar_origin_x, scalar_origin_y;
  float scalar_hx, scalar_hy;
  int reserved;
} TextureSource;

/* The output pixels: width x height over a region whose lower-left corner is (x0, y0); pixel (px, py)
 * samples the domain at (x0 + (px + 0.5) pixel_x, y0 + (py + 0.5) pixel_y). The Lagrangian
 * reconstruction bins grids into square tiles of `tile` pixels, tiles_x per row.
 * Layout (32 bytes): int width, height; float x0, y0, pixel_x, pixel_y; int tile, tiles_x. */
typedef struct OutputGrid {
  int width, height;
  float x0, y0;
  float pixel_x, pixel_y;
  int tile, tiles_x;
} OutputGrid;

/* The auxiliary planes every method writes after the final and raw planes: the weight sum, the sum of
 * squared weights, the number of blended samples (-1 on solid pixels), the selected layer l*, and the
 * texture coordinate u (x then y, in periods) of the sample with the largest weight (0 where none). */
#define SQUALL_AUX_PLANES 6

/* The number of final planes F produces: every channel for the identity, the LUT's channels, else one. */
static inline int final_channels(const TextureSource* t) {
  if (t->final_function == SQUALL_FINAL_IDENTITY) return t->channels;
  return t->final_function == SQUALL_FINAL_LUT ? t->lut_channels : 1;
}

/* The nearest of n nodes spaced h apart to a point `offset` from the first, clamped to the grid before the
 * conversion to int (a point far outside a fine grid would overflow it; NaN gives node 0). */
static inline int nearest_node(float offset, float h, int n) {
  const float u = floor(offset / h + 0.5f);
  if (!(u > 0.0f)) return 0;
  return u >= (float)(n - 1) ? n - 1 : (int)u;
}

/* Fluid test at (x, y): 0 inside the cylinder or outside the channel's walls, and on grid nodes the mask
 * marks solid (nearest node, clamped to the grid). */
static inline int velocity_fluid_at(const VelocityField* f, SQUALL_GLOBAL const unsigned char* mask, float x, float y) {
  if (f->kind == SQUALL_VELOCITY_CHANNEL) return fabs(y - f->p[1]) < f->p[2];
  if (f->kind == SQUALL_VELOCITY_CYLINDER) {
    float dx = x - f->p[1], dy = y - f->p[2];
    return dx * dx + dy * dy > f->p[3] * f->p[3];
  }
  if (f->kind != SQUALL_VELOCITY_GRID || !f->has_mask) return 1;
  const int i = nearest_node(x - f->origin_x, f->hx, f->nx), j = nearest_node(y - f->origin_y, f->hy, f->ny);
  return mask[i + f->nx * j] != 0;
}

#ifdef __cplusplus
#include "common/host_layout.h"
SQUALL_ASSERT_SIZE(VelocityField, 96);
SQUALL_ASSERT_OFFSET(VelocityField, kind, 0);
SQUALL_ASSERT_OFFSET(VelocityField, nx, 4);
SQUALL_ASSERT_OFFSET(VelocityField, ny, 8);
SQUALL_ASSERT_OFFSET(VelocityField, extrapolation, 12);
SQUALL_ASSERT_OFFSET(VelocityField, origin_x, 16);
SQUALL_ASSERT_OFFSET(VelocityField, origin_y, 20);
SQUALL_ASSERT_OFFSET(VelocityField, hx, 24);
SQUALL_ASSERT_OFFSET(VelocityField, hy, 28);
SQUALL_ASSERT_OFFSET(VelocityField, frames, 32);
SQUALL_ASSERT_OFFSET(VelocityField, frame_first, 36);
SQUALL_ASSERT_OFFSET(VelocityField, reserved0, 40);
SQUALL_ASSERT_OFFSET(VelocityField, has_mask, 48);
SQUALL_ASSERT_OFFSET(VelocityField, reserved, 52);
SQUALL_ASSERT_OFFSET(VelocityField, p, 64);
SQUALL_ASSERT_SIZE(OutputGrid, 32);
SQUALL_ASSERT_OFFSET(OutputGrid, width, 0);
SQUALL_ASSERT_OFFSET(OutputGrid, height, 4);
SQUALL_ASSERT_OFFSET(OutputGrid, x0, 8);
SQUALL_ASSERT_OFFSET(OutputGrid, y0, 12);
SQUALL_ASSERT_OFFSET(OutputGrid, pixel_x, 16);
SQUALL_ASSERT_OFFSET(OutputGrid, pixel_y, 20);
SQUALL_ASSERT_OFFSET(OutputGrid, tile, 24);
SQUALL_ASSERT_OFFSET(OutputGrid, tiles_x, 28);
SQUALL_ASSERT_SIZE(TextureSource, 144);
SQUALL_ASSERT_OFFSET(TextureSource, kind, 0);
SQUALL_ASSERT_OFFSET(TextureSource, channels, 4);
SQUALL_ASSERT_OFFSET(TextureSource, width, 8);
SQUALL_ASSERT_OFFSET(TextureSource, height, 12);
SQUALL_ASSERT_OFFSET(TextureSource, seed, 16);
SQUALL_ASSERT_OFFSET(TextureSource, base_cells, 20);
SQUALL_ASSERT_OFFSET(TextureSource, mean, 24);
SQUALL_ASSERT_OFFSET(TextureSource, turn, 56);
SQUALL_ASSERT_OFFSET(TextureSource, final_function, 88);
SQUALL_ASSERT_OFFSET(TextureSource, final_scale, 92);
SQUALL_ASSERT_OFFSET(TextureSource, lut_entries, 96);
SQUALL_ASSERT_OFFSET(TextureSource, lut_channels, 100);
SQUALL_ASSERT_OFFSET(TextureSource, lut_min, 104);
SQUALL_ASSERT_OFFSET(TextureSource, lut_max, 108);
SQUALL_ASSERT_OFFSET(TextureSource, lut_band_shape, 112);
SQUALL_ASSERT_OFFSET(TextureSource, scalar_nx, 116);
SQUALL_ASSERT_OFFSET(TextureSource, scalar_ny, 120);
SQUALL_ASSERT_OFFSET(TextureSource, scalar_origin_x, 124);
SQUALL_ASSERT_OFFSET(TextureSource, scalar_origin_y, 128);
SQUALL_ASSERT_OFFSET(TextureSource, scalar_hx, 132);
SQUALL_ASSERT_OFFSET(TextureSource, scalar_hy, 136);
SQUALL_ASSERT_OFFSET(TextureSource, reserved, 140);
#endif

#endif
