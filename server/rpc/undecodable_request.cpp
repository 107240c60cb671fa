#include "rpc/undecodable_request.h"

#include <google/protobuf/descriptor.h>

#include <string>
#include <string_view>

namespace squall::rpc {
namespace {

using grpc::experimental::InterceptionHookPoints;
using grpc::experimental::ServerRpcInfo;

// "/squall.v1.Ocean/GetTile" -> "squall.v1.GetTileRequest", from the generated descriptors.
std::string request_type(const std::string& method) {
  std::string name = method.substr(1);
  const size_t slash = name.find('/');
  if (slash != std::string::npos) name[slash] = '.';
  const auto* found = google::protobuf::DescriptorPool::generated_pool()->FindMethodByName(name);
  return found ? found->input_type()->full_name() : "request message";
}

// Watches a call of one request (unary or server-streaming), which gRPC decodes before the handler runs.
class UndecodableRequest : public grpc::experimental::Interceptor {
 public:
  explicit UndecodableRequest(const char* method) : method_(method) {}

  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    // The call's one request, null where gRPC could not decode it.
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::POST_RECV_MESSAGE))
      undecoded_ = methods->GetRecvMessage() == nullptr;
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_STATUS) && undecoded_ &&
        methods->GetSendStatus().error_code() == grpc::StatusCode::INTERNAL)
      methods->ModifySendStatus(grpc::Status(
          grpc::StatusCode::INVALID_ARGUMENT,
          "request: not a " + request_type(method_) + " in protobuf's wire format (missing, truncated or garbled)"));
    methods->Proceed();
  }

 private:
  const char* method_;  // gRPC's, which outlives the call
  bool undecoded_ = false;
};

}  // namespace

// The calls of one request of squall's services and of the health service squalld serves (its reflection
// service is a client stream).
grpc::experimental::Interceptor* UndecodableRequestFactory::CreateServerInterceptor(ServerRpcInfo* info) {
  const bool one_request =
      info->type() == ServerRpcInfo::Type::UNARY || info->type() == ServerRpcInfo::Type::SERVER_STREAMING;
  const std::string_view method = info->method();
  const bool protobuf = method.rfind("/squall.", 0) == 0 || method.rfind("/grpc.health.v1.", 0) == 0;
  return one_request && protobuf ? new UndecodableRequest(info->method()) : nullptr;
}

}  // namespace squall::rpc
