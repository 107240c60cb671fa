/* sin and cos of a phase given in turns, 2 pi x, in float arithmetic with no calls: a work-group loop around
 * them vectorizes. PoCL's sin, cos and sincos call a scalar argument reduction for large arguments, and that
 * call keeps the whole loop scalar on a CPU device.
 *
 * A phase counted in turns drops its whole turns exactly: x - rint(x) is exact for every float x. So the
 * phase f t of a frequency f = f_hi + f_lo (turns per second) at a time t = t_hi + t_lo (two floats each)
 * keeps its fraction however many whole turns it holds: the whole turns n of f_hi t_hi are taken off the
 * exact product in one fma (as in T. J. Dekker's split, "A floating-point technique for extending the
 * available precision", Numer. Math. 18 (1971)), and the fractions are added with a rounding of 2^-25 turn
 * each. What is left is the two-float f and t's own error and the cross terms' rounding: about f t 2^-46
 * turn in all, below 1e-6 rad for w t up to 6e7 rad. The
 * quarter turn and the octant follow, where the minimax polynomials of Cephes' sinf and cosf (S. L.
 * Moshier, "Methods and Programs for Mathematical Functions", 1989) are within 1e-7.
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

/* x - rint(x): the fraction of a turn, in [-1/2, 1/2], exact. */
static inline float sq_turn_fraction(float x) { return x - sq_rint(x); }

/* The fraction of the turns a b (of two floats) to within a rounding of 2^-25 turn: for any whole n near
 * a b, a b - n is at most a few turns and the fma rounds it once (exactly once a b passes 2^23, where n is
 * the rounded product). n is any integer near a b, so a compiler that fuses a b into the rint is harmless. */
static inline float sq_product_turns(float a, float b) {
  float n = sq_rint(a * b);
  return sq_turn_fraction(fma(a, b, -n));
}

/* sin and cos of 2 pi x for a phase x in turns. */
static inline void sq_sincos_turn(float x, float* s, float* c) {
  float r = sq_turn_fraction(x);                     /* |r| <= 1/2 */
  float q = sq_rint(4.0f * r);                       /* -2 .. 2 quarter turns */
  float y = (r - 0.25f * q) * 6.2831853071795865f;   /* exact difference (Sterbenz), |y| <= pi/4 */
  float sy, cy;
  sq_sincos_octant(y, &sy, &cy);
  int quadrant = (int)q; /* & 3 is the quadrant mod 4 in two's complement */
  float sr = (quadrant & 1) ? cy : sy, cr = (quadrant & 1) ? sy : cy;
  *s = (quadrant & 2) ? -sr : sr;
  *c = ((quadrant + 1) & 2) ? -cr : cr;
}

/* sin and cos of 2 pi f t for a frequency f = f_hi + f_lo in turns per second at the time t = t_hi + t_lo
 * (two floats each, |f_lo| <= ulp(f_hi) / 2 and |t_lo| <= ulp(t_hi) / 2). The cross terms f_hi t_lo + f_lo t_hi
 * are below f t 2^-23 and are rounded twice, by f t 2^-47 turn at most; f_lo t_lo is left out. */
static inline void sq_sincos_turns(float f_hi, float f_lo, float t_hi, float t_lo, float* s, float* c) {
  float cross = fma(f_lo, t_hi, f_hi * t_lo);
  sq_sincos_turn(sq_product_turns(f_hi, t_hi) + sq_turn_fraction(cross), s, c);
}

#endif
