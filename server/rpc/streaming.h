// The bookkeeping of every streaming handler, written once: the serving check, a --max-streams slot held
// for the whole call, cancellation (client gone, deadline passed, server shutting down) checked before
// each message, and the status the call ends with.
#pragma once

#include <grpcpp/grpcpp.h>

#include <string>

#include "rpc/serving.h"
#include "rpc/status.h"

namespace squall::rpc {

class StreamCall {
 public:
  StreamCall(grpc::ServerContext& context, const char* method) : context_(context), method_(method) {}

  // False once the call is cancelled or a write failed; the handler then stops.
  bool live() const { return !ended_ && !context_.IsCancelled(); }

  // Writes one message unless the call is no longer live; returns live().
  template <typename Writer, typename Message>
  bool write(Writer& writer, const Message& message) {
    if (!live() || !writer.Write(message)) ended_ = true;
    return !ended_;
  }

  grpc::ServerContext& context() { return context_; }

  // OK, or CANCELLED naming the method when the call did not end by itself.
  grpc::Status status() const {
    if (live()) return grpc::Status::OK;
    return grpc::Status(grpc::StatusCode::CANCELLED, method_ + " cancelled (client gone, deadline or shutdown)");
  }

 private:
  grpc::ServerContext& context_;
  std::string method_;
  bool ended_ = false;
};

// Runs a streaming handler's body(StreamCall&) under guarded(), after the serving check and with a stream
// slot; the status is the body's error, else the call's.
template <typename Body>
grpc::Status serve_stream(grpc::ServerContext& context, ServingState& serving, const char* method, Body&& body) {
  return guarded([&] {
    serving.require_serving();
    Slot slot = serving.gate().acquire_stream();  // released on every way out of this call
    StreamCall call(context, method);
    body(call);
    return call.status();
  });
}

// A unary handler's body() -> grpc::Status under guarded(), after the serving check.
template <typename Body>
grpc::Status serve(ServingState& serving, Body&& body) {
  return guarded([&] {
    serving.require_serving();
    return body();
  });
}

}  // namespace squall::rpc
