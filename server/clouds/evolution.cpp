#include "clouds/evolution.h"

#include <algorithm>
#include <cmath>

#include "common/error.h"
#include "common/validate.h"

namespace squall::clouds {
namespace {

void move(Vec3d& p, const Vec3d& v, double t) {
  for (int a = 0; a < 3; ++a) p[a] += v[a] * t;
}
void move_pattern(NoiseParams& n, const Vec3d& v, double t) {
  for (int a = 0; a < 3; ++a) n.offset[a] -= v[a] * t;  // N_t(x) = N_0(x - v t)
}

}  // namespace

void validate(const Evolution& e, const std::string& f) {
  validate::finite_xyz(f + ".drift", e.drift);
  validate::finite_xyz(f + ".noise_drift", e.noise_drift);
  validate::finite(f + ".amplitude_rate", e.amplitude_rate);
  validate::non_negative(f + ".advection_rate", e.advection_rate);
  validate::finite_xyz(f + ".velocity_drift", e.velocity_drift);
}

CloudModel model_at(const CloudModel& base, const Evolution& e, double t) {
  CloudModel m = base;
  for (auto& s : m.spheres) move(s.center, e.drift, t);
  for (auto& s : m.ellipsoids) move(s.center, e.drift, t);
  for (auto& mesh : m.meshes)
    for (auto& v : mesh.vertices) move(v, e.drift, t);
  for (auto& p : m.particles) {
    move(p.center, e.drift, t);
    move_pattern(p.noise, e.noise_drift, t);
  }
  // The patterns of the stages switched on only: one left as sent is validated as sent, and an error after a
  // long drift names a noise of a stage the model has.
  if (m.pyroclastic.layers > 0) move_pattern(m.pyroclastic.noise, e.noise_drift, t);
  m.pyroclastic.amplitude = std::max(0.0, m.pyroclastic.amplitude + e.amplitude_rate * t);
  if (m.temperature.enabled) move_pattern(m.temperature.noise, e.noise_drift, t);
  m.advection.time = std::max(0.0, m.advection.time + e.advection_rate * t);
  if (m.advection.speed > 0) move_pattern(m.advection.noise, e.velocity_drift, t);
  return m;
}

}  // namespace squall::clouds
