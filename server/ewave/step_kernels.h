// Host declarations of the eWave kernels: each argument list once, in the order of the kernel's
// signature (kernels/ewave/step_impl.clh, obstruction.cl). Real is the state's type: cl_float for
// step.cl, cl_double for step_f64.cl. Sizes and flags are cl_int, as everywhere in squall's kernels.
#pragma once

#include <type_traits>
#include <variant>

#include "runtime/kernel.h"
#include "runtime/runtime.h"

namespace squall::ewave {

constexpr int kOutputFields = 9;  // h, phi, eps_x, eps_y, D_x, D_y, dDx/dx, dDy/dy, dDx/dy (ewave_propagate)

template <typename Real>
struct StepKernels {
  using RealType = Real;
  static constexpr const char* kProgram = std::is_same_v<Real, cl_double> ? "ewave/step_f64.cl" : "ewave/step.cl";

  // state, nx, ny, obstruction, has_obstruction, ambient, has_ambient, trim_x, trim_y, has_trim,
  // source_h, has_source_h, source_phi, has_source_phi, source_scale, decay, gain
  Kernel<cl::Buffer, cl_int, cl_int, cl::Buffer, cl_int, cl::Buffer, cl_int, cl::Buffer, cl::Buffer, cl_int, cl::Buffer,
         cl_int, cl::Buffer, cl_int, Real, Real, Real>
      prepare;
  // spectrum, coefficients, nx, ny, kx_unit, ky_unit, fields
  Kernel<cl::Buffer, cl::Buffer, cl_int, cl_int, Real, Real, cl_int> propagate;
  // work, fields, state, out, nx, ny, drift_mode, shift_x, shift_y, drift_x, drift_y, dt_over_dx,
  // dt_over_dy, obstruction, has_obstruction, mask_phi, trim_x, trim_y, has_trim, displacement_scale;
  // ewave_finish (no drift: drift_mode and the shifts are not read) and ewave_finish_advect
  using Finish = Kernel<cl::Buffer, cl_int, cl::Buffer, cl::Buffer, cl_int, cl_int, cl_int, Real, Real, cl::Buffer,
                        cl::Buffer, Real, Real, cl::Buffer, cl_int, cl_int, cl::Buffer, cl::Buffer, cl_int, Real>;
  Finish finish, finish_advect;

  StepKernels() = default;
  explicit StepKernels(Runtime& runtime)
      : prepare(runtime, kProgram, "ewave_prepare"),
        propagate(runtime, kProgram, "ewave_propagate"),
        finish(runtime, kProgram, "ewave_finish"),
        finish_advect(runtime, kProgram, "ewave_finish_advect") {}
};

// The step kernels of either precision.
using AnyStepKernels = std::variant<StepKernels<cl_float>, StepKernels<cl_double>>;

inline AnyStepKernels make_step_kernels(Runtime& runtime, bool double_precision) {
  if (double_precision) return AnyStepKernels(std::in_place_index<1>, runtime);
  return AnyStepKernels(std::in_place_index<0>, runtime);
}

// obstruction, shapes (EWaveShape), shape_count, vertices, nx, ny, dx, dy, reset
using RasterizeKernel = Kernel<cl::Buffer, cl::Buffer, cl_int, cl::Buffer, cl_int, cl_int, cl_float, cl_float, cl_int>;

inline RasterizeKernel make_rasterize_kernel(Runtime& runtime) {
  return RasterizeKernel(runtime, "ewave/obstruction.cl", "ewave_rasterize");
}

}  // namespace squall::ewave
