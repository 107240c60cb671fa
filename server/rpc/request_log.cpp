#include "rpc/request_log.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>

#include <chrono>
#include <string>

#include "common/log.h"
#include "common/validate.h"
#include "common/status_names.h"
#include "rpc/metadata.h"

namespace squall::rpc {
namespace {

using grpc::experimental::InterceptionHookPoints;

class RequestLog : public grpc::experimental::Interceptor {
 public:
  RequestLog(grpc::experimental::ServerRpcInfo* info, const std::string& replica, Metrics* metrics)
      : method_(info->method()), replica_(replica), metrics_(metrics), start_(std::chrono::steady_clock::now()) {}

  ~RequestLog() override {
    if (!logged_) write("CANCELLED", "");  // the call ended without a status: client went away
  }

  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::POST_RECV_INITIAL_METADATA)) {
      const auto& metadata = *methods->GetRecvInitialMetadata();
      id_ = metadata_value(metadata, kRequestIdKey);
      session_ = session_routing_key(metadata);
    }
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_INITIAL_METADATA) && !replica_.empty())
      name_replica(methods);
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_MESSAGE) && metrics_)
      count_sent(methods->GetSendMessage());
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::POST_RECV_MESSAGE) && id_.empty() &&
        is_squall_method())
      id_ = request_id_field(methods->GetRecvMessage());
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_STATUS)) {
      grpc::Status status = methods->GetSendStatus();
      write(status_code_name(status.error_code()), status.ok() ? "" : status.error_message());
    }
    methods->Proceed();
  }

 private:
  // Only squall's own services are known to carry protobuf messages (gRPC's built-in health service
  // receives raw bytes), so only theirs are read.
  bool is_squall_method() const { return method_.rfind("/squall.", 0) == 0; }

  // Every squall request is a protobuf message; the field is found by name, so any service gets it.
  static std::string request_id_field(void* message) {
    if (!message) return "";
    auto* m = static_cast<google::protobuf::Message*>(message);
    const auto* field = m->GetDescriptor()->FindFieldByName("request_id");
    if (!field || field->type() != google::protobuf::FieldDescriptor::TYPE_STRING || field->is_repeated()) return "";
    return m->GetReflection()->GetString(*m, field).substr(0, kMaxMetadataValue);
  }

  // x-squall-replica: in the initial metadata, unless this batch also ends the call with an error: then
  // in the trailing metadata, so the failure stays a trailers-only response, which a client's gRPC retry
  // policy may retry (response headers would commit the call to this replica).
  void name_replica(grpc::experimental::InterceptorBatchMethods* methods) {
    const bool fails_now =
        methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_STATUS) && !methods->GetSendStatus().ok();
    auto* metadata = fails_now ? methods->GetSendTrailingMetadata() : methods->GetSendInitialMetadata();
    metadata->emplace(kReplicaKey, replica_);
  }

  // A response message: squall's are protobuf messages (their size is counted); gRPC's own, raw bytes.
  void count_sent(const void* message) {
    if (!message || !is_squall_method()) return;
    metrics_->record_sent(method_, static_cast<const google::protobuf::Message*>(message)->ByteSizeLong());
  }

  // Client text as one word of the log line: escaped, and its spaces too.
  static std::string word(const std::string& text) {
    std::string out;
    for (char c : validate::printable(text, kMaxMetadataValue)) out += c == ' ' ? "\\x20" : std::string(1, c);
    return out;
  }

  void write(const char* status, const std::string& message) {
    logged_ = true;
    double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_).count();
    if (metrics_) metrics_->record_call(method_, status, ms / 1000);
    // Client strings (the ids, and the error, which may quote the request) escaped: one call, one line, and
    // the unquoted ids one word each, so that no id can add fields of its own.
    log(LogLevel::Info, "request id=", id_.empty() ? "-" : word(id_), " method=", method_, " status=", status,
        " duration_ms=", ms, " replica=", replica_.empty() ? "-" : replica_,
        session_.empty() ? "" : " session=" + word(session_),
        message.empty() ? "" : " error=\"" + validate::printable(message, 1024) + "\"");
  }

  std::string method_;
  const std::string& replica_;  // the factory's, which outlives the server
  Metrics* metrics_;            // likewise; null: none
  std::string id_;
  std::string session_;  // x-squall-session, when the client names one
  std::chrono::steady_clock::time_point start_;
  bool logged_ = false;
};

}  // namespace

grpc::experimental::Interceptor* RequestLogFactory::CreateServerInterceptor(grpc::experimental::ServerRpcInfo* info) {
  return new RequestLog(info, replica_id_, metrics_);
}

}  // namespace squall::rpc
