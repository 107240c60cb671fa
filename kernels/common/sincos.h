/* sin and cos of a phase w t, with the time t = t_hi + t_lo given as two floats, in float arithmetic
 * with no calls: a work-group loop around it vectorizes. PoCL's sin, cos and sincos call a scalar
 * argument reduction for large arguments, and that call keeps the whole loop scalar on a CPU device.
 *
 * Two reductions (W. J. Cody and W. Waite, "Software Manual for the Elementary Functions", 1980, ch. 8):
 *   by whole turns, n = rint(w t / 2 pi): w t = p + e split exactly with an fma, 2 pi = C1 + C2 + C3 with
 *   C1 of 8 significant bits and C2 of 12, so that n C1 and n C2 are exact below 2^16 and 2^12 turns;
 *   then by quarter turns to |y| <= pi/4, where the minimax polynomials of Cephes' sinf and cosf
 *   (S. L. Moshier, "Methods and Programs for Mathematical Functions", 1989) are within 1e-7.
 * Past 2^12 turns the phase's error grows as |w t| 2^-24: that of rounding w t to one float.
 * Shared by OpenCL C and host C++ (the tests run it on the host; <math.h> provides fabs, copysign and fma).
 */
#ifndef SQUALL_COMMON_SINCOS_H
#define SQUALL_COMMON_SINCOS_H

#ifndef __OPENCL_VERSION__
#include <math.h>
#endif

/* rint(x): x to the nearest integer, ties to even. Below 2^23 in magnitude, adding 2^23 leaves no bits
 * below the units, so the addition rounds (to even) and the subtraction is exact; from 2^23 on every float
 * is an integer. In float arithmetic, with no call: PoCL's rint is a longer bitwise emulation. */
static inline float sq_rint(float x) {
  const float two_23 = 8388608.0f;
  return fabs(x) < two_23 ? copysign((fabs(x) + two_23) - two_23, x) : x;
}

/* sin y and cos y for |y| <= pi/4 (Cephes sinf.c, cosf.c). */
static inline void sq_sincos_octant(float y, float* s, float* c) {
  float z = y * y;
  *s = y + y * z * (-1.6666654611e-1f + z * (8.3321608736e-3f + z * -1.9515295891e-4f));
  *c = 1.0f - 0.5f * z + z * z * (4.166664568298827e-2f + z * (-1.388731625493765e-3f + z * 2.443315711809948e-5f));
}

/* sin and cos of w (t_hi + t_lo). */
static inline void sq_sincos_phase(float w, float t_hi, float t_lo, float* s, float* c) {
  float p = w * t_hi;
  float e = fma(w, t_hi, -p) + w * t_lo; /* w t = p + e */
  float n = sq_rint(p * 0.15915493667125702f);
  float r = ((p - n * 6.28125f) - n * 1.9350051879882812e-3f) - n * 3.019916050561733e-07f + e; /* |r| <~ pi */
  float q = sq_rint(r * 0.6366197466850281f);
  float y = (r - q * 1.5707963705062866f) - q * -4.371138828673793e-08f; /* r = y + q pi/2 */
  float sy, cy;
  sq_sincos_octant(y, &sy, &cy);
  int quadrant = (int)q; /* -2 .. 2; & 3 is the quadrant mod 4 in two's complement */
  float sr = (quadrant & 1) ? cy : sy, cr = (quadrant & 1) ? sy : cy;
  *s = (quadrant & 2) ? -sr : sr;
  *c = ((quadrant + 1) & 2) ? -cr : cr;
}

#endif
