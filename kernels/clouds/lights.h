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

#endif
