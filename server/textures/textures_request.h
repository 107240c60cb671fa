// squall.v1 Textures messages <-> the textures engine's structs: published defaults for unset optional
// fields, the named analytic velocity parameters put in fields.h's params[] order, Fields decoded, and
// frames encoded as Fields. Part of squall_rpc (includes the protos).
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "common/limits.h"
#include "ocean/ocean_params.h"
#include "squall/v1/textures.pb.h"
#include "textures/advection.h"
#include "textures/texture_spec.h"

namespace squall::textures::rpc {

// The planes a reply carries (TextureOutput.planes) and their element type.
struct PlaneSelection {
  bool final_planes = true, raw_planes = false, weight_sum = false, weight_sq_sum = false, coverage = false,
       layer = false, uv = false;
  squall::v1::DType dtype = squall::v1::DTYPE_FLOAT32;
};

// Translates; what translation itself reads throws InvalidArgument naming the proto field under `path`:
// an unknown enum value, a Field of the wrong shape, dtype or byte count, an image with both channels and
// a PNG, an unreadable PNG, and the values whose engine names differ from the proto's (the named velocity
// parameters, image values, the grid's origin and spacing, the output's size and region). A PNG larger
// than --max-grid-cells is RESOURCE_EXHAUSTED before it is decoded. The other range checks happen in
// TextureEngine::validate under the same path. An image's decoded planes are held in `decoded` (acquired
// from `gate`'s memory budget before they are allocated: RESOURCE_EXHAUSTED past it) until the call's own
// reservation counts them.
AdvectSpec spec(const squall::v1::AdvectTextureRequest& request, LimitGate& gate, Slot& decoded,
                const std::string& path = "request");
PlaneSelection planes(const squall::v1::TextureOutput& output, const std::string& path = "request.output");

// An image's planes (kind SQUALL_TEXTURE_IMAGE), translated as AdvectTexture's texture.image.
TextureSpec image_texture(const squall::v1::ImageTexture& image, LimitGate& gate, Slot& decoded,
                          const std::string& path);
// A Field that must be an nx x ny plane (the texture's size), decoded: InvalidArgument naming `path`.nx,
// .ny, .nz, .dtype or .data otherwise.
std::vector<float> image_plane(const squall::v1::Field& field, const std::string& path, uint32_t nx, uint32_t ny);

// A velocity read from another engine before each step: the surface current of an eWave session or of an
// ocean tile. spec() leaves such a velocity (and a river's) an empty grid, which the caller fills before
// validation.
struct FollowedCurrent {
  std::string ewave_session;             // velocity.ewave_session
  std::optional<ocean::TileSpec> ocean;  // velocity.ocean, validated (ocean::validate_current)
  std::string path;                      // the request field that names it
  bool any() const { return !ewave_session.empty() || ocean.has_value(); }
  // The eWave session's grid at the first read of its current, which the stream was validated and reserved
  // for: a later read of another grid (the session closed and made again under its id) is refused.
  struct Grid {
    int64_t nx = 0, ny = 0;
    double dx = 0, dy = 0;
    bool operator==(const Grid&) const = default;
  };
  std::optional<Grid> session_grid;
};
FollowedCurrent followed(const squall::v1::VelocitySpec& velocity, const LimitGate& gate, const std::string& path);

// AdvectInteractive. The first message's start (required; frames, checkpoint_every and resume_state
// unset), translated like spec() under `path`.start, with frames = 1.
AdvectSpec interactive_start(const squall::v1::TextureControl& control, LimitGate& gate, Slot& decoded,
                             const std::string& path);
// The frames a message asks for: 1 when unset, else 0..kMaxControlFrames.
constexpr int64_t kMaxControlFrames = 1024;
uint32_t control_frames(const squall::v1::TextureControl& control, const std::string& path);
// A message's changes applied to the running spec: velocity, dt, substeps, spin (noise only), final_scale;
// true when it changes any. The result is validated by TextureEngine::validate like a request.
bool steer(const squall::v1::TextureControl& control, AdvectSpec& spec, const std::string& path);

// Bytes of the planes one frame carries (the Fields' data).
uint64_t frame_bytes(const AdvectSpec& spec, const PlaneSelection& planes);
// Memory an advection stream holds, an estimate for the memory budget: every plane the engine computes, in
// float32, on the device and on the host; the planes sent (`frame_bytes`) in the message and serialized; the
// advection's state and its inputs (an image's planes among them).
uint64_t stream_bytes(const AdvectSpec& spec, uint64_t frame_bytes);

// The frame's index, time, selected planes (placed on the output pixels) and statistics.
void fill_frame(const TextureFrame& frame, const AdvectSpec& spec, const PlaneSelection& planes,
                squall::v1::TextureFrame* out);

}  // namespace squall::textures::rpc
