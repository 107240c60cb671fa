// squall.v1.Textures over a TextureEngine. Requests are translated in textures_request.h and validated by
// the engine under the path "request" (AdvectInteractive: "control[n]"); each stream runs one advection,
// frame by frame. A velocity may follow an eWave session: its surface current is read from the daemon's
// eWave engine before each step.
#pragma once

#include <memory>
#include <string>

#include "ewave/ewave_engine.h"
#include "rpc/capability.h"
#include "rpc/serving.h"
#include "squall/v1/textures.grpc.pb.h"
#include "textures/texture_engine.h"

namespace squall::rpc {

class TexturesService final : public squall::v1::Textures::Service, public Capability {
 public:
  explicit TexturesService(ServingState& serving) : serving_(serving) {}

  grpc::Service& service() override { return *this; }
  void start(EngineContext& context) override;

  // Holds a --max-streams slot; starts the advection (or resumes it from resume_state) and writes its
  // frames up to frame `frames - 1`, checking for cancellation before each; a failing frame ends the
  // stream with its status.
  grpc::Status AdvectTexture(grpc::ServerContext* context, const squall::v1::AdvectTextureRequest* request,
                             grpc::ServerWriter<squall::v1::TextureFrame>* writer) override;
  // Holds a --max-streams slot; reads one message, applies it (the first starts the advection), writes
  // the frames it asks for (blocking writes: gRPC flow control), then reads the next.
  grpc::Status AdvectInteractive(
      grpc::ServerContext* context,
      grpc::ServerReaderWriter<squall::v1::TextureFrame, squall::v1::TextureControl>* stream) override;

 private:
  // The spec's velocity: the surface current of eWave session `session`, read now (NOT_FOUND naming `path`).
  void follow(textures::AdvectSpec& spec, const std::string& session, const std::string& path);

  ServingState& serving_;
  std::unique_ptr<textures::TextureEngine> engine_;
  ewave::EWaveEngine* ewave_ = nullptr;  // the daemon's
};

}  // namespace squall::rpc
