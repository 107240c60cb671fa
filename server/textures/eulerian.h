// Eulerian texture advection on nodes over the output region: F. Neyret, "Advected Textures" (SCA 2003),
// N layers of regenerated texture coordinates with latencies, chosen per pixel from their accumulated
// deformation (sec. 2) and blended before the final function (sec. 3). The same engine runs the game
// engines' two-phase flow map (one layer, two phases with triangle weights) and naive advection (one
// parameterization never regenerated). With EulerianParams::cascade the multi-layer method also advects the
// vorticity cascade of sec. 4, which turns the noise bands with the flow's vorticity.
#pragma once

#include <memory>
#include <string>
#include <string_view>

#include "common/cancel.h"
#include "textures/advection.h"
#include "textures/device_inputs.h"
#include "textures/texture_kernels.h"

namespace squall::textures {

// `state` (from checkpoint()) resumes where it was taken; empty starts at t0. The advection asks `cancel`
// while it lays out its start and before each substep (Error(Cancelled)).
std::unique_ptr<Advection> make_eulerian(Runtime& runtime, TextureKernels& kernels, const AdvectSpec& spec,
                                         std::shared_ptr<const DeviceInputs> inputs, std::string_view state,
                                         const Cancellation& cancel = {});

}  // namespace squall::textures
