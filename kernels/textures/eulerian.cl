/* Multi-layer Eulerian texture advection: F. Neyret, "Advected Textures", Symposium on Computer Animation
 * 2003. Nodes over the output region carry, per slot (layer i, phase j), a texture coordinate u^i_j and
 * its accumulated deformation d^i_j (float4: u.x, u.y, d, 0), advected semi-Lagrangianly (J. Stam,
 * "Stable Fluids", SIGGRAPH 1999); the host regenerates slots (u = S x, d = 0) when their phase ends.
 * With one layer of two phases this is the game engines' two-phase flow map; one slot never regenerated
 * is naive advection. Node (i, j) sits at (x0 + i hx, y0 + j hy), hx = region width / (nx - 1).
 * With the vorticity cascade (sec. 4) the nodes also carry, per noise band k, a vorticity w_k and a phase
 * theta_k (float2 per band and node, band-major like the slots), shared by every slot. */
#include "textures/texture.clh"
#include "textures/velocity.clh"

#define SQUALL_DEFORMATION_WEIGHTED 0
#define SQUALL_DEFORMATION_PAPER 1
#define SQUALL_EULERIAN_OCTAVE 0
#define SQUALL_EULERIAN_FINAL 1
#define SQUALL_EULERIAN_OCTAVE_VP 2

/* Bilinear sample of slot `slot` of the node state at node coordinates g (inside the grid). */
static float4 node_state_at(__global const float4* state, int nx, int ny, int slot, float2 g) {
  int i = min((int)g.x, nx - 2), j = min((int)g.y, ny - 2);
  float s = g.x - (float)i, r = g.y - (float)j;
  __global const float4* q = state + (size_t)slot * (size_t)nx * (size_t)ny;
  float4 bottom = mix(q[i + nx * j], q[i + 1 + nx * j], s);
  float4 top = mix(q[i + nx * (j + 1)], q[i + 1 + nx * (j + 1)], s);
  return mix(bottom, top, r);
}

/* The norm of the strain rate e = (G + G^T) / 2, G = grad v, by central differences (ADV03 sec. 2.1):
 * |e| = sqrt(e_xx^2 + e_yy^2 + 2 e_xy^2). */
static float strain_rate_norm(const VelocityField* f, __global const float2* grid, float2 x, float t, float h) {
  float2 dvdx = (velocity_at(f, grid, x + (float2)(h, 0.0f), t) - velocity_at(f, grid, x - (float2)(h, 0.0f), t));
  float2 dvdy = (velocity_at(f, grid, x + (float2)(0.0f, h), t) - velocity_at(f, grid, x - (float2)(0.0f, h), t));
  dvdx /= 2.0f * h;
  dvdy /= 2.0f * h;
  float exy = 0.5f * (dvdy.x + dvdx.y);
  return sqrt(dvdx.x * dvdx.x + dvdy.y * dvdy.y + 2.0f * exy * exy);
}

/* The point the flow carries to x over [t, t + dt]: an RK2 (midpoint) backtrace. */
static float2 backtrace(const VelocityField* f, __global const float2* grid, float2 x, float t, float dt) {
  float2 mid = x - 0.5f * dt * velocity_at(f, grid, x, t + dt);
  return x - dt * velocity_at(f, grid, mid, t + 0.5f * dt);
}

/* One step [0, dt] (times from the step's start, as the velocity's): backtrace each node along the flow (RK2
 * midpoint), take every slot's state from there (fresh coordinates where the backtrace leaves the region),
 * add |e| dt to the deformation, and regenerate the slots whose bit is set in reset_mask. */
__kernel void eulerian_advect(__global const float4* state_in, __global float4* state_out, int nx, int ny,
                              OutputGrid frame, int slots, VelocityField velocity, __global const float2* grid,
                              float dt, float scale, int reset_mask, __global const float2* offsets) {
  int i = get_global_id(0), j = get_global_id(1);
  if (i >= nx || j >= ny) return;
  float hx = frame.pixel_x * (float)frame.width / (float)(nx - 1);
  float hy = frame.pixel_y * (float)frame.height / (float)(ny - 1);
  float2 x = (float2)(frame.x0 + (float)i * hx, frame.y0 + (float)j * hy);
  float2 back = backtrace(&velocity, grid, x, 0.0f, dt);
  float2 g = (float2)((back.x - frame.x0) / hx, (back.y - frame.y0) / hy);
  bool inside = g.x >= 0.0f && g.y >= 0.0f && g.x <= (float)(nx - 1) && g.y <= (float)(ny - 1);
  float strain = strain_rate_norm(&velocity, grid, x, dt, 0.5f * min(hx, hy));
  size_t node = (size_t)i + (size_t)nx * (size_t)j, plane = (size_t)nx * (size_t)ny;
  /* Inflow (a backtrace that leaves the grid) continues the map of the nearest edge point with the
   * window's gradient S: u(back) = u(edge) + S (back - edge), exact for a uniform flow. */
  float2 edge = clamp(g, (float2)(0.0f), (float2)((float)(nx - 1), (float)(ny - 1)));
  float2 beyond = scale * (back - (float2)(frame.x0 + edge.x * hx, frame.y0 + edge.y * hy));
  for (int s = 0; s < slots; ++s) {
    float4 q = node_state_at(state_in, nx, ny, s, edge);
    if (!inside) q.xy += beyond;
    q.z += strain * dt;
    if ((reset_mask >> s) & 1) q = (float4)(scale * x + offsets[s], 0.0f, 0.0f);
    state_out[(size_t)s * plane + node] = q;
  }
}

