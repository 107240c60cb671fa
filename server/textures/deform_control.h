// The controls of d mu as the host drives them each frame (G. Guingo et al., "Content-aware texture
// deformation with dynamic control", Computers & Graphics 91, 2020, sec. 5): the running control, and for
// the tensor controls the deformation gradient G of each frame, T = G_now G_before^-1 and A = T A.
#pragma once

#include "textures/deform_spec.h"

namespace squall::textures {

// What deform_step takes for one frame (deform.cl).
struct StepControl {
  int kind = 0;              // DeformControlKind
  double d_mu = 0;           // constant; isotropic: eq. 7's d mu
  double kappa = 1;          // map, anisotropic: the scale (times dt in paper mode)
  Tensor2 t_minus_identity;  // anisotropic: T - I
};

// G at frame `index` of a ramp from `start` at frame 0 to `end` at frame frames - 1, held after.
Tensor2 deformation_ramp(const Tensor2& start, const Tensor2& end, int frames, int index);
// A frame's deformation T = G_now G_before^-1 (sec. 5.1).
Tensor2 frame_deformation(const Tensor2& g_now, const Tensor2& g_before);

class ControlState {
 public:
  explicit ControlState(const DeformSpec& spec);

  // The control of frame `index` (>= 1): G_now from the ramp (or the steered G), T and A moved on.
  StepControl advance(int index);
  // From the next frame on: `control` runs; its deformation_start (tensor controls) is G from then on.
  void steer(const DeformControl& control);
  const DeformControl& control() const { return control_; }
  // T of the next frame were G then `g_now` (a steered deformation).
  Tensor2 next_deformation(const Tensor2& g_now) const { return frame_deformation(g_now, g_before_); }

 private:
  DeformControl control_;
  int frames_;
  double dt_;
  bool held_ = false;  // after a steer: G stays at held_g_
  Tensor2 held_g_, g_before_, a_;
};

}  // namespace squall::textures
