// One running content-aware deformation: its state on the device and its frames (deform_run.cpp).
#pragma once

#include <memory>

#include "textures/deform.h"
#include "textures/deform_flow.h"
#include "textures/deform_kernels.h"

namespace squall::textures {

// A validated spec's deformation over a solved flow; builds the resampling stack when asked. The stack's
// build and each frame's step run in slices of texels, asking `cancel` between them (Error(Cancelled)).
std::unique_ptr<Deformation> make_deformation(Runtime& runtime, std::shared_ptr<DeformKernels> kernels,
                                              std::shared_ptr<const FlowField> flow, const DeformSpec& spec,
                                              const Cancellation& cancel = {});

}  // namespace squall::textures
