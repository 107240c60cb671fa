// A request squalld cannot decode is the client's error: INVALID_ARGUMENT, naming the message it expected.
// gRPC's synchronous server answers a unary or server-streaming call whose request is not the method's
// protobuf message (truncated, garbled: bytes protobuf's wire format cannot parse) or is missing with
// INTERNAL and no message,
// before any handler runs; this server interceptor rewrites that status for squall's own methods and the
// health service's.
//
// A client stream's undecodable message cannot be told apart from the end of the client's stream in the
// synchronous API (both end Read() without a message), so those calls end as at the client's half-close.
#pragma once

#include <grpcpp/support/server_interceptor.h>

namespace squall::rpc {

class UndecodableRequestFactory : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  grpc::experimental::Interceptor* CreateServerInterceptor(grpc::experimental::ServerRpcInfo* info) override;
};

}  // namespace squall::rpc
