/* Dispersion relations of linear surface waves and their group velocities (Table 1 of J. Tessendorf,
 * "Gilligan: A Prototype Framework for Simulating and Rendering Maritime Environments" (2017)).
 * Shared by OpenCL C (kernels include "common/dispersion.h") and host C++ (include it with kernels/ on the
 * include path; the shim below maps the OpenCL built-ins to <math.h>). SI units: k in rad/m, omega in
 * rad/s, gravity in m/s^2, depth and capillary length in m, group velocity in m/s.
 *
 * Layout of Dispersion (16 bytes, no padding; identical for cl_int/cl_float on the host):
 *   offset 0  int   kind              SQUALL_DISPERSION_*
 *   offset 4  float gravity           g > 0 (9.81)
 *   offset 8  float depth             h > 0, used by SHALLOW and COMBINED
 *   offset 12 float capillary_length  l >= 0, used by CAPILLARY and COMBINED (physical value ~2.7e-3 m)
 */
#ifndef SQUALL_COMMON_DISPERSION_H
#define SQUALL_COMMON_DISPERSION_H

#ifndef __OPENCL_VERSION__
#include <math.h>
#endif

#define SQUALL_DISPERSION_DEEP 0      /* w^2 = g k */
#define SQUALL_DISPERSION_SHALLOW 1   /* w^2 = g k tanh(k h) */
#define SQUALL_DISPERSION_CAPILLARY 2 /* w^2 = g k (1 + (k l)^2) */
#define SQUALL_DISPERSION_COMBINED 3  /* w^2 = g k tanh(k h) (1 + (k l)^2) */

typedef struct {
  int kind;
  float gravity;
  float depth;
  float capillary_length;
} Dispersion; /* 16 bytes */

#ifdef __cplusplus
#include "common/host_layout.h"
SQUALL_ASSERT_SIZE(Dispersion, 16);
SQUALL_ASSERT_OFFSET(Dispersion, kind, 0);
SQUALL_ASSERT_OFFSET(Dispersion, gravity, 4);
SQUALL_ASSERT_OFFSET(Dispersion, depth, 8);
SQUALL_ASSERT_OFFSET(Dispersion, capillary_length, 12);
#endif

/* tanh(kh) for the kinds with a bottom, 1 for the others. */
static inline float dispersion_depth_factor(float k, Dispersion d) {
  return (d.kind == SQUALL_DISPERSION_SHALLOW || d.kind == SQUALL_DISPERSION_COMBINED) ? tanh(k * d.depth) : 1.0f;
}

/* (k l)^2 for the kinds with surface tension, 0 for the others. */
static inline float dispersion_capillary_term(float k, Dispersion d) {
  float kl = k * d.capillary_length;
  return (d.kind == SQUALL_DISPERSION_CAPILLARY || d.kind == SQUALL_DISPERSION_COMBINED) ? kl * kl : 0.0f;
}

/* G(k) = g (1 + (k l)^2), m/s^2: the restoring force of gravity and surface tension per unit height in the
 * linearized surface conditions (L. D. Landau, E. M. Lifshitz, "Fluid Mechanics", sec. 61):
 * d phi / dt = -G h and d h / dt = k tanh(kh) phi = (omega^2 / G) phi. */
static inline float dispersion_restoring(float k, Dispersion d) {
  return d.gravity * (1.0f + dispersion_capillary_term(k, d));
}

/* omega(k) >= 0 of Table 1; 0 at k <= 0. */
static inline float dispersion_omega(float k, Dispersion d) {
  if (k <= 0.0f) return 0.0f;
  return sqrt(d.gravity * k * dispersion_depth_factor(k, d) * (1.0f + dispersion_capillary_term(k, d)));
}

/* v_g = d omega / dk of Table 1. At k <= 0 it returns the long-wave limit: sqrt(g h) for SHALLOW and
 * COMBINED, and 0 for DEEP and CAPILLARY (whose limit is infinite; every spectrum vanishes there). */
static inline float dispersion_group_velocity(float k, Dispersion d) {
  int finite_depth = d.kind == SQUALL_DISPERSION_SHALLOW || d.kind == SQUALL_DISPERSION_COMBINED;
  if (k <= 0.0f) return finite_depth ? sqrt(d.gravity * d.depth) : 0.0f;
  float factor = 1.0f;
  if (finite_depth) {
    float kh = k * d.depth;
    float c = cosh(kh); /* inf for kh > ~89: the term is then 0, as it should be */
    factor += kh / (tanh(kh) * c * c);
  }
  float kl2 = dispersion_capillary_term(k, d);
  factor += 2.0f * kl2 / (1.0f + kl2);
  return 0.5f * (dispersion_omega(k, d) / k) * factor;
}

#endif
