// Requests that pass every admission limit of a default squalld yet keep a CPU device busy for minutes:
// for the tests that let a deadline pass, cancel or shut down in the middle of long work.
#pragma once

#include "squall/v1/clouds.pb.h"

namespace squall::test {

// A sphere of radius 5 m in voxels of 0.5 m (about 20 m across with its box).
inline v1::CloudModel long_work_sphere() {
  v1::CloudModel m;
  m.set_voxel_size(0.5);
  m.add_spheres()->set_radius(5);
  return m;
}

// 256 x 256 pixels, a 2 mm step and a direct shadow march every 5 cm toward one light: an estimated
// 3e11 density samples (under --max-render-samples = 4e11), minutes on 2 cores.
inline v1::RenderSettings long_render_settings() {
  v1::RenderSettings s;
  auto* c = s.mutable_camera();
  c->mutable_eye()->set_y(-30);
  c->mutable_up()->set_z(1);
  c->set_width(256);
  c->set_height(256);
  s.set_step(0.002);
  s.add_wavelengths(550e-9);
  s.add_extinction(0.5);
  s.set_shadow(v1::SHADOW_MODE_DIRECT);
  s.set_shadow_step(0.05);
  auto* l = s.add_lights();
  l->mutable_direction()->set_z(1);
  l->add_intensity(1000);
  return s;
}

}  // namespace squall::test
