// The horizontal velocity of the water surface on a regular grid, as the wave engines produce it for
// the textures that follow the water: u = grad phi of linear potential flow (J. Tessendorf, "Gilligan: A
// Prototype Framework for Simulating and Rendering Maritime Environments" (2017), eq 11, on the surface),
// plus a uniform drift current where the engine has one.
#pragma once

#include <cstdint>
#include <vector>

namespace squall {

struct SurfaceCurrent {
  int64_t nx = 0, ny = 0;             // nodes
  double origin_x = 0, origin_y = 0;  // m, position of node (0, 0)
  double dx = 0, dy = 0;              // m, node spacing
  double time = 0;                    // s
  std::vector<float> u, v;            // m/s, nx * ny each, x fastest
};

// current.u, current.v = grad phi of a velocity potential phi (m^2/s) on the current's nx x ny nodes of a
// periodic domain, by central differences: a mode of wavenumber k is differentiated with the factor
// sin(k h) / (k h) ~ 1 - (k h)^2 / 6.
void periodic_gradient(const std::vector<float>& phi, SurfaceCurrent& current);

}  // namespace squall
