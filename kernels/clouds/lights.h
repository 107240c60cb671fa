// The lights of the cloud ray marcher (render.cl): directional (a sun) and point lights, seen from a point
// of the medium. Included by render.cl and by the device-side checks (probe.cl).
#ifndef SQUALL_CLOUDS_LIGHTS_H
#define SQUALL_CLOUDS_LIGHTS_H

#include "clouds/render_params.h"

// Unit direction to light i from x, the distance to it and its irradiance scale: 1 for a directional light;
// for a point light the inverse square 1 / max(d, r)^2, r = p->point_light_radius (half the grid's voxel).
// Along a ray through a point light the integral of 1 / d^2 diverges, so within r, below the density's own
// resolution, the inverse square is held at its value at r. At d = 0 the direction is +z (any direction:
// the column toward the light is 0 there).
static inline float3 sq_to_light(__private const CloudRenderParams* p, int i, float3 x, float* dist, float* scale) {
  __private const CloudLight* l = &p->lights[i];
  if (l->kind == SQUALL_LIGHT_DIRECTIONAL) {
    *dist = 1e30f;
    *scale = 1.0f;
    return normalize((float3)(l->direction[0], l->direction[1], l->direction[2]));
  }
  float3 to = (float3)(l->position[0], l->position[1], l->position[2]) - x;
  const float d2 = dot(to, to), r = p->point_light_radius;
  *dist = sqrt(d2);
  *scale = 1.0f / fmax(d2, r * r);
  return *dist > 0.0f ? to / *dist : (float3)(0.0f, 0.0f, 1.0f);
}

// Point lights along a primary ray, by equiangular sampling (C. Kulla and M. Fajardo, "Importance Sampling
// Techniques for Path Tracing in Participating Media", EGSR 2012): on a sub-step of the ray, the light's
// inverse square g(u) = 1 / max(b^2 + u^2, r^2) (as sq_to_light's; u the ray parameter counted from the point
// nearest the light, b the light's distance from the ray) is integrated exactly, and the light is sampled at
// points drawn with density g / integral, so that the 1 / d^2 peak near the light costs no variance. Where
// |u| <= c = sqrt(max(r^2 - b^2, 0)), g = 1 / r^2.

// atan(b y) / b and tan(b y) / b, y at b = 0.
static inline float sq_atan_over(float b, float y) { return b > 0.0f ? atan(b * y) / b : y; }
static inline float sq_tan_over(float b, float y) { return b > 0.0f ? tan(b * y) / b : y; }

// The integral of g over [0, x], odd in x: beyond c, (atan(|x| / b) - atan(c / b)) / b written as one atan.
static inline float sq_g_integral(float x, float b, float r2, float c) {
  const float ax = fabs(x);
  if (ax <= c) return x / r2;
  return copysign(c / r2 + sq_atan_over(b, (ax - c) / (b * b + ax * c)), x);
}

// The x at which sq_g_integral reaches h.
static inline float sq_g_inverse(float h, float b, float r2, float c) {
  const float ah = fabs(h);
  if (ah <= c / r2) return h * r2;
  const float m = sq_tan_over(b, ah - c / r2);
  return copysign((c + m * b * b) / (1.0f - m * c), h);
}

// Point light i seen from the sub-step [t0, t0 + len] of the primary ray entry + t dir (dir a unit vector).
// Ray parameters are kept as offsets from the sub-step's start, not from tc, which may be far along the ray
// from a distant light: its rounding there would swamp the sub-step's length.
typedef struct LightSpan {
  float len;       // the sub-step's length, m
  float u0;        // its start from the ray's point nearest the light, m
  float b, r2, c;  // the light's distance from the ray, r^2, the held core's half-length (m, m^2, m)
  int one_side;    // the sub-step lies on one side of the core (|u| >= c throughout)
  float integral;  // G, the integral of g over the sub-step, m^-1
  float angle;     // max(b, r) G: the angle the sub-step spans seen from the light where b >= r, rad
} LightSpan;

// On one side of the held core (the usual case away from the light), G comes from the sub-step's own
// length (atan(b len / (b^2 + u0 u1)) / b), not as a difference of integrals from the nearest point, which
// would cancel far from the light.
static inline LightSpan sq_light_span(__private const CloudRenderParams* p, int i, float3 entry, float3 dir,
                                      float t0, float len) {
  __private const CloudLight* l = &p->lights[i];
  const float3 to = (float3)(l->position[0], l->position[1], l->position[2]) - entry;
  const float tc = dot(to, dir);
  LightSpan s;
  s.len = len;
  s.u0 = t0 - tc;
  s.b = length(to - tc * dir);
  s.r2 = p->point_light_radius * p->point_light_radius;
  s.c = sqrt(fmax(s.r2 - s.b * s.b, 0.0f));
  const float u1 = s.u0 + len;
  s.one_side = s.u0 >= s.c || u1 <= -s.c;
  s.integral = s.one_side ? sq_atan_over(s.b, len / (s.b * s.b + s.u0 * u1))
                          : sq_g_integral(u1, s.b, s.r2, s.c) - sq_g_integral(s.u0, s.b, s.r2, s.c);
  s.angle = s.integral * fmax(s.b, p->point_light_radius);
  return s;
}

// The offset from the sub-step's start, in [0, len], at which the integral of g from there reaches xi G
// (xi in [0, 1]): a point drawn with density g / G for a uniform xi.
static inline float sq_light_span_point(const LightSpan* s, float xi) {
  float du;
  if (s->one_side) {
    const float m = sq_tan_over(s->b, xi * s->integral);
    du = m * (s->b * s->b + s->u0 * s->u0) / (1.0f - m * s->u0);
  } else {
    du = sq_g_inverse(sq_g_integral(s->u0, s->b, s->r2, s->c) + xi * s->integral, s->b, s->r2, s->c) - s->u0;
  }
  return clamp(du, 0.0f, s->len);
}
#endif
