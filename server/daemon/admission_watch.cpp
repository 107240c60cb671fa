#include "daemon/admission_watch.h"

#include "common/log.h"

namespace squall::rpc {

AdmissionWatch::AdmissionWatch(const LimitGate& gate, grpc::HealthCheckServiceInterface& health)
    : gate_(gate), health_(health), beat_(std::chrono::milliseconds(250), [this] { tick(); }) {}

void AdmissionWatch::tick() {
  const double share = double(gate_.memory_bytes()) / double(gate_.limits().memory_budget);
  const bool next = admitting_ ? share < kFullShare : share < kFreeShare;
  if (next == admitting_) return;
  admitting_ = next;
  health_.SetServingStatus(admitting_);
  log(LogLevel::Warn, admitting_ ? "SERVING: " : "NOT_SERVING: ", int(share * 100), "% of --memory-budget reserved");
}

}  // namespace squall::rpc
