#include "daemon/admission_watch.h"

#include <algorithm>

#include "common/log.h"

namespace squall::rpc {

AdmissionWatch::AdmissionWatch(const LimitGate& gate, grpc::HealthCheckServiceInterface& health)
    : gate_(gate), health_(health), beat_(std::chrono::milliseconds(250), [this] { tick(); }) {}

void AdmissionWatch::tick() {
  // What the caches keep is given back to the calls that need it: not counted as reserved.
  const uint64_t held = gate_.memory_bytes(), cached = std::min(gate_.cached_memory_bytes(), held);
  const double share = double(held - cached) / double(gate_.limits().memory_budget);
  const bool next = admitting_ ? share < kFullShare : share < kFreeShare;
  if (next == admitting_) return;
  admitting_ = next;
  health_.SetServingStatus(admitting_);
  log(LogLevel::Warn, admitting_ ? "SERVING: " : "NOT_SERVING: ", int(share * 100), "% of --memory-budget reserved");
}

}  // namespace squall::rpc
