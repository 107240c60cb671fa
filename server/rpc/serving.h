// The serving state every service shares: the limit gate and whether squalld takes work (kernels
// built and not draining). Services hold a reference; the daemon owns it and flips it.
#pragma once

#include <grpcpp/server_context.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "common/limits.h"
#include "common/session_registry.h"
#include "rpc/stream_watch.h"

namespace squall::rpc {

class ServingState {
 public:
  explicit ServingState(const Limits& limits) : gate_(limits), streams_(limits.stream_idle_seconds) {}

  LimitGate& gate() { return gate_; }
  const LimitGate& gate() const { return gate_; }
  // The streaming calls, watched for waiting on their clients past --stream-idle-timeout.
  StreamWatch& streams() const { return streams_; }

  // Starting -> Serving (every capability started) -> Draining (SIGTERM/SIGINT).
  enum class Phase { Starting, Serving, Draining };
  void set_phase(Phase phase) { phase_ = phase; }
  Phase phase() const { return phase_; }
  bool serving() const { return phase_ == Phase::Serving; }

  // Every handler calls this first: UNAVAILABLE while kernels are being built, and while draining, except
  // for calls that name a session live here (x-squall-session): those go on until their session has been
  // checkpointed for another replica (SessionStore answers UNAVAILABLE then, and refuses new sessions).
  void require_serving(const grpc::ServerContext& context) const;
  // The daemon's sessions (set before serving starts): which ids are live here.
  void set_sessions(SessionRegistry* sessions) { sessions_ = sessions; }
  // Whether the call's x-squall-session names a session live here; any other value names none.
  bool names_live_session(const grpc::ServerContext& context) const;

  // This replica's name (squalld --replica-id), sent back on every call as x-squall-replica.
  void set_replica_id(std::string id) { replica_id_ = std::move(id); }
  const std::string& replica_id() const { return replica_id_; }

  // --auth-tokens: the accepted bearer tokens (none: every caller is let in); replaced as a whole when
  // squalld re-reads the file (SIGHUP), while calls check theirs.
  void set_tokens(std::vector<std::string> tokens) {
    auto next = std::make_shared<const std::vector<std::string>>(std::move(tokens));
    std::lock_guard<std::mutex> lock(tokens_mutex_);
    tokens_ = std::move(next);
    tokens_version_.fetch_add(1);
  }
  // How many times the tokens were set: an open stream checks its token again when this has changed.
  uint64_t tokens_version() const { return tokens_version_.load(); }
  // With tokens set: UNAUTHENTICATED unless the call's "authorization" metadata is "Bearer <token>" (the
  // scheme in any case) with one of them, compared in constant time; the message says nothing about which
  // part was wrong.
  void require_token(const grpc::ServerContext& context) const;
  bool token_accepted(const grpc::ServerContext& context) const;  // require_token's test, as a bool

  double uptime_seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  }

 private:
  LimitGate gate_;
  mutable StreamWatch streams_;
  mutable std::mutex tokens_mutex_;  // guards the pointer; the vector it points to never changes
  std::shared_ptr<const std::vector<std::string>> tokens_ = std::make_shared<const std::vector<std::string>>();
  std::atomic<uint64_t> tokens_version_{0};
  std::string replica_id_;               // set before serving starts, read-only afterwards
  SessionRegistry* sessions_ = nullptr;  // likewise
  std::atomic<Phase> phase_{Phase::Starting};
  const std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
};

}  // namespace squall::rpc
