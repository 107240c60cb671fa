#include "textures/textures_service.h"

#include "common/error.h"
#include "rpc/streaming.h"
#include "textures/textures_request.h"

namespace squall::rpc {
namespace {

namespace v1 = squall::v1;
using namespace squall::textures;
namespace req = squall::textures::rpc;

struct Stream {
  AdvectSpec spec;
  req::PlaneSelection planes;
  uint64_t frame_bytes = 0;  // the planes of one frame
};

// The frames of `advection` up to frame spec.frames - 1. A resumed advection starts after its
// checkpoint's frame; one already at the last frame has nothing left to send.
void write_frames(StreamCall& call, Advection& advection, const Stream& s, const v1::AdvectTextureRequest& request,
                  const LimitGate& gate, grpc::ServerWriter<v1::TextureFrame>& writer) {
  const uint32_t every = request.checkpoint_every();
  for (bool first = true; call.live(); first = false) {
    TextureFrame frame = advection.next();
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
      std::string state = advection.checkpoint();
      gate.check_message_bytes("TextureFrame.checkpoint with the planes", state.size() + s.frame_bytes);
      out.set_checkpoint(std::move(state));
    }
    if (!call.write(writer, out) || frame.index + 1 >= s.spec.frames) return;
  }
}

}  // namespace

void TexturesService::start(EngineContext& context) {
  engine_ = std::make_unique<TextureEngine>(context.runtime, context.gate);
}

grpc::Status TexturesService::AdvectTexture(grpc::ServerContext* context, const v1::AdvectTextureRequest* request,
                                            grpc::ServerWriter<v1::TextureFrame>* writer) {
  auto prepare = [&] {
    Stream s{req::spec(*request, serving_.gate()), req::planes(request->output())};
    engine_->validate(s.spec, "request");
    s.frame_bytes = req::frame_bytes(s.spec, s.planes);
    serving_.gate().check_message_bytes("TextureFrame (ask for fewer pixels or planes)", s.frame_bytes);
    return s;
  };
  return serve_stream(*context, serving_, "AdvectTexture", prepare, [&](StreamCall& call, const Stream& s) {
    std::unique_ptr<Advection> advection = engine_->start(s.spec, request->resume_state());
    write_frames(call, *advection, s, *request, serving_.gate(), *writer);
  });
}

}  // namespace squall::rpc