/* The vorticity omega = dv_y/dx - dv_x/dy by central differences of step h. */
static float vorticity_at(const VelocityField* f, __global const float2* grid, float2 x, float t, float h) {
  float2 dvdx = velocity_at(f, grid, x + (float2)(h, 0.0f), t) - velocity_at(f, grid, x - (float2)(h, 0.0f), t);
  float2 dvdy = velocity_at(f, grid, x + (float2)(0.0f, h), t) - velocity_at(f, grid, x - (float2)(0.0f, h), t);
  return (dvdx.y - dvdy.x) / (2.0f * h);
}

/* Bilinear sample of band k's (w_k, theta_k) at node coordinates g, clamped to the grid: fluid entering
 * the region brings the values of the edge it enters by. */
static float2 cascade_at(__global const float2* cascade, int nx, int ny, int k, float2 g) {
  g = clamp(g, (float2)(0.0f), (float2)((float)(nx - 1), (float)(ny - 1)));
  int i = min((int)g.x, nx - 2), j = min((int)g.y, ny - 2);
  float s = g.x - (float)i, r = g.y - (float)j;
  __global const float2* q = cascade + (size_t)k * (size_t)nx * (size_t)ny;
  float2 bottom = mix(q[i + nx * j], q[i + 1 + nx * j], s);
  float2 top = mix(q[i + nx * (j + 1)], q[i + 1 + nx * (j + 1)], s);
  return mix(bottom, top, r);
}

/* One step [0, dt] (times from the step's start) of the vorticity cascade (ADV03 sec. 4): every band's (w_k, theta_k) taken from the
 * node's backtrace, then w_0 = c_w |omega| and, in increasing k with the previous step's w_(k-1),
 * w_k := beta_k w_k + (1 - beta_k) w_(k-1), beta_k = 2^(-dt / tau_k), tau_k = tau tau_ratio^(k-1); and
 * theta_k += w_k dt with the updated w_k. */
__kernel void eulerian_cascade(__global const float2* cascade_in, __global float2* cascade_out, int nx, int ny,
                               OutputGrid frame, int bands, float c_w, float tau, float tau_ratio,
                               VelocityField velocity, __global const float2* grid, float dt) {
  int i = get_global_id(0), j = get_global_id(1);
  if (i >= nx || j >= ny) return;
  float hx = frame.pixel_x * (float)frame.width / (float)(nx - 1);
  float hy = frame.pixel_y * (float)frame.height / (float)(ny - 1);
  float2 x = (float2)(frame.x0 + (float)i * hx, frame.y0 + (float)j * hy);
  float2 back = backtrace(&velocity, grid, x, 0.0f, dt);
  float2 g = (float2)((back.x - frame.x0) / hx, (back.y - frame.y0) / hy);
  float w_0 = c_w * fabs(vorticity_at(&velocity, grid, x, dt, 0.5f * min(hx, hy)));
  float w_coarser = 0.0f; /* w_(k-1) of the previous step */
  for (int k = 0; k < bands; ++k) {
    float2 q = cascade_at(cascade_in, nx, ny, k, g);
    float w = w_0;
    if (k > 0) {
      float beta = exp2(-dt / (tau * pown(tau_ratio, k - 1)));
      w = beta * q.x + (1.0f - beta) * w_coarser;
    }
    w_coarser = q.x;
    cascade_out[(size_t)k * (size_t)nx * (size_t)ny + (size_t)i + (size_t)nx * (size_t)j] = (float2)(w, q.y + w * dt);
  }
}

/* The weights alpha'^i of the layers from their deformations d^i (ADV03 sec. 2.2): the two layers that
 * bracket d*, l* = i + (d* - d^i) / (d^(i+1) - d^i); a running maximum keeps d^i monotone. */
static float select_layers(const float* deformation, int layers, float d_star, float* layer_weight) {
  float level = 0.0f, running = deformation[0];
  for (int i = 0; i < layers; ++i) layer_weight[i] = 0.0f;
  layer_weight[0] = 1.0f;
  for (int i = 0; i + 1 < layers; ++i) {
    float lo = running, hi = max(running, deformation[i + 1]);
    running = hi;
    if (d_star < lo) break;
    layer_weight[i] = 0.0f;
    if (d_star >= hi || hi - lo < 1e-12f) {
      layer_weight[i + 1] = 1.0f;
      level = (float)(i + 1);
      continue;
    }
    float f = (d_star - lo) / (hi - lo);
    layer_weight[i] = 1.0f - f;
    layer_weight[i + 1] = f;
    level = (float)i + f;
    break;
  }
  return level;
}

