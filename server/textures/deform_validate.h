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

}  // namespace squall::textures
