// Host declarations of the content-aware deformation kernels (kernels/textures/deform.cl): each argument
// list once, in the order of the kernel's signature. Shared by the engine and its deformations.
#pragma once

#include "runtime/kernel.h"
#include "runtime/runtime.h"

namespace squall::textures {

constexpr int kDeformChunk = 64;  // items per work-item of the reductions (DEFORM_CHUNK in deform.cl)

struct DeformKernels {
  Kernel<cl::Buffer> real_bytes;  // out
  // p, q, width, height, partial
  Kernel<cl::Buffer, cl::Buffer, cl_int, cl_int, cl::Buffer> cgls_d;
  // r, free_texel, s, width, height, partial
  Kernel<cl::Buffer, cl::Buffer, cl::Buffer, cl_int, cl_int, cl::Buffer> cgls_dt;
  Kernel<cl::Buffer, cl::Buffer, cl_float2, cl_int> cgls_axpy;  // y, x, a (hi, lo), n
  Kernel<cl::Buffer, cl::Buffer, cl_float2, cl_int> cgls_xpby;  // p, s, b (hi, lo), n
  Kernel<cl::Buffer, cl::Buffer, cl_int> flow_store;            // x, flow, n
  // flow, width, height, warp, reference, substeps, kind, d_mu, kappa, tensor, map, strokes, stroke_count,
  // levels, residual, level
  Kernel<cl::Buffer, cl_int, cl_int, cl::Buffer, cl::Buffer, cl_int, cl_int, cl_float, cl_float, cl_float4, cl::Buffer,
         cl::Buffer, cl_int, cl_int, cl::Buffer, cl::Buffer>
      step;
  // images, channels, width, height, warp, levels, residual, level, out
  Kernel<cl::Buffer, cl_int, cl_int, cl_int, cl::Buffer, cl_int, cl::Buffer, cl::Buffer, cl::Buffer> color;
  // flow, width, height, channels, levels, steps, images
  Kernel<cl::Buffer, cl_int, cl_int, cl_int, cl_int, cl_int, cl::Buffer> stack_build;
  // warp, residual, reference, n, levels, partial
  Kernel<cl::Buffer, cl::Buffer, cl::Buffer, cl_int, cl_int, cl::Buffer> stats;
  cl::Buffer none;  // 16 bytes passed for an argument a launch does not use
  int real_size;    // bytes of the flow solve's `real` on this device: 8 (fp64) or 4

  explicit DeformKernels(Runtime& runtime);
};

}  // namespace squall::textures
