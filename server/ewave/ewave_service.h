// squall.v1.EWave: interactive wave sessions over the EWaveEngine of Engines. Requests are translated and
// validated in ewave_request.h; sessions idle past --session-ttl are evicted at the start of every EWave
// call, so an evicted id is NOT_FOUND from the first call after its TTL ran out.
#pragma once

#include "daemon/engines.h"
#include "squall/v1/ewave.grpc.pb.h"

namespace squall::rpc {

class EWaveService final : public squall::v1::EWave::Service {
 public:
  explicit EWaveService(Engines& engines) : engines_(engines) {}

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
  ewave::EWaveEngine& engine();  // ready and with idle sessions evicted
  void step(const squall::v1::EWaveStepRequest& request, squall::v1::EWaveFrame* frame);

  Engines& engines_;
};

}  // namespace squall::rpc
