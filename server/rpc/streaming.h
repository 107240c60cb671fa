// The bookkeeping of every streaming handler, written once: the serving check, a --max-streams slot held
// for the whole call, cancellation (client gone, deadline passed, server shutting down) checked before
// each message, and the status the call ends with. When squalld drains, a stream whose x-squall-session names
// no session live here ends before its next message with UNAVAILABLE (reopen it on another replica); one
// that names such a session goes on until the session is checkpointed for another replica, whose calls then
// answer UNAVAILABLE. A stream whose bearer token is dropped when squalld reads its tokens again (SIGHUP)
// ends before its next message with UNAUTHENTICATED. A stream that sent every message it was to make ends OK,
// whatever came after its last.
#pragma once

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <string>

#include "common/cancel.h"
#include "rpc/metadata.h"
#include "rpc/serving.h"
#include "rpc/status.h"

namespace squall::rpc {

class StreamCall {
 public:
  StreamCall(grpc::ServerContext& context, const char* method, const ServingState& serving)
      : context_(context), method_(method), serving_(serving), waiting_(context) {
    serving_.streams().add(&waiting_);
  }
  ~StreamCall() { serving_.streams().remove(&waiting_); }
  StreamCall(const StreamCall&) = delete;
  StreamCall& operator=(const StreamCall&) = delete;

  // Reads the client's next message (false at its end, once the call is cancelled, or when its token was
  // dropped while it waited: that message is not acted on), as time spent waiting on the client.
  template <typename Reader, typename Message>
  bool read(Reader& reader, Message* message) {
    const Waiting waiting(waiting_);
    if (!reader.Read(message)) return false;
    if (token_still_accepted()) return true;
    told_to_stop_ = true;
    return false;
  }

  // Asked before each message is made: false once the call is cancelled, a write failed, squalld drains
  // (streams naming no session live here, asked while draining: the stream's own messages may have resumed
  // it) or the call's token is no longer accepted; the handler then stops, and the call ends with why.
  bool live() const {
    if (still_wanted()) return true;
    told_to_stop_ = true;
    return false;
  }

  // Writes one message, even while squalld drains: what it holds was made (an eWave step is taken, its
  // session checkpointed with it), so it is sent before the stream ends. False when the write failed (the
  // client is gone); whether to make another message is live()'s to say.
  template <typename Writer, typename Message>
  bool write(Writer& writer, const Message& message) {
    if (ended_) return false;
    const Waiting waiting(waiting_);  // a client that reads nothing blocks the write (flow control)
    if (!writer.Write(message)) ended_ = true;
    return !ended_;
  }

  grpc::ServerContext& context() { return context_; }

  // For the engines' long work: requested once the call is no longer live. Work that stops for it throws
  // Error(Cancelled), which serve_stream takes for the handler being stopped.
  Cancellation cancellation() const {
    return Cancellation([this] { return !still_wanted(); });
  }
  void stopped_by_cancellation() { told_to_stop_ = true; }

