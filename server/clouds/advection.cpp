#include "clouds/advection.h"

namespace squall::clouds {

Vec3d map_semi_lagrangian(const VelocityField& u, const Vec3d& x, double dt) {
  Vec3d v = u(x);
  return {x[0] - v[0] * dt, x[1] - v[1] * dt, x[2] - v[2] * dt};
}

Vec3d map_modified_maccormack(const VelocityField& u, const Vec3d& x, double dt) {
  Vec3d back = map_semi_lagrangian(u, x, dt);
  Vec3d forth = map_semi_lagrangian(u, back, -dt);
  return {back[0] + 0.5 * (x[0] - forth[0]), back[1] + 0.5 * (x[1] - forth[1]), back[2] + 0.5 * (x[2] - forth[2])};
}

Vec3d characteristic_map(const VelocityField& u, const Vec3d& x, double time, int substeps, AdvectionScheme scheme) {
  double dt = time / substeps;
  Vec3d y = x;
  for (int i = 0; i < substeps; ++i)
    y = scheme == AdvectionScheme::SemiLagrangian ? map_semi_lagrangian(u, y, dt) : map_modified_maccormack(u, y, dt);
  return y;
}

VelocityField noise_velocity(const Advection& advection) {
  NoiseParams n = advection.noise;
  double speed = advection.speed;
  return [n, speed](const Vec3d& x) -> Vec3d {
    // Shifts of many noise periods decorrelate the three components.
    const double d1 = 37.17 / n.frequency, d2 = 71.53 / n.frequency;
    return {speed * fractal_noise(n, x), speed * fractal_noise(n, {x[0] + d1, x[1], x[2]}),
            speed * fractal_noise(n, {x[0], x[1] + d2, x[2]})};
  };
}

}  // namespace squall::clouds
