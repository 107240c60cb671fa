// The checks of a content-aware deformation's spec and of a steered control (field names as the proto's).
#pragma once

#include <string>

#include "common/limits.h"
#include "textures/deform_spec.h"

namespace squall::textures {

// Every field of `spec` under `path` (INVALID_ARGUMENT), its cells within --max-grid-cells.
void validate_deform(const DeformSpec& spec, const LimitGate& gate, const std::string& path);

// A control for a width x height texture: "<prefix>d_mu", "<prefix>strokes[0].radius", ...; `tensor_name`
// is the field that carries G (deformation_start in a spec, deformation when steered).
void validate_control(const DeformControl& control, int width, int height, const std::string& prefix,
                      const std::string& tensor_name);

// An ANISOTROPIC control's frame deformation T: vb^T T vb > 0 for every direction vb (T's symmetric part
// positive definite), else INVALID_ARGUMENT naming `field` and `frame`: eq. 8's log(vb^T T vb) is
// undefined for the texels whose flow points where T turns a direction by 90 degrees or more.
void validate_anisotropic_step(const Tensor2& t, const std::string& field, const std::string& frame);

}  // namespace squall::textures
