// One log line per request: its id, method, status and duration (and the session the client names in
// x-squall-session), written by a server interceptor so no handler has to remember. The id is the "x-request-id" metadata, else the request's `request_id`
// field, else "-".
#pragma once

#include <grpcpp/support/server_interceptor.h>

namespace squall::rpc {

class RequestLogFactory : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  grpc::experimental::Interceptor* CreateServerInterceptor(grpc::experimental::ServerRpcInfo* info) override;
};

}  // namespace squall::rpc