/* One output pixel: every slot's coordinate and deformation interpolated from the nodes, the layers
 * selected per pixel, the slots' samples blended with weights alpha'^i alpha^i_j. Planes as in
 * lagrangian_reconstruct, with the selected layer l* in the last one. Noise band c's gradients turn by the
 * cascade phase theta_c for c < cascade_bands (0: no cascade; `cascade` is then not read). */
__kernel void eulerian_render(__global float* out, OutputGrid frame, __global const float4* state, int nx, int ny,
                              int layers, int phases, __global const float* alpha, int deformation_mode, float d_star,
                              int blend, TextureSource texture, __global const float* image,
                              __global const float* scalar, __global const float* lut, VelocityField velocity,
                              __global const uchar* mask, __global const float2* cascade, int cascade_bands) {
  int px = get_global_id(0), py = get_global_id(1);
  if (px >= frame.width || py >= frame.height) return;
  float2 p = (float2)(frame.x0 + ((float)px + 0.5f) * frame.pixel_x, frame.y0 + ((float)py + 0.5f) * frame.pixel_y);
  float2 g = (float2)(((float)px + 0.5f) * (float)(nx - 1) / (float)frame.width,
                      ((float)py + 0.5f) * (float)(ny - 1) / (float)frame.height);
  size_t plane = (size_t)frame.width * (size_t)frame.height, pixel = (size_t)px + (size_t)frame.width * (size_t)py;

  float4 q[SQUALL_EULERIAN_MAX_SLOTS];
  float deformation[SQUALL_EULERIAN_MAX_LAYERS], layer_weight[SQUALL_EULERIAN_MAX_LAYERS];
  for (int i = 0; i < layers; ++i) {
    deformation[i] = 0.0f;
    for (int j = 0; j < phases; ++j) {
      int s = i * phases + j;
      q[s] = node_state_at(state, nx, ny, s, g);
      deformation[i] += deformation_mode == SQUALL_DEFORMATION_PAPER ? q[s].z : (float)phases * alpha[s] * q[s].z;
    }
  }
  float level = select_layers(deformation, layers, d_star, layer_weight);
  float theta[SQUALL_TEXTURE_MAX_CHANNELS]; /* band c's cascade phase (ADV03 sec. 4), bilinear from the nodes */
  for (int c = 0; c < SQUALL_TEXTURE_MAX_CHANNELS; ++c)
    theta[c] = c < cascade_bands ? cascade_at(cascade, nx, ny, c, g).y : 0.0f;

  float r[SQUALL_TEXTURE_MAX_CHANNELS], sample[SQUALL_TEXTURE_MAX_CHANNELS];
  float f[SQUALL_LUT_MAX_CHANNELS], blended_final[SQUALL_LUT_MAX_CHANNELS];
  bool final_blend = blend == SQUALL_EULERIAN_FINAL && texture.final_function != SQUALL_FINAL_IDENTITY;
  int finals = final_channels(&texture);
  for (int c = 0; c < texture.channels; ++c) r[c] = 0.0f;
  for (int c = 0; c < SQUALL_LUT_MAX_CHANNELS; ++c) blended_final[c] = 0.0f;
  float s0 = 0.0f, s2 = 0.0f, w_max = 0.0f;
  float2 u_max = (float2)(0.0f);
  int n = 0;
  for (int s = 0; s < layers * phases; ++s) {
    float w = layer_weight[s / phases] * alpha[s];
    if (w <= 0.0f) continue;
    if (w > w_max) w_max = w, u_max = q[s].xy;
    for (int c = 0; c < texture.channels; ++c) {
      sample[c] = texture_channel_turned(&texture, image, c, q[s].xy, theta[c]);
      r[c] += w * (blend == SQUALL_EULERIAN_OCTAVE_VP ? sample[c] - texture.mean[c] : sample[c]);
    }
    if (final_blend) {
      final_values(&texture, scalar, lut, p, sample, f);
      for (int c = 0; c < finals; ++c) blended_final[c] += w * f[c];
    }
    s0 += w;
    s2 += w * w;
    ++n;
  }
  if (blend == SQUALL_EULERIAN_OCTAVE_VP)
    for (int c = 0; c < texture.channels; ++c) r[c] = r[c] / sqrt(max(s2, 1e-12f)) + texture.mean[c];
  write_texture_planes(&texture, scalar, lut, p, r, out, plane, pixel);
  for (int c = 0; final_blend && c < finals; ++c) out[(size_t)c * plane + pixel] = blended_final[c];
  int aux = finals + texture.channels;
  out[(size_t)aux * plane + pixel] = s0;
  out[(size_t)(aux + 1) * plane + pixel] = s2;
  out[(size_t)(aux + 2) * plane + pixel] = velocity_fluid_at(&velocity, mask, p.x, p.y) ? (float)n : -1.0f;
  out[(size_t)(aux + 3) * plane + pixel] = level;
  out[(size_t)(aux + 4) * plane + pixel] = u_max.x;
  out[(size_t)(aux + 5) * plane + pixel] = u_max.y;
}
