// DeformEngine: the kernels of kernels/textures/deform.cl, the checks, and the flow solves kept for reuse
// (G. Guingo et al., "Content-aware texture deformation with dynamic control", Computers & Graphics 91, 2020).
#include "textures/deform.h"

#include "textures/deform_flow.h"
#include "textures/deform_run.h"
#include "textures/deform_validate.h"

namespace squall::textures {
namespace {

constexpr char kProgram[] = "textures/deform.cl";

int probe_real_size(Runtime& runtime, Kernel<cl::Buffer>& probe) {
  cl::Buffer out(runtime.context(), CL_MEM_WRITE_ONLY, sizeof(cl_int));
  cl_int size = 0;
  auto lock = runtime.exclusive();
  probe.launch(cl::NDRange(1), cl::NullRange, out);
  runtime.queue().enqueueReadBuffer(out, CL_TRUE, 0, sizeof(size), &size);
  return size;
}

}  // namespace

DeformKernels::DeformKernels(Runtime& runtime)
    : real_bytes(runtime, kProgram, "deform_real_bytes"),
      cgls_d(runtime, kProgram, "deform_cgls_d"),
      cgls_dt(runtime, kProgram, "deform_cgls_dt"),
      cgls_axpy(runtime, kProgram, "deform_cgls_axpy"),
      cgls_xpby(runtime, kProgram, "deform_cgls_xpby"),
      flow_store(runtime, kProgram, "deform_flow_store"),
      step(runtime, kProgram, "deform_step"),
      color(runtime, kProgram, "deform_color"),
      stack_build(runtime, kProgram, "deform_stack_build"),
      stats(runtime, kProgram, "deform_stats"),
      none(runtime.context(), CL_MEM_READ_WRITE, 16),
      real_size(probe_real_size(runtime, real_bytes)) {}

struct DeformEngine::Impl {
  Impl(Runtime& r, LimitGate& g) : runtime(r), gate(g), kernels(std::make_shared<DeformKernels>(r)), flows(&g) {}
  Runtime& runtime;
  LimitGate& gate;
  std::shared_ptr<DeformKernels> kernels;
  FlowCache flows;
};

DeformEngine::DeformEngine(Runtime& runtime, LimitGate& gate) : impl_(std::make_unique<Impl>(runtime, gate)) {}

DeformEngine::~DeformEngine() = default;

void DeformEngine::validate(const DeformSpec& spec, const std::string& path) const {
  validate_deform(spec, impl_->gate, path);
}

std::unique_ptr<Deformation> DeformEngine::start(const DeformSpec& spec, const Cancellation& cancel, Slot* reserved) {
  std::shared_ptr<const FlowField> flow = impl_->flows.find(spec);
  if (!flow) {
    flow = solve_flow(impl_->runtime, *impl_->kernels, spec, cancel);
    impl_->flows.keep(spec, flow, reserved);
  }
  if (reserved) reserved->give_back(solve_bytes(spec));
  return make_deformation(impl_->runtime, impl_->kernels, std::move(flow), spec, cancel);
}

}  // namespace squall::textures
