// Device-side checks of the NanoVDB path: exact voxel lookups through PNanoVDB.h.
#include "clouds/node_walk.clh"
#include "clouds/pnanovdb_cl.h"

// out[i] = value of voxel ijk[3i..3i+2] of the float grid in `grid`, read with a PNanoVDB read accessor.
__kernel void nanovdb_lookup(__global const uint* grid, __global const int* ijk, const int n, __global float* out) {
  uint i = get_global_id(0);
  if (i >= n) return;
  pnanovdb_buf_t buf = pnanovdb_make_buf(grid);
  pnanovdb_readaccessor_t acc = sq_vdb_accessor(buf);
  out[i] = sq_vdb_value(buf, &acc, (int3)(ijk[3 * i], ijk[3 * i + 1], ijk[3 * i + 2]));
}

#include "clouds/render_params.h"
#include "clouds/phase.h"
#include "clouds/lights.h"

// out[i] = the phase function of p at scattering angle theta[i] (radians).
__kernel void phase_eval(CloudRenderParams p, __global const float* theta, const int n, __global float* out) {
  uint i = get_global_id(0);
  if (i >= n) return;
  float s = sin(0.5f * theta[i]), c = cos(0.5f * theta[i]);
  out[i] = phase_function(&p, cos(theta[i]), s * s, c * c);
}

// out[i] = B_lambda(T) at wavelength lambda[i] (m) and temperature T[i] (K).
__kernel void blackbody_eval(__global const float* lambda, __global const float* T, const int n, __global float* out) {
  uint i = get_global_id(0);
  if (i >= n) return;
  out[i] = blackbody(lambda[i], T[i]);
}

// out[i] = the tree queries of the walk of ray i (cell-space origin and direction at origin[3i], dir[3i])
// through the grid's bounding box, as the marches walk it: counted from where it enters the box, as a
// primary ray (from_entry), or from its origin, as a shadow ray; stops counting at 1e6.
__kernel void node_walk_queries(__global const uint* grid, __global const float* origin, __global const float* dir,
                                const int n, const int from_entry, __global int* out) {
  uint i = get_global_id(0);
  if (i >= n) return;
  VdbVolume v = sq_volume_open(grid, 0);
  float3 o = (float3)(origin[3 * i], origin[3 * i + 1], origin[3 * i + 2]);
  float3 d = (float3)(dir[3 * i], dir[3 * i + 1], dir[3 * i + 2]);
  float base, t0 = 0.0f, t1 = 1e30f;
  int queries = 0;
  if (from_entry ? sq_clip_root_from_entry(&v, &o, d, &base, &t0, &t1) : sq_clip_root(&v, o, d, &t0, &t1)) {
    const float nudge = 1e-4f / length(d);
    const float3 inv_d = 1.0f / d;
    for (float t = t0; t < t1 && queries < 1000000; ++queries) {
      VdbNode node;
      sq_node(&v, o, d, inv_d, t, nudge, &node);
      t = node.exit;
    }
  }
  out[i] = queries;
}

// out[4i..4i+3] = sq_to_light's direction (x, y, z) and irradiance scale for light `light` of p at the
// world point x[3i..3i+2].
__kernel void light_eval(CloudRenderParams p, const int light, __global const float* x, const int n,
                         __global float* out) {
  uint i = get_global_id(0);
  if (i >= n) return;
  float dist, scale;
  float3 dir = sq_to_light(&p, light, (float3)(x[3 * i], x[3 * i + 1], x[3 * i + 2]), &dist, &scale);
  out[4 * i] = dir.x;
  out[4 * i + 1] = dir.y;
  out[4 * i + 2] = dir.z;
  out[4 * i + 3] = scale;
}

// out[2i], out[2i + 1] = sq_light_span's G and sq_light_span_point's offset for light `light` of p, on the
// sub-step of ray i: in[9i..9i+8] = entry (3), unit direction (3), t0, len, xi.
__kernel void light_span_eval(CloudRenderParams p, const int light, __global const float* in, const int n,
                              __global float* out) {
  uint i = get_global_id(0);
  if (i >= n) return;
  __global const float* r = in + 9 * i;
  const LightSpan span =
      sq_light_span(&p, light, (float3)(r[0], r[1], r[2]), (float3)(r[3], r[4], r[5]), r[6], r[7]);
  out[2 * i] = span.integral;
  out[2 * i + 1] = sq_light_span_point(&span, r[8]);
}
