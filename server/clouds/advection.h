// Characteristic maps for advection (eqs 115-117 of J. Tessendorf, "Gilligan: A Prototype Framework for
// Simulating and Rendering Maritime Environments" (2017), and eqs 11-13 of its App. E, J. Tessendorf,
// "Advection Solver Performance with Long Time Steps, and Strategies for Fast and Accurate Numerical
// Implementation" (2015)). u is steady over the map; the substep maps compose:
// X(x, n dt) = X(X(x, (n-1) dt), dt) (App E eq 16).
#pragma once

#include <functional>

#include "clouds/model.h"

namespace squall::clouds {

using VelocityField = std::function<Vec3d(const Vec3d&)>;

// X_SL(x, dt) = x - u(x) dt  (eq 117; App E eq 11). A negative dt gives the forward map.
Vec3d map_semi_lagrangian(const VelocityField& u, const Vec3d& x, double dt);
// X_MM(x, dt) = X_SL(x, dt) + (x - X_SL(X_SL(x, dt), -dt)) / 2  (App E eq 13, modified MacCormack).
Vec3d map_modified_maccormack(const VelocityField& u, const Vec3d& x, double dt);
// The map over `time` in `substeps` equal steps of `scheme`.
Vec3d characteristic_map(const VelocityField& u, const Vec3d& x, double time, int substeps, AdvectionScheme scheme);

// The noise velocity of App D eq 3.9: speed (FS(x), FS(x + d1), FS(x + d2)), FS the normalized fractal
// noise and d1, d2 fixed decorrelating shifts; |u| <= sqrt(3) speed.
VelocityField noise_velocity(const Advection& advection);

}  // namespace squall::clouds
