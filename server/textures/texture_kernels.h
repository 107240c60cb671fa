// Host declarations of the texture kernels (kernels/textures/): each argument list once, in the order of
// the kernel's signature.
#pragma once

#include "runtime/kernel.h"
#include "runtime/runtime.h"
#include "textures/fields.h"

SQUALL_KERNEL_STRUCT(VelocityField)
SQUALL_KERNEL_STRUCT(TextureSource)
SQUALL_KERNEL_STRUCT(OutputGrid)

namespace squall::textures {

struct TextureKernels {
  // positions, count, velocity, grid, dt, substeps
  Kernel<cl::Buffer, cl_int, VelocityField, cl::Buffer, cl_float, cl_int> lagrangian_advect;
  // out, frame, tile_offsets, tile_grids, grid_boxes, bucket_offsets, bucket_quads, positions, uvs, weights,
  // grid_res, blend, texture, image, scalar, lut, velocity, mask
  Kernel<cl::Buffer, OutputGrid, cl::Buffer, cl::Buffer, cl::Buffer, cl::Buffer, cl::Buffer, cl::Buffer, cl::Buffer,
         cl::Buffer, cl_int, cl_int, TextureSource, cl::Buffer, cl::Buffer, cl::Buffer, VelocityField, cl::Buffer>
      lagrangian_reconstruct;
  // state_in, state_out, nx, ny, frame, slots, velocity, grid, dt, scale, reset_mask, offsets
  Kernel<cl::Buffer, cl::Buffer, cl_int, cl_int, OutputGrid, cl_int, VelocityField, cl::Buffer, cl_float, cl_float,
         cl_int, cl::Buffer>
      eulerian_advect;
  // cascade_in, cascade_out, nx, ny, frame, bands, c_w, tau, tau_ratio, velocity, grid, dt
  Kernel<cl::Buffer, cl::Buffer, cl_int, cl_int, OutputGrid, cl_int, cl_float, cl_float, cl_float, VelocityField,
         cl::Buffer, cl_float>
      eulerian_cascade;
  // out, frame, state, nx, ny, layers, phases, alpha, deformation_mode, d_star, blend, texture, image,
  // scalar, lut, velocity, mask, cascade, cascade_bands
  Kernel<cl::Buffer, OutputGrid, cl::Buffer, cl_int, cl_int, cl_int, cl_int, cl::Buffer, cl_int, cl_float, cl_int,
         TextureSource, cl::Buffer, cl::Buffer, cl::Buffer, VelocityField, cl::Buffer, cl::Buffer, cl_int>
      eulerian_render;
  // out, frame, scale, texture, image, scalar, lut
  Kernel<cl::Buffer, OutputGrid, cl_float, TextureSource, cl::Buffer, cl::Buffer, cl::Buffer> texture_window;

  explicit TextureKernels(Runtime& runtime)
      : lagrangian_advect(runtime, "textures/lagrangian.cl", "lagrangian_advect"),
        lagrangian_reconstruct(runtime, "textures/lagrangian.cl", "lagrangian_reconstruct"),
        eulerian_advect(runtime, "textures/eulerian.cl", "eulerian_advect"),
        eulerian_cascade(runtime, "textures/eulerian.cl", "eulerian_cascade"),
        eulerian_render(runtime, "textures/eulerian.cl", "eulerian_render"),
        texture_window(runtime, "textures/reference.cl", "texture_window") {}
};

}  // namespace squall::textures
