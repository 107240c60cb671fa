// Push-pull extrapolation of a vector field from its valid (fluid) nodes to every node: P. Sander,
// J. Snyder, S. Gortler, H. Hoppe, "Texture Mapping Progressive Meshes" (SIGGRAPH 2001), sec. 5.3, the
// extrapolation LTA11 (Yu et al. 2011, sec. 3.3.4) uses so that grid vertices outside the fluid keep
// moving smoothly.
#pragma once

#include <cstdint>
#include <vector>

#include "textures/texture_spec.h"

namespace squall::textures {

// Fills u and v (nx * ny, x fastest) at the nodes where mask is 0: "pull" averages (value * mask, mask)
// over 2x2 blocks level by level; "push" fills each level's empty nodes from the coarser level, bilinearly.
// Valid nodes keep their values. Without any valid node the field becomes zero.
void push_pull(int nx, int ny, const std::vector<uint8_t>& mask, std::vector<float>& u, std::vector<float>& v);

// Whether the kernels sample a grid's solid nodes filled by push-pull (else as given: their bilinear
// samples read solid nodes too).
bool fills_solid_nodes(const VelocitySpec& grid);

// A grid's frame as the kernels sample it.
VelocityFrame sampled_frame(const VelocitySpec& grid, const VelocityFrame& frame);

}  // namespace squall::textures
