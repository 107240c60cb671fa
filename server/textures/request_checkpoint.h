// An AdvectTexture checkpoint bound to the request that made it: a fingerprint of the request's fields
// that shape the advection (every field but frames, checkpoint_every and resume_state), then the
// advection's own state (Advection::checkpoint()). A resume_state is taken only by a request of the same
// fingerprint, so that a checkpoint resumed with another dt, texture, velocity or region is refused
// rather than continued as if it were that request's. Part of squall_rpc (includes the protos).
//
// Byte layout (common/byte_codec.h): u32 kCheckpointMagic, u32 kCheckpointFormat, u64 fingerprint
// (64-bit FNV-1a of the request's deterministic serialization with those three fields cleared: fields
// as sent, so a field left unset and one set to its default differ), u64 the state's 64-bit FNV-1a (a
// checkpoint damaged on its way back, a bit flipped or a frame index edited, is refused, not continued
// from a state no stream had), then the state's bytes to the end. A checksum, not a signature: it finds
// damage, not a forger who recomputes it.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "squall/v1/textures.pb.h"

namespace squall::textures::rpc {

constexpr uint32_t kCheckpointMagic = 0x43545153;  // "SQTC", little-endian
constexpr uint32_t kCheckpointFormat = 2;          // 1: no checksum (refused: its state cannot be checked)

// The fingerprint of the fields of `request` that shape its advection.
uint64_t request_fingerprint(const squall::v1::AdvectTextureRequest& request);

// The checkpoint of the request of `fingerprint` whose advection is in `state`.
std::string bind_checkpoint(uint64_t fingerprint, std::string_view state);

// The advection state in `resume_state`, which must be a checkpoint of a request of `fingerprint` holding
// a state: InvalidArgument naming `path` otherwise. The view is into resume_state's bytes.
std::string_view bound_state(std::string_view resume_state, uint64_t fingerprint, const std::string& path);

}  // namespace squall::textures::rpc