  // The status of a handler that returned. OK when it ended by itself: every message it was to make was
  // written, whatever happened since (a drain or a SIGHUP after the last frame of a finite stream).
  // Otherwise why it was stopped: DEADLINE_EXCEEDED when it waited on its client past --stream-idle-timeout
  // (for the log: the client sees the cancellation); UNAVAILABLE when squalld drains; UNAUTHENTICATED when
  // its token is no longer accepted; CANCELLED naming the method when the client went away.
  grpc::Status status() const {
    if (waiting_.idled_out)
      return grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED,
                          method_ + " waited on its client past --stream-idle-timeout and was cancelled");
    if (!told_to_stop_ && !ended_ && !context_.IsCancelled()) return grpc::Status::OK;
    if (stopped_by_drain_)
      return grpc::Status(grpc::StatusCode::UNAVAILABLE,
                          method_ + " ended: squalld is shutting down; reopen the stream on another replica");
    if (revoked_)
      return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                          method_ + " ended: its bearer token is no longer accepted (--auth-tokens was read again)");
    return grpc::Status(grpc::StatusCode::CANCELLED, method_ + " cancelled (client gone, deadline or shutdown)");
  }

 private:
  // Marks the stream as waiting on its client for its lifetime (one read or write).
  class Waiting {
   public:
    explicit Waiting(StreamWaiting& w) : w_(w) { w_.since_ns = StreamWatch::now_ns(); }
    ~Waiting() { w_.since_ns = 0; }

   private:
    StreamWaiting& w_;
  };

  // live()'s answer, without taking a no for the handler's: the engines ask it from their worker threads.
  bool still_wanted() const {
    if (!stopped_by_drain_ && serving_.phase() == ServingState::Phase::Draining &&
        !serving_.names_live_session(context_))
      stopped_by_drain_ = true;
    return !ended_ && !context_.IsCancelled() && !stopped_by_drain_ && token_still_accepted();
  }

  // A stream outlives the tokens it was let in with: when they are set again (SIGHUP), its token is checked
  // again at its next live(), and one no longer among them ends the stream.
  bool token_still_accepted() const {
    const uint64_t version = serving_.tokens_version();
    if (version != tokens_checked_.load()) {
      if (!serving_.token_accepted(context_)) revoked_ = true;
      tokens_checked_ = version;
    }
    return !revoked_;
  }

  grpc::ServerContext& context_;
  std::string method_;
  const ServingState& serving_;
  StreamWaiting waiting_;
  mutable std::atomic<uint64_t> tokens_checked_{0};  // the tokens_version() its token was last checked at
  mutable std::atomic<bool> revoked_{false};
  // A write failed (the client is gone). Atomic: engines ask still_wanted() from their worker threads (a
  // stream's next frame is computed while the handler writes the last).
  std::atomic<bool> ended_{false};
  mutable std::atomic<bool> stopped_by_drain_{false};
  // live() or read() said no to the handler, or its work was cancelled: it did not end by itself.
  mutable std::atomic<bool> told_to_stop_{false};
};

// Runs a streaming handler under guarded(): the serving and token checks; check(), the request's validation,
// so that a bad request is refused for what it is even when every slot is taken; a --max-streams slot and
// the client's, given back on every way out; prepare(checked), what the stream sets up before its first
// frame (a river's bake, a followed ocean, its memory: work the slots bound); then run(call, checked). The
// status is the first error thrown, else the call's.
template <typename Check, typename Prepare, typename Run>
grpc::Status serve_stream(grpc::ServerContext& context, ServingState& serving, const char* method, Check&& check,
                          Prepare&& prepare, Run&& run) {
  return guarded([&] {
    serving.require_serving(context);
    serving.require_token(context);
    auto prepared = check();
    Slot slot = serving.gate().acquire_stream();
    Slot client_slot = serving.gate().acquire_client_stream(client_address(context));
    prepare(prepared);
    StreamCall call(context, method, serving);
    try {
      run(call, prepared);
    } catch (const Error& e) {
      if (e.code() != Code::Cancelled) throw;  // work stopped because the call ended: say why it ended
      call.stopped_by_cancellation();
    }
    return call.status();
  });
}

// The same with nothing to set up before the first frame.
template <typename Check, typename Run>
grpc::Status serve_stream(grpc::ServerContext& context, ServingState& serving, const char* method, Check&& check,
                          Run&& run) {
  return serve_stream(
      context, serving, method, check, [](auto&) {}, run);
}

// The same for a stream whose messages are validated one by one as they arrive: run(call).
template <typename Run>
grpc::Status serve_stream(grpc::ServerContext& context, ServingState& serving, const char* method, Run&& run) {
  return serve_stream(
      context, serving, method, [] { return 0; }, [&](StreamCall& call, int) { run(call); });
}

// A unary call's cancellation for the engines: requested once the client is gone, its deadline passed or
// the server shuts down.
inline Cancellation cancellation(const grpc::ServerContext& context) {
  return Cancellation([&context] { return context.IsCancelled(); });
}

// A unary handler's body() -> grpc::Status under guarded(), after the serving and token checks, holding one
// of the --max-calls slots: each call holds a gRPC thread and its request, so that many clients at once are
// refused by name rather than starting a thread each.
template <typename Body>
grpc::Status serve(const grpc::ServerContext& context, ServingState& serving, Body&& body) {
  return guarded([&] {
    serving.require_serving(context);
    serving.require_token(context);
    const Slot call = serving.gate().acquire_call();
    return body();
  });
}

}  // namespace squall::rpc
