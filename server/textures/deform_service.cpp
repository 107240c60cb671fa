// TexturesService's content-aware deformation methods (squall.v1.Textures.DeformTexture and
// DeformInteractive) over the DeformEngine.
#include "common/field_codec.h"
#include "common/validate.h"
#include "rpc/streaming.h"
#include "textures/deform_request.h"
#include "textures/textures_service.h"

namespace squall::rpc {
namespace {

namespace v1 = squall::v1;
using namespace squall::textures;
namespace req = squall::textures::rpc;

// One deformation stream: its spec (as steered so far) and the planes it sends.
struct DeformStream {
  DeformSpec spec;
  DeformPlanes planes;
  v1::DType dtype = v1::DTYPE_FLOAT32;
  Slot decoded;  // the texture's planes, from their decoding until `memory` counts them
  Slot memory;   // the stream's working memory, against --memory-budget
  Slot steered;  // a d mu map steered into a stream that started without one
};

// The planes of `request`, their bytes within --max-message-bytes.
void choose_planes(DeformStream& s, const v1::DeformTextureRequest& request, LimitGate& gate, const std::string& path) {
  s.planes = req::deform_planes(request, path);
  s.dtype = field::dtype(request.dtype(), path + ".dtype");
  gate.check_message_bytes("DeformFrame (ask for fewer texels or planes)", req::frame_bytes(s.spec, s.planes, s.dtype));
}

// The stream's working memory reserved: an estimate, the deformation's state, flow and solve
// (DeformEngine::working_bytes), the planes asked for in the message and serialized, and the spec's own
// planes on the host (the texture, the rigidity and a d mu map), which the stream keeps.
void reserve(DeformStream& s, LimitGate& gate) {
  const DeformSpec& spec = s.spec;
  const uint64_t inputs = sizeof(float) * (spec.pixels.size() + spec.rigidity.size() + spec.control.d_mu_map.size());
  s.decoded = Slot();  // the texture's planes, counted in `inputs`: given back first, not held twice
  s.memory =
      gate.acquire_memory("the deformation's state and frames",
                          DeformEngine::working_bytes(spec) + inputs + 2 * req::frame_bytes(spec, s.planes, s.dtype));
}

// A map steered into a stream that started without one (its control not MAP): the spec's copy and the
// deformation's (DeformEngine::map_bytes) reserved before it is decoded. A later map replaces it.
void reserve_steered_map(DeformStream& s, const v1::DeformControl& message, LimitGate& gate,
                         const std::string& path) {
  if (!message.has_d_mu_map() || !s.spec.control.d_mu_map.empty()) return;
  const uint64_t n = uint64_t(s.spec.width) * uint64_t(s.spec.height);
  s.steered = gate.acquire_memory(path + ".d_mu_map", sizeof(float) * n + DeformEngine::map_bytes(s.spec));
}

v1::DeformFrame encode(const DeformStream& s, Deformation& deformation) {
  v1::DeformFrame out;
  req::fill_frame(deformation.next(s.planes), deformation.flow(), s.planes, s.spec.channels, s.dtype, &out);
  return out;
}

}  // namespace

grpc::Status TexturesService::DeformTexture(grpc::ServerContext* context, const v1::DeformTextureRequest* request,
                                            grpc::ServerWriter<v1::DeformFrame>* writer) {
  auto check = [&] {
    DeformStream s;
    s.spec = req::deform_spec(*request, serving_.gate(), s.decoded);
    deform_->validate(s.spec, "request");
    choose_planes(s, *request, serving_.gate(), "request");
    return s;
  };
  auto prepare = [&](DeformStream& s) { reserve(s, serving_.gate()); };
  return serve_stream(*context, serving_, "DeformTexture", check, prepare, [&](StreamCall& call, DeformStream& s) {
    std::unique_ptr<Deformation> deformation = deform_->start(s.spec, call.cancellation(), &s.memory);
    for (int i = 0; i < s.spec.frames && call.live(); ++i)
      if (!call.write(*writer, encode(s, *deformation))) return;
  });
}

grpc::Status TexturesService::DeformInteractive(grpc::ServerContext* context,
                                                grpc::ServerReaderWriter<v1::DeformFrame, v1::DeformControl>* stream) {
  return serve_stream(*context, serving_, "DeformInteractive", [&](StreamCall& call) {
    DeformStream s;
    std::unique_ptr<Deformation> deformation;
    v1::DeformControl message;
    for (size_t n = 0; call.live() && call.read(*stream, &message); ++n) {
      const std::string path = validate::at("control", n);
      const uint32_t frames = req::deform_control_frames(message, path);
      if (n > 0 && message.has_start())
        fail(Code::InvalidArgument, path + ".start is set: only the first message starts the deformation");
      if (n == 0) {
        s.spec = req::deform_start(message, serving_.gate(), s.decoded, path);
        deform_->validate(s.spec, path + ".start");
        choose_planes(s, message.start(), serving_.gate(), path + ".start");
        reserve(s, serving_.gate());
        deformation = deform_->start(s.spec, call.cancellation(), &s.memory);
      }
      reserve_steered_map(s, message, serving_.gate(), path);
      if (req::steer(message, s.spec, path)) deformation->steer(s.spec.control, path);
      for (uint32_t k = 0; k < frames && call.live(); ++k)
        if (!call.write(*stream, encode(s, *deformation))) return;
    }
  });
}

}  // namespace squall::rpc
