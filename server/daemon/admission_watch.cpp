#include "daemon/admission_watch.h"

#include <algorithm>

#include "common/log.h"

namespace squall::rpc {

AdmissionWatch::AdmissionWatch(const LimitGate& gate, const SessionRegistry& sessions,
                               grpc::HealthCheckServiceInterface& health)
    : gate_(gate), sessions_(sessions), health_(health), beat_(std::chrono::milliseconds(250), [this] { tick(); }) {}

void AdmissionWatch::tick() {
  // What the caches keep is given back to the calls that need it: not counted as reserved.
  const uint64_t held = gate_.memory_bytes(), cached = std::min(gate_.cached_memory_bytes(), held);
  const double share = double(held - cached) / double(gate_.limits().memory_budget);
  memory_free_ = memory_free_ ? share < kFullShare : share < kFreeShare;
  const bool beating = sessions_.beating();
  const bool next = memory_free_ && beating;
  if (next == serving_) return;
  serving_ = next;
  health_.SetServingStatus(serving_);
  log(LogLevel::Warn, serving_ ? "SERVING: " : "NOT_SERVING: ", int(share * 100), "% of --memory-budget reserved",
      beating ? "" : "; this replica cannot write its heartbeat");
}

}  // namespace squall::rpc
