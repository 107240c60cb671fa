// AdmissionWatch: while squalld serves, four times a second, turns the health name "admission"
// NOT_SERVING when the memory budget is nearly spent (at least kFullShare of --memory-budget reserved,
// what caches keep for the next calls not counted as it is given back to calls that need it: new work
// would be refused RESOURCE_EXHAUSTED, so a balancer of stateless work should send it elsewhere) and
// SERVING again once the reservations fall below kFreeShare (the gap keeps it from flapping). The other
// readiness names stay SERVING: a balancer that hashes sessions to replicas keeps them where they live.
// Every readiness name is NOT_SERVING while this replica cannot write its heartbeat
// (SessionRegistry::beating): its sessions answer UNAVAILABLE then, and that balancer should move them.
// Stopped before the daemon drains, which turns health NOT_SERVING for good.
#pragma once

#include "common/limits.h"
#include "common/session_registry.h"
#include "daemon/beat.h"
#include "daemon/health_service.h"

namespace squall::rpc {

class AdmissionWatch {
 public:
  static constexpr double kFullShare = 0.9, kFreeShare = 0.8;

  AdmissionWatch(const LimitGate& gate, const SessionRegistry& sessions, HealthService& health);
  void stop() { beat_.stop(); }

 private:
  void tick();

  const LimitGate& gate_;
  const SessionRegistry& sessions_;
  HealthService& health_;
  bool memory_free_ = true, beating_ = true, admitting_ = true;  // touched by the beat's thread only
  Beat beat_;                                                    // last: it starts ticking once the members above exist
};

}  // namespace squall::rpc
