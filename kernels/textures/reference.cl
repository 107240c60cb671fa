/* The reference texture R of a TextureSource (fields.h), unadvected. */
#include "textures/texture.clh"

/* The reference texture registered to the domain, T(S x) (u = S x at each pixel): what every method
 * shows at rest. Same planes as the reconstructions (weight 1, one sample). */
__kernel void texture_window(__global float* out, OutputGrid frame, float scale, TextureSource texture,
                             __global const float* image, __global const float* scalar, __global const float* lut) {
  int px = get_global_id(0), py = get_global_id(1);
  if (px >= frame.width || py >= frame.height) return;
  float2 p = (float2)(frame.x0 + ((float)px + 0.5f) * frame.pixel_x, frame.y0 + ((float)py + 0.5f) * frame.pixel_y);
  size_t plane = (size_t)frame.width * (size_t)frame.height, pixel = (size_t)px + (size_t)frame.width * (size_t)py;
  float r[SQUALL_TEXTURE_MAX_CHANNELS];
  for (int c = 0; c < texture.channels; ++c) r[c] = texture_channel(&texture, image, c, scale * p);
  write_texture_planes(&texture, scalar, lut, p, r, out, plane, pixel);
  int aux = final_channels(&texture) + texture.channels;
  out[(size_t)aux * plane + pixel] = 1.0f;
  out[(size_t)(aux + 1) * plane + pixel] = 1.0f;
  out[(size_t)(aux + 2) * plane + pixel] = 1.0f;
  out[(size_t)(aux + 3) * plane + pixel] = 0.0f;
  out[(size_t)(aux + 4) * plane + pixel] = scale * p.x;
  out[(size_t)(aux + 5) * plane + pixel] = scale * p.y;
}
