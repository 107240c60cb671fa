// At most kMaxStreams of gRPC's server reflection streams at once. Reflection runs outside squall's
// services, so neither --max-streams nor --max-calls counts it, and each stream holds one of the server's
// threads for as long as its client keeps it open: left unbounded, a few hundred idle reflection streams
// would take every thread of the quota and gRPC would refuse every call, health checks included. A stream
// past the limit is cancelled as it opens (the client sees CANCELLED; the request log and the metrics,
// RESOURCE_EXHAUSTED naming the limit). Serve it before RequestLogFactory, so that the log reads that status.
#pragma once

#include <grpcpp/support/server_interceptor.h>

#include <atomic>

namespace squall::rpc {

class ReflectionLimitFactory : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  static constexpr int kMaxStreams = 16;

  grpc::experimental::Interceptor* CreateServerInterceptor(grpc::experimental::ServerRpcInfo* info) override;

 private:
  std::atomic<int> open_{0};  // reflection streams running now, refused ones included until they end
};

}  // namespace squall::rpc
