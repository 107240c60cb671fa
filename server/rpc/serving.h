// The serving state every service shares: the limit gate and whether squalld takes work (kernels
// built and not draining). Services hold a reference; the daemon owns it and flips it.
#pragma once

#include <atomic>
#include <chrono>

#include "common/limits.h"

namespace squall::rpc {

class ServingState {
 public:
  explicit ServingState(const Limits& limits) : gate_(limits) {}

  LimitGate& gate() { return gate_; }
  const LimitGate& gate() const { return gate_; }

  // Starting -> Serving (every capability started) -> Draining (SIGTERM/SIGINT).
  enum class Phase { Starting, Serving, Draining };
  void set_phase(Phase phase) { phase_ = phase; }
  Phase phase() const { return phase_; }
  bool serving() const { return phase_ == Phase::Serving; }

  // Every handler calls this first: UNAVAILABLE while kernels are being built or while draining.
  void require_serving() const;

  double uptime_seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  }

 private:
  LimitGate gate_;
  std::atomic<Phase> phase_{Phase::Starting};
  const std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
};

}  // namespace squall::rpc
