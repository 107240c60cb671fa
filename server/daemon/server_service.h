// squall.v1.Server: GetInfo.
#pragma once

#include "daemon/engines.h"
#include "squall/v1/server.grpc.pb.h"

namespace squall::rpc {

class ServerService final : public squall::v1::Server::Service {
 public:
  explicit ServerService(Engines& engines) : engines_(engines) {}
  grpc::Status GetInfo(grpc::ServerContext* context, const squall::v1::GetInfoRequest* request,
                       squall::v1::GetInfoResponse* response) override;

 private:
  Engines& engines_;
};

}  // namespace squall::rpc
