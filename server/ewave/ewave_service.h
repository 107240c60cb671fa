// squall.v1.EWave: interactive wave sessions over an EWaveEngine. Requests are translated and validated in
// ewave_request.h; sessions idle past --session-ttl are evicted lazily, so an evicted id is NOT_FOUND from
// the first call after its TTL ran out. Calls that create a session announce its id as x-squall-session.
#pragma once

#include "ewave/ewave_engine.h"
#include "rpc/capability.h"
#include "rpc/serving.h"
#include "squall/v1/ewave.grpc.pb.h"

namespace squall::rpc {

class EWaveService final : public squall::v1::EWave::Service, public Capability {
 public:
  explicit EWaveService(ServingState& serving) : serving_(serving) {}

  grpc::Service& service() override { return *this; }
  const char* service_name() const override { return squall::v1::EWave::service_full_name(); }
  void start(EngineContext& context) override;
  void evict_idle() override {
    if (engine_) engine_->evict_idle();
  }

  grpc::Status CreateSession(grpc::ServerContext* context, const squall::v1::EWaveCreateSessionRequest* request,
                             squall::v1::EWaveSessionResponse* response) override;
  grpc::Status Step(grpc::ServerContext* context, const squall::v1::EWaveStepRequest* request,
                    squall::v1::EWaveFrame* response) override;
  // Holds a --max-streams slot while it runs; reads one request, steps, writes its frame (a blocking
  // write: gRPC flow control), and checks for cancellation (client gone, deadline, shutdown) each time.
  // Everything per stream lives on this call's stack and goes when it returns.
  grpc::Status Run(grpc::ServerContext* context,
                   grpc::ServerReaderWriter<squall::v1::EWaveFrame, squall::v1::EWaveStepRequest>* stream) override;
  grpc::Status GetState(grpc::ServerContext* context, const squall::v1::EWaveSessionRequest* request,
                        squall::v1::EWaveStateResponse* response) override;
  grpc::Status Restore(grpc::ServerContext* context, const squall::v1::EWaveRestoreRequest* request,
                       squall::v1::EWaveSessionResponse* response) override;
  grpc::Status CloseSession(grpc::ServerContext* context, const squall::v1::EWaveSessionRequest* request,
                            squall::v1::EWaveCloseResponse* response) override;

 private:
  void step(const squall::v1::EWaveStepRequest& request, const Cancellation& cancel, squall::v1::EWaveFrame* frame);

  ServingState& serving_;
  ewave::EWaveEngine* engine_ = nullptr;  // the daemon's, shared with the textures that follow its sessions
};

}  // namespace squall::rpc
