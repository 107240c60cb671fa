#include "rpc/reflection_limit.h"

#include <grpcpp/server_context.h>

#include <string>
#include <string_view>

namespace squall::rpc {
namespace {

using grpc::experimental::InterceptionHookPoints;

// Holds one place among the open reflection streams from the call's start to its end; cancels the call
// as its metadata arrives, before the handler reads, when it found no place. The status it records (the
// request log, which runs after it, and the metrics) says why; the client, cancelled, sees CANCELLED.
class ReflectionStream : public grpc::experimental::Interceptor {
 public:
  ReflectionStream(grpc::experimental::ServerRpcInfo* info, std::atomic<int>& open)
      : info_(info), open_(open), refused_(open.fetch_add(1) >= ReflectionLimitFactory::kMaxStreams) {}
  ~ReflectionStream() override { open_.fetch_sub(1); }

  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    if (refused_ && methods->QueryInterceptionHookPoint(InterceptionHookPoints::POST_RECV_INITIAL_METADATA))
      info_->server_context()->TryCancel();
    if (refused_ && methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_STATUS))
      methods->ModifySendStatus(grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                                             "reflection: " + std::to_string(ReflectionLimitFactory::kMaxStreams) +
                                                 " streams open, the most squalld serves at once"));
    methods->Proceed();
  }

 private:
  grpc::experimental::ServerRpcInfo* info_;
  std::atomic<int>& open_;
  const bool refused_;
};

}  // namespace

grpc::experimental::Interceptor* ReflectionLimitFactory::CreateServerInterceptor(
    grpc::experimental::ServerRpcInfo* info) {
  const bool reflection = std::string_view(info->method()).rfind("/grpc.reflection.", 0) == 0;
  return reflection ? new ReflectionStream(info, open_) : nullptr;
}

}  // namespace squall::rpc
