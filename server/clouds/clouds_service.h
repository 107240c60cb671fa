// squall.v1.Clouds over a CloudEngine. Requests are translated in clouds_request.h and validated by the
// engine (messages name the request field); stored volumes past their TTL are dropped lazily. Kept
// volumes are announced as x-squall-session.
#pragma once

#include <memory>

#include "clouds/cloud_engine.h"
#include "rpc/capability.h"
#include "rpc/serving.h"
#include "squall/v1/clouds.grpc.pb.h"

namespace squall::rpc {

class CloudsService final : public squall::v1::Clouds::Service, public Capability {
 public:
  explicit CloudsService(ServingState& serving) : serving_(serving) {}

  grpc::Service& service() override { return *this; }
  const char* service_name() const override { return squall::v1::Clouds::service_full_name(); }
  void start(EngineContext& context) override;
  // squall_stored_volumes, squall_stored_volume_bytes (host trees + device uploads).
  std::vector<CapabilityGauge> gauges() const override;
  void evict_idle() override {  // stored volumes
    if (engine_) engine_->evict_expired();
  }

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
  // RESOURCE_EXHAUSTED naming settings.step when the render's estimated samples pass --max-render-samples.
  void check_work(const clouds::DeviceVolume& volume, const clouds::RenderSettings& settings) const;

  ServingState& serving_;
  std::unique_ptr<clouds::CloudEngine> engine_;
};

}  // namespace squall::rpc
