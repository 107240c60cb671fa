// squall.v1.Ocean: GetTile, StreamTiles and SampleSurface over an OceanEngine.
#pragma once

#include "ocean/ocean_engine.h"
#include "rpc/capability.h"
#include "rpc/serving.h"
#include "squall/v1/ocean.grpc.pb.h"

namespace squall::rpc {

class OceanService final : public squall::v1::Ocean::Service, public Capability {
 public:
  explicit OceanService(ServingState& serving) : serving_(serving) {}

  grpc::Service& service() override { return *this; }
  const char* service_name() const override { return squall::v1::Ocean::service_full_name(); }
  void start(EngineContext& context) override;

  grpc::Status GetTile(grpc::ServerContext* context, const squall::v1::GetTileRequest* request,
                       squall::v1::GetTileResponse* response) override;
  // Holds a --max-streams slot while it runs; checks for cancellation (client gone, deadline, shutdown)
  // before each frame; carries the whitecap map from frame to frame; computes frame i + 1 while frame i
  // is being sent.
  grpc::Status StreamTiles(grpc::ServerContext* context, const squall::v1::StreamTilesRequest* request,
                           grpc::ServerWriter<squall::v1::TileChunk>* writer) override;
  grpc::Status SampleSurface(grpc::ServerContext* context, const squall::v1::SampleSurfaceRequest* request,
                             squall::v1::SampleSurfaceResponse* response) override;

 private:
  ServingState& serving_;
  ocean::OceanEngine* engine_ = nullptr;  // shared with other capabilities through the EngineContext
};

}  // namespace squall::rpc
