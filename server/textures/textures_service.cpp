#include "textures/textures_service.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string_view>
#include <utility>

#include "common/error.h"
#include "common/field_codec.h"
#include "common/validate.h"
#include "ewave/shared_engine.h"
#include "ocean/shared_engine.h"
#include "ocean/spectrum_setup.h"
#include "rpc/streaming.h"
#include "textures/request_checkpoint.h"
#include "textures/river_request.h"
#include "textures/textures_request.h"

namespace squall::rpc {
namespace {

namespace v1 = squall::v1;
using namespace squall::textures;
namespace req = squall::textures::rpc;

// A velocity grid of surface currents on the same nodes (du = m), one frame per current, extrapolated as
// `outside`.
VelocitySpec current_grid(std::vector<SurfaceCurrent> currents, Extrapolation outside) {
  const SurfaceCurrent& first = currents.front();
  VelocitySpec v;
  v.kind = SQUALL_VELOCITY_GRID;
  v.nx = int(first.nx);
  v.ny = int(first.ny);
  v.origin_x = first.origin_x;
  v.origin_y = first.origin_y;
  v.hx = first.dx;
  v.hy = first.dy;
  for (SurfaceCurrent& c : currents) v.frames.push_back({c.time, std::move(c.u), std::move(c.v)});
  v.extrapolation = outside;
  return v;
}

// Whether an ocean tile's current repeats past its output grid's edges: its extent a whole number of every
// layer's patches (each layer periodic over its patch, J. Tessendorf, "Simulating Ocean Water", sec. 4.3).
bool repeats(const ocean::TileSpec& spec) {
  const ocean::OutputGrid grid = ocean::output_grid(spec);
  auto whole = [](double extent, double patch) {
    const double n = extent / patch;
    return n >= 0.5 && std::abs(n - std::round(n)) <= 1e-9 * n;
  };
  return std::all_of(spec.layers.begin(), spec.layers.end(),
                     [&](const ocean::LayerSpec& L) { return whole(grid.lx, L.lx) && whole(grid.ly, L.ly); });
}

// An ocean surface is evaluated at times within a SimTime's range, as GetTile's are: INVALID_ARGUMENT
// naming `path` (the followed velocity) and `what` reaches `t` past it.
void check_ocean_time(const std::string& path, const std::string& what, double t) {
  if (!(std::abs(t) <= kMaxTextureTime))
    fail(Code::InvalidArgument, path + " follows an ocean surface, which is evaluated within +-" +
                                    validate::number(kMaxTextureTime) + " s: " + what +
                                    " reaches t = " + validate::number_apart(t, kMaxTextureTime) + " s");
}

// The same for a whole AdvectTexture: its steps read the current up to its last frame (the first step
// reads t0 .. t0 + dt even for one frame).
void check_ocean_clock(const req::FollowedCurrent& current, const AdvectSpec& spec) {
  if (!current.ocean) return;
  const int64_t steps = std::max<int64_t>(spec.frames - 1, 1);
  check_ocean_time(current.path,
                   "request.frames = " + std::to_string(spec.frames) + " at dt = " + validate::number(spec.dt) +
                       " s from t0 = " + validate::number_apart(spec.t0, kMaxTextureTime) + " s",
                   spec.t0 + double(steps) * spec.dt);
}

// "64 x 64 cells of 0.03125 x 0.03125 m".
std::string describe(const req::FollowedCurrent::Grid& grid) {
  return std::to_string(grid.nx) + " x " + std::to_string(grid.ny) + " cells of " + validate::number(grid.dx) + " x " +
         validate::number(grid.dy) + " m";
}

}  // namespace

// One advection stream: its spec (as steered so far), the planes it sends, the current its velocity follows
// and the river it bakes into its velocity (if any).
struct TexturesService::Stream {
  AdvectSpec spec;
  req::PlaneSelection planes;
  uint64_t frame_bytes = 0;  // the planes of one frame
  req::FollowedCurrent current;
  Slot decoded;         // the texture's image planes, from their decoding until `memory` counts them
  Slot memory;          // the stream's working memory, against --memory-budget
  Slot steered_memory;  // what inputs a later control message sent hold beyond `memory`
  struct River {
    RiverSpec spec;
    BakeGrid grid;
  };
  std::optional<River> river;  // checked, to bake into the velocity
  Cancellation cancel;         // whether its client still wants it: ends a river's bake early
  uint64_t fingerprint = 0;    // of the request, which its checkpoints carry (AdvectTexture, with checkpoints)
  std::string_view resume;     // the advection state it resumes from (AdvectTexture; empty: from frame 0)
  std::string velocity_path;   // the request field its velocity came from (AdvectInteractive's last)
};

req::FollowedCurrent TexturesService::followed(const v1::VelocitySpec& velocity, const std::string& path) {
  req::FollowedCurrent current = req::followed(velocity, serving_.gate(), path);
  if (current.ocean) ocean_->check_transforms(*current.ocean, current.path);
  return current;
}

void TexturesService::start(EngineContext& context) {
  engine_ = std::make_unique<TextureEngine>(context.runtime, context.gate);
  rivers_ = std::make_unique<RiverEngine>(context.runtime, context.gate);
  deform_ = std::make_unique<DeformEngine>(context.runtime, context.gate);
  ewave_ = &ewave::shared_engine(context);
  ocean_ = &ocean::shared_engine(context);
}

void TexturesService::follow(Stream& s, double from) {
  req::FollowedCurrent& followed = s.current;  // session_current() notes the session's grid in it
  if (!followed.any()) return;
  if (followed.ocean) {
    check_ocean_time(followed.path, "the texture's clock", from + s.spec.dt);
    // The spectra the current builds, reserved before it takes the device (as a tile's).
    Slot spectra =
        serving_.gate().acquire_memory(followed.path + "'s spectra", ocean_->new_spectra_bytes(*followed.ocean));
    s.spec.velocity = current_grid({ocean_->surface_current(*followed.ocean, from, &spectra),
                                    ocean_->surface_current(*followed.ocean, from + s.spec.dt, &spectra)},
                                   repeats(*followed.ocean) ? Extrapolation::Wrap : Extrapolation::Clamp);
  } else {
    s.spec.velocity = current_grid({session_current(followed)}, Extrapolation::Clamp);
  }
  validate_followed_current(s.spec.velocity, followed.path);
  validate_made_velocity(s.spec.velocity, serving_.gate(), followed.path);
}

SurfaceCurrent TexturesService::session_current(req::FollowedCurrent& followed) const {
  SurfaceCurrent current;
  try {
    current = ewave_->surface_current(followed.ewave_session);
  } catch (const Error& e) {
    if (e.code() != Code::NotFound) throw;
    fail(Code::NotFound, followed.path + ": " + e.what());
  }
  if (current.nx < 2 || current.ny < 2)
    fail(Code::InvalidArgument, followed.path + " is a session of " + std::to_string(current.nx) + " x " +
                                    std::to_string(current.ny) + " cells: a followed current needs 2 x 2 or more");
  const req::FollowedCurrent::Grid grid{current.nx, current.ny, current.dx, current.dy};
  if (!followed.session_grid) followed.session_grid = grid;
  if (grid != *followed.session_grid)
    fail(Code::Aborted, followed.path + " names a session of " + describe(grid) + " now, not the one of " +
                            describe(*followed.session_grid) +
                            " that the stream began to follow: it was closed and made again under its id");
  return current;
}

void TexturesService::check_river(const v1::VelocitySpec& velocity, Stream& s, const std::string& path) const {
  s.river.reset();
  if (!velocity.has_river()) return;
  Stream::River river{req::river(velocity.river()), req::bake_grid(velocity.river(), s.spec.output)};
  rivers_->validate(river.spec, path + ".river");
  const bool defaulted = !velocity.river().has_bake_region();
  rivers_->validate(river.grid, path + ".river", "bake_",
                    defaulted ? "; bake_region is unset: it is the output's region" : "");
  s.river = std::move(river);
}

void TexturesService::bake_river(Stream& s, const std::string& path) {
  if (!s.river) return;
  Slot memory = serving_.gate().acquire_memory("the river's bake", RiverEngine::bake_bytes(s.river->grid));
  VelocitySpec baked =
      velocity_grid(rivers_->bake(s.river->spec, s.river->grid, path + ".river", s.cancel), path + ".river");
  validate_made_velocity(baked, serving_.gate(), path + ".river");
  s.river.reset();
  s.spec.velocity = std::move(baked);
}

void TexturesService::validate_beside_velocity(Stream& s, const std::string& spec_path) const {
  VelocitySpec velocity = std::exchange(s.spec.velocity, VelocitySpec{});
  try {
    engine_->validate(s.spec, spec_path);
  } catch (...) {
    s.spec.velocity = std::move(velocity);
    throw;
  }
  s.spec.velocity = std::move(velocity);
}

TextureFrame TexturesService::next_frame(Stream& s, Advection& advection, bool refresh) {
  if (refresh && s.current.any()) {  // the step to this frame uses the current read now
    follow(s, advection.time());
    validate_followed_turn(s.spec, s.current.path);
    engine_->steer(advection, s.spec);
  }
  return advection.next();
}

grpc::Status TexturesService::AdvectTexture(grpc::ServerContext* context, const v1::AdvectTextureRequest* request,
                                            grpc::ServerWriter<v1::TextureFrame>* writer) {
  // A river or a current: the velocity is made after the check, under the stream's slot.
  auto velocity_made = [](const Stream& s) { return s.river || s.current.any(); };
  auto check = [&] {
    Stream s;
    s.cancel = cancellation(*context);
    s.current = followed(request->velocity(), "request.velocity");  // before the texture is decoded
    s.spec = req::spec(*request, serving_.gate(), s.decoded);
    if (request->checkpoint_every() > 0 || !request->resume_state().empty()) {
      s.fingerprint = req::request_fingerprint(*request);
      if (!request->resume_state().empty())
        s.resume = req::bound_state(request->resume_state(), s.fingerprint, "request.resume_state");
    }
    s.planes = req::planes(request->output());
    validate_clock(s.spec, "request");
    check_ocean_clock(s.current, s.spec);  // before any frame is sent
    // A river's or a current's velocity is made later: the rest now (the output first, a river's default
    // bake region), the velocity once made.
    if (request->velocity().has_river() || s.current.any())
      validate_beside_velocity(s, "request");
    else
      engine_->validate(s.spec, "request");
    check_river(request->velocity(), s, "request.velocity");
    s.frame_bytes = req::frame_bytes(s.spec, s.planes);
    serving_.gate().check_message_bytes("TextureFrame (ask for fewer pixels or planes)", s.frame_bytes);
    if (request->checkpoint_every() > 0)  // an Eulerian checkpoint holds its slots' and cascade's nodes
      serving_.gate().check_message_bytes(
          "TextureFrame.checkpoint with the planes",
          TextureEngine::eulerian_slot_bytes(s.spec) + TextureEngine::eulerian_cascade_bytes(s.spec) + s.frame_bytes);
    return s;
  };
  auto prepare = [&](Stream& s) {  // the velocity made, and the memory reserved, under the stream's slot
    const bool made = velocity_made(s);
    follow(s, s.spec.t0);
    bake_river(s, "request.velocity");
    if (made) engine_->validate(s.spec, "request");
    s.decoded = Slot();  // counted in stream_bytes: given back first, not held twice
    s.memory =
        serving_.gate().acquire_memory("AdvectTexture's frames and state", req::stream_bytes(s.spec, s.frame_bytes));
  };
  return serve_stream(*context, serving_, "AdvectTexture", check, prepare, [&](StreamCall& call, Stream& s) {
    s.cancel = call.cancellation();  // from now on a drain or a dropped token stops a frame's work too
    std::unique_ptr<Advection> advection = engine_->start(s.spec, s.resume, s.cancel);
    const uint32_t every = request->checkpoint_every();
    for (bool first = true; call.live(); first = false) {
      // Frame 0 takes no step, but a resumed stream's first frame does: read the current each time.
      TextureFrame frame = next_frame(s, *advection, true);
      if (frame.index >= s.spec.frames) {
        if (first)
          fail(Code::InvalidArgument, "request.resume_state is the checkpoint of frame " +
                                          std::to_string(frame.index - 1) +
                                          "; frames = " + std::to_string(s.spec.frames) + " leaves no frame after it");
        return;
      }
      v1::TextureFrame out;
      req::fill_frame(frame, s.spec, s.planes, &out);
      if (every > 0 && frame.index % every == 0) {
        std::string state = req::bind_checkpoint(s.fingerprint, advection->checkpoint());
        serving_.gate().check_message_bytes("TextureFrame.checkpoint with the planes", state.size() + s.frame_bytes);
        out.set_checkpoint(std::move(state));
      }
      if (!call.write(*writer, out) || frame.index + 1 >= s.spec.frames) return;
    }
  });
}

void TexturesService::apply(const v1::TextureControl& control, size_t n, Stream& s,
                            std::unique_ptr<Advection>& advection) {
  const std::string path = validate::at("control", n);
  if (n > 0 && control.has_start())
    fail(Code::InvalidArgument, path + ".start is set: only the first message starts the advection");
  if (n == 0) {
    s.current = followed(control.start().velocity(), path + ".start.velocity");  // before the texture is decoded
    s.spec = req::interactive_start(control, serving_.gate(), s.decoded, path);
    s.planes = req::planes(control.start().output(), path + ".start.output");
  }
  const bool changed = req::steer(control, s.spec, path);
  if (control.has_velocity()) s.current = followed(control.velocity(), path + ".velocity");
  const std::string spec_path = n == 0 ? path + ".start" : path;
  validate_clock(s.spec, spec_path, advection ? advection->time() : s.spec.t0);
  if (s.current.any()) validate_beside_velocity(s, spec_path);  // the rest before the current is read
  follow(s, advection ? advection->time() : s.spec.t0);
  // A message that changes nothing of the stream's clock or velocity: a current the integration cannot
  // follow now is the followed state's doing, not the message's.
  if (n > 0 && s.current.any() && !changed) validate_followed_turn(s.spec, s.current.path);
  const bool started_velocity = n == 0 && !control.has_velocity();  // the start's, unless steered at once
  if (started_velocity || control.has_velocity()) {
    s.velocity_path = path + (started_velocity ? ".start.velocity" : ".velocity");
    const v1::VelocitySpec& velocity = started_velocity ? control.start().velocity() : control.velocity();
    // The rest first (before the bake, seconds on a large grid), the output before the river, whose bake
    // region it is by default.
    if (velocity.has_river()) validate_beside_velocity(s, spec_path);
    check_river(velocity, s, s.velocity_path);
    bake_river(s, s.velocity_path);
  }
  engine_->validate(s.spec, spec_path, s.velocity_path);
  if (n == 0) {
    s.frame_bytes = req::frame_bytes(s.spec, s.planes);
    serving_.gate().check_message_bytes("TextureFrame (ask for fewer pixels or planes)", s.frame_bytes);
    s.decoded = Slot();  // counted in stream_bytes: given back first, not held twice
    s.memory = serving_.gate().acquire_memory("AdvectInteractive's frames and state",
                                              req::stream_bytes(s.spec, s.frame_bytes));
    advection = engine_->start(s.spec, {}, s.cancel);
  } else if (changed || s.current.any()) {
    const uint64_t needed = req::stream_bytes(s.spec, s.frame_bytes);
    if (needed > s.memory.amount() + s.steered_memory.amount()) {
      s.steered_memory = Slot();  // given back before the larger share is asked for, not counted twice
      s.steered_memory = serving_.gate().acquire_memory(path + "'s steered inputs", needed - s.memory.amount());
    }
    engine_->steer(*advection, s.spec);
  }
}

grpc::Status TexturesService::AdvectInteractive(
    grpc::ServerContext* context, grpc::ServerReaderWriter<v1::TextureFrame, v1::TextureControl>* stream) {
  return serve_stream(*context, serving_, "AdvectInteractive", [&](StreamCall& call) {
    Stream s;
    s.cancel = call.cancellation();
    std::unique_ptr<Advection> advection;
    v1::TextureControl control;
    for (size_t n = 0; call.live() && call.read(*stream, &control); ++n) {
      const uint32_t frames = req::control_frames(control, validate::at("control", n));
      apply(control, n, s, advection);
      // The message's own steering (or current) already holds for its first frame's step.
      for (uint32_t k = 0; k < frames && call.live(); ++k) {
        v1::TextureFrame out;
        req::fill_frame(next_frame(s, *advection, k > 0), s.spec, s.planes, &out);
        if (!call.write(*stream, out)) return;
      }
    }
  });
}

grpc::Status TexturesService::BakeVelocity(grpc::ServerContext* context, const v1::BakeVelocityRequest* request,
                                           v1::BakeVelocityReply* reply) {
  return serve(*context, serving_, [&] {
    const RiverSpec river = req::river(request->river());
    const BakeGrid grid = req::bake_grid(*request);
    rivers_->validate(river, "request.river");
    rivers_->validate(grid, "request");
    const uint64_t planes = request->psi() ? 4 : 3;
    const uint64_t reply_bytes =
        planes * uint64_t(grid.nx) * uint64_t(grid.ny) * field::bytes_per_value(request->dtype(), "request.dtype");
    serving_.gate().check_message_bytes("BakeVelocityReply (ask for fewer nodes)", reply_bytes);
    // The bake's and the reply's memory, in the message and serialized.
    Slot memory = serving_.gate().acquire_memory("BakeVelocity's bake and reply",
                                                 RiverEngine::bake_bytes(grid) + 2 * reply_bytes);
    req::fill_bake(rivers_->bake(river, grid, "request.river", cancellation(*context)), *request, reply);
    return grpc::Status::OK;
  });
}

}  // namespace squall::rpc
