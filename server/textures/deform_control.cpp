#include "textures/deform_control.h"

#include <algorithm>
#include <cmath>

namespace squall::textures {
namespace {

Tensor2 product(const Tensor2& a, const Tensor2& b) {
  return {a.xx * b.xx + a.xy * b.yx, a.xx * b.xy + a.xy * b.yy, a.yx * b.xx + a.yy * b.yx, a.yx * b.xy + a.yy * b.yy};
}

Tensor2 inverse(const Tensor2& a) {
  const double det = a.determinant();  // > 0 (validated)
  return {a.yy / det, -a.xy / det, -a.yx / det, a.xx / det};
}

double frobenius(const Tensor2& a) { return std::sqrt(a.xx * a.xx + a.xy * a.xy + a.yx * a.yx + a.yy * a.yy); }

bool tensor_kind(DeformControlKind kind) {
  return kind == DeformControlKind::Isotropic || kind == DeformControlKind::Anisotropic;
}

}  // namespace

ControlState::ControlState(const DeformSpec& spec)
    : control_(spec.control), frames_(spec.frames), dt_(spec.dt), g_before_(spec.control.deformation_start) {}

Tensor2 deformation_ramp(const Tensor2& a, const Tensor2& b, int frames, int index) {
  const double f = frames > 1 ? std::min(1.0, double(index) / (frames - 1)) : 0.0;
  return {a.xx + f * (b.xx - a.xx), a.xy + f * (b.xy - a.xy), a.yx + f * (b.yx - a.yx), a.yy + f * (b.yy - a.yy)};
}

Tensor2 frame_deformation(const Tensor2& g_now, const Tensor2& g_before) { return product(g_now, inverse(g_before)); }

StepControl ControlState::advance(int index) {
  const Tensor2 g_now =
      held_ ? held_g_ : deformation_ramp(control_.deformation_start, control_.deformation_end, frames_, index);
  const Tensor2 t = frame_deformation(g_now, g_before_);
  const Tensor2 a_now = product(t, a_);  // A accumulated from the identity
  StepControl out;
  out.kind = int(control_.kind);
  const double scale = control_.paper_dt_factor && tensor_kind(control_.kind) ? dt_ : 1.0;
  out.kappa = control_.kappa * scale;
  if (control_.kind == DeformControlKind::Constant) out.d_mu = control_.d_mu;
  if (control_.kind == DeformControlKind::Isotropic)
    out.d_mu = control_.kappa * (frobenius(a_now) - frobenius(a_)) * scale;  // eq. 7
  out.t_minus_identity = {t.xx - 1, t.xy, t.yx, t.yy - 1};                   // eq. 8 on the device
  g_before_ = g_now;
  a_ = a_now;
  return out;
}

void ControlState::steer(const DeformControl& control) {
  held_g_ = tensor_kind(control.kind) ? control.deformation_start : g_before_;
  held_ = true;
  control_ = control;
}

}  // namespace squall::textures
