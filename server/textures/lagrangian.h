// Lagrangian texture advection (the primary method): Q. Yu, F. Neyret, E. Bruneton, N. Holzschuch,
// "Lagrangian Texture Advection: Preserving both Spectrum and Velocity Field", IEEE TVCG 17(11), 2011.
// Particles in a dynamic Poisson-disk distribution (sec. 3.3.1) carry G x G grids mapped to patches of the
// reference texture; the vertices follow the flow on the device (sec. 3.3.2); the host kills distorted,
// folded, uncovering and crowded particles, fades them out, inserts new ones (sec. 3.3.2-3.3.4) and weighs
// the vertices (eqs. 5-8); the device rebuilds each frame directly (sec. 3.5.1) with eq. 4 or eq. 3.
#pragma once

#include <cstddef>
#include <memory>
#include <string_view>

#include "common/cancel.h"
#include "textures/advection.h"
#include "textures/device_inputs.h"
#include "textures/texture_kernels.h"

namespace squall::textures {

// The most grids an advection of `spec` holds, ALIVE and FADING: twice the area of the output region grown
// by d on each side over d^2.
size_t lagrangian_grid_bound(const LagrangianParams& params, const OutputSpec& output);
inline size_t lagrangian_grid_bound(const AdvectSpec& spec) {
  return lagrangian_grid_bound(spec.lagrangian, spec.output);
}

// The most entries a frame's tile lists hold (a grid in each 16 x 16-pixel reconstruction tile its bounds
// meet): kTileSpread times what the most grids take at rest. Past it the most spread grids are deleted
// (FADING before ALIVE): a grid fading for a long fade_tau in a shear flow spreads over ever more tiles.
inline constexpr double kTileSpread = 4;
uint64_t lagrangian_tile_bound(const LagrangianParams& params, const OutputSpec& output);

// `state` (from checkpoint()) resumes where it was taken; empty starts at t0. The advection asks `cancel`
// before each frame and between the slices of its reconstruction (Error(Cancelled)).
std::unique_ptr<Advection> make_lagrangian(Runtime& runtime, TextureKernels& kernels, const AdvectSpec& spec,
                                           std::shared_ptr<const DeviceInputs> inputs, std::string_view state,
                                           const Cancellation& cancel = {});

}  // namespace squall::textures
