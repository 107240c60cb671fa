// squall.v1 deformation messages (DeformTextureRequest, DeformControl, DeformFrame) <-> the deform engine's
// structs. Part of squall_rpc (includes the protos).
#pragma once

#include <cstdint>
#include <string>

#include "common/limits.h"
#include "squall/v1/textures.pb.h"
#include "textures/deform.h"

namespace squall::textures::rpc {

// Translates; what translation reads throws InvalidArgument naming the field under `path` (an unknown
// enum, a Field of the wrong size, an unset rigidity); range checks happen in DeformEngine::validate.
// The texture's decoded planes are held in `decoded` as spec() holds them.
DeformSpec deform_spec(const squall::v1::DeformTextureRequest& request, LimitGate& gate, Slot& decoded,
                       const std::string& path = "request");
DeformPlanes deform_planes(const squall::v1::DeformTextureRequest& request, const std::string& path = "request");

// DeformInteractive's first message: its start (required, frames 0) with frames = 1.
DeformSpec deform_start(const squall::v1::DeformControl& control, LimitGate& gate, Slot& decoded,
                        const std::string& path);
// The frames a message asks for: 1 when unset, else 0..1024.
uint32_t deform_control_frames(const squall::v1::DeformControl& control, const std::string& path);
// A message's changes applied to the running control (its tensor in deformation_start, as
// Deformation::steer takes it); true when it changes any. Deformation::steer checks the result.
bool steer(const squall::v1::DeformControl& message, DeformSpec& spec, const std::string& path);

// Bytes of the planes of one frame.
uint64_t frame_bytes(const DeformSpec& spec, const DeformPlanes& planes, squall::v1::DType dtype);
void fill_frame(const DeformFrame& frame, const FlowSolve& flow, const DeformPlanes& planes, int channels,
                squall::v1::DType dtype, squall::v1::DeformFrame* out);

}  // namespace squall::textures::rpc
