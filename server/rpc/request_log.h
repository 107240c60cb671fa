// One log line per request (and its metrics: metrics.h): its id, method, status and duration, the replica that served it, and the
// session the client names in x-squall-session, written by a server interceptor so no handler has to
// remember. The id is the "x-request-id" metadata, else the request's `request_id` field, else "-".
// The same interceptor tells every client which replica answered: x-squall-replica in the initial
// metadata (rpc/metadata.h), so tests and operators behind a proxy see where each call went.
#pragma once

#include <grpcpp/support/server_interceptor.h>

#include <string>

#include "rpc/metrics.h"

namespace squall::rpc {

class RequestLogFactory : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  // `metrics` (may be null: none) outlives the server.
  RequestLogFactory(std::string replica_id, Metrics* metrics) : replica_id_(std::move(replica_id)), metrics_(metrics) {}
  grpc::experimental::Interceptor* CreateServerInterceptor(grpc::experimental::ServerRpcInfo* info) override;

 private:
  std::string replica_id_;
  Metrics* metrics_;
};

}  // namespace squall::rpc
