#include "daemon/admission_watch.h"

#include <algorithm>

#include "common/log.h"

namespace squall::rpc {

AdmissionWatch::AdmissionWatch(const LimitGate& gate, const SessionRegistry& sessions, HealthService& health)
    : gate_(gate), sessions_(sessions), health_(health), beat_(std::chrono::milliseconds(250), [this] { tick(); }) {}

void AdmissionWatch::tick() {
  // What the caches keep is given back to the calls that need it: not counted as reserved.
  const uint64_t held = gate_.memory_bytes(), cached = std::min(gate_.cached_memory_bytes(), held);
  const double share = double(held - cached) / double(gate_.limits().memory_budget);
  memory_free_ = memory_free_ ? share < kFullShare : share < kFreeShare;
  const bool beating = sessions_.beating(), admitting = memory_free_ && beating;
  const bool beating_changed = beating != beating_, admitting_changed = admitting != admitting_;
  beating_ = beating;
  admitting_ = admitting;
  if (beating_changed || admitting_changed) health_.SetReadiness(beating, admitting);
  if (beating_changed)
    log(LogLevel::Warn, beating ? "SERVING: this replica writes its heartbeat again"
                                : "NOT_SERVING: this replica cannot write its heartbeat");
  if (admitting_changed && !beating_changed)
    log(LogLevel::Warn, "admission ", admitting ? "SERVING: " : "NOT_SERVING: ", int(share * 100),
        "% of --memory-budget reserved");
}

}  // namespace squall::rpc
