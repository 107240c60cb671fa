/* The unit normal of a displaced surface, eq 94 of J. Tessendorf, "Gilligan: A Prototype Framework for
 * Simulating and Rendering Maritime Environments" (2017): with lambda the displacement scale,
 *   n ~ (1 + l dDx/dx, l dDx/dy, eps_x) x (l dDx/dy, 1 + l dDy/dy, eps_y),
 * given jxx = 1 + l dDx/dx, jyy = 1 + l dDy/dy, jxy = l dDx/dy and the slopes (eps_x, eps_y). In scalars,
 * not float3: PoCL vectorizes a kernel across work-items only when it computes with no OpenCL vector
 * values. A degenerate (zero) cross product gives the zero vector, as normalize does.
 */
#ifndef SQUALL_COMMON_SURFACE_NORMAL_H
#define SQUALL_COMMON_SURFACE_NORMAL_H

#ifndef __OPENCL_VERSION__
#include <float.h>
#include <math.h>
#endif

static inline void sq_surface_normal(float jxx, float jyy, float jxy, float eps_x, float eps_y, float* n_x, float* n_y,
                                     float* n_z) {
  float x = jxy * eps_y - eps_x * jyy, y = eps_x * jxy - jxx * eps_y, z = jxx * jyy - jxy * jxy;
  // Divided by its largest component first: squared, a component past 1.8e19 (steep slopes times a large
  // displacement scale) overflows float, and one below 1e-19 underflows. A division, not a reciprocal, which
  // is denormal past 2^126 (and zero where a device flushes denormals); a largest component that is itself
  // denormal or infinite leaves the vector as it is. Magnitudes by comparison, not fabs: PoCL 3.1 then
  // vectorizes the tile's finishing kernel (docs/performance.md, "Normals scaled before squaring").
  const float ax = x < 0.0f ? -x : x, ay = y < 0.0f ? -y : y, az = z < 0.0f ? -z : z;
  const float largest = ax > ay ? (ax > az ? ax : az) : (ay > az ? ay : az);
  const float divisor = largest >= FLT_MIN && largest < INFINITY ? largest : 1.0f;
  x /= divisor, y /= divisor, z /= divisor;
  const float length = sqrt(x * x + y * y + z * z);  // in [1, sqrt(3)] when scaled
  const float inverse = length > 0.0f ? 1.0f / length : 0.0f;
  *n_x = x * inverse;
  *n_y = y * inverse;
  *n_z = z * inverse;
}

#endif
