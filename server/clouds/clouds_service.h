// squall.v1.Clouds over the CloudEngine of Engines. Requests are translated in clouds_request.h and
// validated by the engine (messages name the request field); stored volumes past their TTL are dropped
// at the start of every call.
#pragma once

#include "daemon/engines.h"
#include "squall/v1/clouds.grpc.pb.h"

namespace squall::rpc {

class CloudsService final : public squall::v1::Clouds::Service {
 public:
  explicit CloudsService(Engines& engines) : engines_(engines) {}

  grpc::Status BuildVolume(grpc::ServerContext* context, const squall::v1::BuildVolumeRequest* request,
                           squall::v1::BuildVolumeResponse* response) override;
  grpc::Status Render(grpc::ServerContext* context, const squall::v1::RenderRequest* request,
                      squall::v1::RenderResponse* response) override;
  // Holds a --max-streams slot; builds and renders one frame per time, checking for cancellation before
  // each; a failing frame ends the stream with its status.
  grpc::Status StreamEvolution(grpc::ServerContext* context, const squall::v1::StreamEvolutionRequest* request,
                               grpc::ServerWriter<squall::v1::EvolutionFrame>* writer) override;
  grpc::Status ReleaseVolume(grpc::ServerContext* context, const squall::v1::ReleaseVolumeRequest* request,
                             squall::v1::ReleaseVolumeResponse* response) override;

 private:
  clouds::CloudEngine& engine();

  Engines& engines_;
};

}  // namespace squall::rpc
