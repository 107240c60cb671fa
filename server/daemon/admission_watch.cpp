#include "daemon/admission_watch.h"

#include "common/log.h"

namespace squall::rpc {

AdmissionWatch::AdmissionWatch(const LimitGate& gate, grpc::HealthCheckServiceInterface& health)
    : gate_(gate), health_(health), thread_([this] { run(); }) {}

void AdmissionWatch::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void AdmissionWatch::run() {
  constexpr auto kBeat = std::chrono::milliseconds(250);
  const double budget = double(gate_.limits().memory_budget);
  bool admitting = true;
  std::unique_lock<std::mutex> lock(mutex_);
  while (!wake_.wait_for(lock, kBeat, [this] { return stopping_; })) {
    const double share = double(gate_.memory_bytes()) / budget;
    const bool next = admitting ? share < kFullShare : share < kFreeShare;
    if (next == admitting) continue;
    admitting = next;
    health_.SetServingStatus(admitting);
    log(LogLevel::Warn, admitting ? "SERVING: " : "NOT_SERVING: ", int(share * 100), "% of --memory-budget reserved");
  }
}

}  // namespace squall::rpc
