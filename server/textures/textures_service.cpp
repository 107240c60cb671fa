#include "textures/textures_service.h"

#include "common/error.h"
#include "common/validate.h"
#include "ewave/shared_engine.h"
#include "rpc/streaming.h"
#include "textures/textures_request.h"

namespace squall::rpc {
namespace {

namespace v1 = squall::v1;
using namespace squall::textures;
namespace req = squall::textures::rpc;

// One advection stream: its spec (as steered so far), the planes it sends and the eWave session its
// velocity follows ("" for none).
struct Stream {
  AdvectSpec spec;
  req::PlaneSelection planes;
  uint64_t frame_bytes = 0;  // the planes of one frame
  std::string session;
  std::string session_path;  // the request field that named the session
};

// The surface current of an eWave session as a one-frame velocity grid on its cells (du = m).
VelocitySpec current_grid(ewave::SurfaceCurrent current) {
  VelocitySpec v;
  v.kind = SQUALL_VELOCITY_GRID;
  v.nx = int(current.nx);
  v.ny = int(current.ny);
  v.origin_x = 0.5 * current.dx;
  v.origin_y = 0.5 * current.dy;
  v.hx = current.dx;
  v.hy = current.dy;
  v.frames.push_back({current.time, std::move(current.u), std::move(current.v)});
  v.extrapolation = Extrapolation::Clamp;
  return v;
}

}  // namespace

void TexturesService::start(EngineContext& context) {
  engine_ = std::make_unique<TextureEngine>(context.runtime, context.gate);
  ewave_ = &ewave::shared_engine(context);
}

void TexturesService::follow(AdvectSpec& spec, const std::string& session, const std::string& path) {
  ewave::SurfaceCurrent current;
  try {
    current = ewave_->surface_current(session);
  } catch (const Error& e) {
    if (e.code() != Code::NotFound) throw;
    fail(Code::NotFound, path + ": " + e.what());
  }
  if (current.nx < 2 || current.ny < 2)
    fail(Code::InvalidArgument, path + " is a session of " + std::to_string(current.nx) + " x " +
                                    std::to_string(current.ny) + " cells: a followed current needs 2 x 2 or more");
  spec.velocity = current_grid(std::move(current));
}

grpc::Status TexturesService::AdvectTexture(grpc::ServerContext* context, const v1::AdvectTextureRequest* request,
                                            grpc::ServerWriter<v1::TextureFrame>* writer) {
  auto prepare = [&] {
    Stream s;
    s.spec = req::spec(*request, serving_.gate());
    s.planes = req::planes(request->output());
    s.session = req::followed_session(request->velocity());
    s.session_path = "request.velocity.ewave_session";
    if (!s.session.empty()) follow(s.spec, s.session, s.session_path);
    engine_->validate(s.spec, "request");
    s.frame_bytes = req::frame_bytes(s.spec, s.planes);
    serving_.gate().check_message_bytes("TextureFrame (ask for fewer pixels or planes)", s.frame_bytes);
    return s;
  };
  return serve_stream(*context, serving_, "AdvectTexture", prepare, [&](StreamCall& call, Stream& s) {
    std::unique_ptr<Advection> advection = engine_->start(s.spec, request->resume_state());
    const uint32_t every = request->checkpoint_every();
    for (bool first = true; call.live(); first = false) {
      if (!first && !s.session.empty()) {  // the step to this frame uses the session's current now
        follow(s.spec, s.session, s.session_path);
        engine_->steer(*advection, s.spec);
      }
      TextureFrame frame = advection->next();
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
        std::string state = advection->checkpoint();
        serving_.gate().check_message_bytes("TextureFrame.checkpoint with the planes", state.size() + s.frame_bytes);
        out.set_checkpoint(std::move(state));
      }
      if (!call.write(*writer, out) || frame.index + 1 >= s.spec.frames) return;
    }
  });
}

grpc::Status TexturesService::AdvectInteractive(
    grpc::ServerContext* context, grpc::ServerReaderWriter<v1::TextureFrame, v1::TextureControl>* stream) {
  return serve_stream(*context, serving_, "AdvectInteractive", [&](StreamCall& call) {
    Stream s;
    std::unique_ptr<Advection> advection;
    v1::TextureControl control;
    for (size_t n = 0; call.live() && stream->Read(&control); ++n) {
      const std::string path = validate::at("control", n);
      if (n > 0 && control.has_start())
        fail(Code::InvalidArgument, path + ".start is set: only the first message starts the advection");
      if (n == 0) {
        s.spec = req::interactive_start(control, serving_.gate(), path);
        s.planes = req::planes(control.start().output(), path + ".start.output");
        s.session = req::followed_session(control.start().velocity());
        s.session_path = path + ".start.velocity.ewave_session";
      }
      const uint32_t frames = req::control_frames(control, path);
      const bool changed = req::steer(control, s.spec, path);
      if (control.has_velocity()) {
        s.session = req::followed_session(control.velocity());
        s.session_path = path + ".velocity.ewave_session";
      }
      if (!s.session.empty()) follow(s.spec, s.session, s.session_path);
      engine_->validate(s.spec, n == 0 ? path + ".start" : path);
      if (n == 0) {
        s.frame_bytes = req::frame_bytes(s.spec, s.planes);
        serving_.gate().check_message_bytes("TextureFrame (ask for fewer pixels or planes)", s.frame_bytes);
        advection = engine_->start(s.spec);
      } else if (changed || !s.session.empty()) {
        engine_->steer(*advection, s.spec);
      }
      for (uint32_t k = frames; k > 0 && call.live(); --k) {
        v1::TextureFrame out;
        req::fill_frame(advection->next(), s.spec, s.planes, &out);
        if (!call.write(*stream, out)) return;
        if (k > 1 && !s.session.empty()) {
          follow(s.spec, s.session, s.session_path);
          engine_->steer(*advection, s.spec);
        }
      }
    }
  });
}

}  // namespace squall::rpc
