/* The per-layer parameters that cross from the host (ocean engine) to the ocean kernels. Shared by host C++
 * and OpenCL C: every member is a 4-byte int/uint/float, so the layout is the same on both sides.
 *
 * OceanLayer layout (256 bytes, no padding):
 *   0   int   nx, ny                     layer grid (even)
 *   8   float dkx, dky                   2 pi / lx, 2 pi / ly (rad/m)
 *   16  int   spectrum, spreading        SQUALL_SPECTRUM_*, SQUALL_SPREAD_* (ocean/spectra.h)
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

#ifdef __cplusplus
#include "common/host_layout.h"
SQUALL_ASSERT_SIZE(OceanLayer, 256);
SQUALL_ASSERT_OFFSET(OceanLayer, nx, 0);
SQUALL_ASSERT_OFFSET(OceanLayer, ny, 4);
SQUALL_ASSERT_OFFSET(OceanLayer, dkx, 8);
SQUALL_ASSERT_OFFSET(OceanLayer, dky, 12);
SQUALL_ASSERT_OFFSET(OceanLayer, spectrum, 16);
SQUALL_ASSERT_OFFSET(OceanLayer, spreading, 20);
SQUALL_ASSERT_OFFSET(OceanLayer, partials, 24);
SQUALL_ASSERT_OFFSET(OceanLayer, layer_index, 28);
SQUALL_ASSERT_OFFSET(OceanLayer, g, 32);
SQUALL_ASSERT_OFFSET(OceanLayer, wind_speed, 36);
SQUALL_ASSERT_OFFSET(OceanLayer, alpha, 40);
SQUALL_ASSERT_OFFSET(OceanLayer, omega_p, 44);
SQUALL_ASSERT_OFFSET(OceanLayer, gamma, 48);
SQUALL_ASSERT_OFFSET(OceanLayer, sigma_a, 52);
SQUALL_ASSERT_OFFSET(OceanLayer, sigma_b, 56);
SQUALL_ASSERT_OFFSET(OceanLayer, depth, 60);
SQUALL_ASSERT_OFFSET(OceanLayer, theta0, 64);
SQUALL_ASSERT_OFFSET(OceanLayer, omega_mean, 68);
SQUALL_ASSERT_OFFSET(OceanLayer, phillips_amplitude, 72);
SQUALL_ASSERT_OFFSET(OceanLayer, phillips_length, 76);
SQUALL_ASSERT_OFFSET(OceanLayer, phillips_cutoff, 80);
SQUALL_ASSERT_OFFSET(OceanLayer, phillips_exponent, 84);
SQUALL_ASSERT_OFFSET(OceanLayer, k_min, 88);
SQUALL_ASSERT_OFFSET(OceanLayer, k_max, 92);
SQUALL_ASSERT_OFFSET(OceanLayer, partial_omega_p, 96);
SQUALL_ASSERT_OFFSET(OceanLayer, partial_scale, 112);
SQUALL_ASSERT_OFFSET(OceanLayer, partial_a, 128);
SQUALL_ASSERT_OFFSET(OceanLayer, partial_b, 144);
SQUALL_ASSERT_OFFSET(OceanLayer, partial_c, 160);
SQUALL_ASSERT_OFFSET(OceanLayer, partial_n, 176);
SQUALL_ASSERT_OFFSET(OceanLayer, partial_m, 192);
SQUALL_ASSERT_OFFSET(OceanLayer, dispersion, 208);
SQUALL_ASSERT_OFFSET(OceanLayer, seed_lo, 224);
SQUALL_ASSERT_OFFSET(OceanLayer, seed_hi, 228);
SQUALL_ASSERT_OFFSET(OceanLayer, pad, 232);
#endif

/* The band of one layer for B(k) (eq 56): |kx| < kx_max, |ky| < ky_max, and not (|kx| < kx_min and
 * |ky| < ky_min), the cell of the mean. float4 (kx_min, ky_min, kx_max, ky_max) per layer. */

#endif
