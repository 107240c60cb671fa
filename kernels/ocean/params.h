/* The per-layer parameters that cross from the host (ocean engine) to the ocean kernels. Shared by host C++
 * and OpenCL C: every member is a 4-byte int/uint/float, so the layout is the same on both sides.
 *
 * OceanLayer layout (256 bytes, no padding):
 *   0   int   nx, ny                     layer grid (even)
 *   8   float dkx, dky                   2 pi / lx, 2 pi / ly (rad/m)
 *   16  int   spectrum, spreading        SQ_SPECTRUM_*, SQ_SPREAD_* (ocean/spectra.h)
 *   24  int   partials, layer_index
 *   32  float g, wind_speed, alpha, omega_p, gamma, sigma_a, sigma_b, depth
 *   64  float theta0, omega_mean, phillips_amplitude, phillips_length
 *   80  float phillips_cutoff, phillips_exponent, k_min, k_max (k_max <= 0: none)
 *   96  float partial_omega_p[4], partial_scale[4], partial_a[4], partial_b[4], partial_c[4],
 *             partial_n[4], partial_m[4]                                    (7 x 16 bytes)
 *   208 Dispersion dispersion            (common/dispersion.h, 16 bytes)
 *   224 uint  seed_lo, seed_hi           the layer's 64-bit seed
 *   232 uint  pad[6]
 */
#ifndef SQUALL_OCEAN_PARAMS_H
#define SQUALL_OCEAN_PARAMS_H

#include "common/dispersion.h"

typedef struct {
  int nx, ny;
  float dkx, dky;
  int spectrum, spreading;
  int partials, layer_index;
  float g, wind_speed, alpha, omega_p, gamma, sigma_a, sigma_b, depth;
  float theta0, omega_mean, phillips_amplitude, phillips_length;
  float phillips_cutoff, phillips_exponent, k_min, k_max;
  float partial_omega_p[4], partial_scale[4], partial_a[4], partial_b[4], partial_c[4], partial_n[4], partial_m[4];
  Dispersion dispersion;
  unsigned int seed_lo, seed_hi;
  unsigned int pad[6];
} OceanLayer;

/* The band of one layer for B(k) (eq 56): |kx| < kx_max, |ky| < ky_max, and not (|kx| < kx_min and
 * |ky| < ky_min), the cell of the mean. float4 (kx_min, ky_min, kx_max, ky_max) per layer. */

#endif
