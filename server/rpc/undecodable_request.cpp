#include "rpc/undecodable_request.h"

#include <google/protobuf/descriptor.h>

#include <string>

namespace squall::rpc {
namespace {

using grpc::experimental::InterceptionHookPoints;
using grpc::experimental::ServerRpcInfo;

// "/squall.v1.Ocean/GetTile" -> "squall.v1.GetTileRequest", from the generated descriptors; empty for a
// method that is not squall's (gRPC's health and reflection services carry their own messages).
std::string request_type(const std::string& method) {
  if (method.rfind("/squall.", 0) != 0) return "";
  std::string name = method.substr(1);
  const size_t slash = name.find('/');
  if (slash == std::string::npos) return "";
  name[slash] = '.';
  const auto* found = google::protobuf::DescriptorPool::generated_pool()->FindMethodByName(name);
  return found ? found->input_type()->full_name() : "";
}

class UndecodableRequest : public grpc::experimental::Interceptor {
 public:
  // Unary and server-streaming calls have one request, decoded before the handler runs.
  explicit UndecodableRequest(ServerRpcInfo* info)
      : request_type_(info->type() == ServerRpcInfo::Type::UNARY ||
                              info->type() == ServerRpcInfo::Type::SERVER_STREAMING
                          ? request_type(info->method())
                          : "") {}

  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    // The one request of the call, null where gRPC could not decode it.
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::POST_RECV_MESSAGE) && !request_type_.empty())
      undecoded_ = methods->GetRecvMessage() == nullptr;
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_STATUS) && undecoded_ &&
        methods->GetSendStatus().error_code() == grpc::StatusCode::INTERNAL)
      methods->ModifySendStatus(grpc::Status(
          grpc::StatusCode::INVALID_ARGUMENT,
          "request: not a " + request_type_ + " in protobuf's wire format (missing, truncated or garbled)"));
    methods->Proceed();
  }

 private:
  std::string request_type_;  // the one request's protobuf type; empty: not a squall method, or a client stream
  bool undecoded_ = false;
};

}  // namespace

grpc::experimental::Interceptor* UndecodableRequestFactory::CreateServerInterceptor(ServerRpcInfo* info) {
  return new UndecodableRequest(info);
}

}  // namespace squall::rpc
