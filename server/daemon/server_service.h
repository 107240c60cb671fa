// squall.v1.Server: GetInfo.
#pragma once

#include "daemon/daemon_state.h"
#include "squall/v1/server.grpc.pb.h"

namespace squall::rpc {

class ServerService final : public squall::v1::Server::Service {
 public:
  explicit ServerService(DaemonState& daemon) : daemon_(daemon) {}
  grpc::Status GetInfo(grpc::ServerContext* context, const squall::v1::GetInfoRequest* request,
                       squall::v1::GetInfoResponse* response) override;

 private:
  DaemonState& daemon_;
};

}  // namespace squall::rpc
