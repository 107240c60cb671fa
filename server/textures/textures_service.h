// squall.v1.Textures over a TextureEngine. Requests are translated in textures_request.h and validated by
// the engine under the path "request"; each stream runs one advection, frame by frame.
#pragma once

#include <memory>

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

 private:
  ServingState& serving_;
  std::unique_ptr<textures::TextureEngine> engine_;
};

}  // namespace squall::rpc
