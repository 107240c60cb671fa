#include "daemon/checkpoint_loop.h"

#include <exception>

#include "common/log.h"

namespace squall::rpc {
namespace {

// Runs `part`, logging what it throws: one part's failure does not keep the others from running.
template <typename Part>
void logged(const char* what, Part&& part) {
  try {
    part();
  } catch (const std::exception& e) {
    log(LogLevel::Error, "state directory: ", what, ": ", e.what());
  }
}

}  // namespace

CheckpointLoop::CheckpointLoop(SessionRegistry& registry, std::chrono::milliseconds interval,
                               std::chrono::milliseconds ttl)
    : registry_(registry),
      interval_(interval),
      ttl_(ttl),
      last_checkpoint_(std::chrono::steady_clock::now()),
      last_expiry_(last_checkpoint_) {
  if (!registry_.state_dir()) return;
  heartbeat_ = std::make_unique<Beat>(std::chrono::milliseconds(250), [this] { beat(); });
  beat_ = std::make_unique<Beat>(std::chrono::milliseconds(250), [this] { tick(); });
}

void CheckpointLoop::beat() {
  const bool was_failing = registry_.heartbeat_failing();
  try {
    registry_.heartbeat();
    if (was_failing) log(LogLevel::Info, "state directory: the heartbeat is written again");
  } catch (const std::exception& e) {
    if (!was_failing)
      log(LogLevel::Error, e.what(),
          " (the other replicas take this one for dead at the owner timeout; its sessions answer UNAVAILABLE "
          "until a beat is written)");
  }
}

void CheckpointLoop::tick() {
  constexpr auto kExpiry = std::chrono::minutes(1);
  logged("handovers", [&] { registry_.tick(); });
  const auto now = std::chrono::steady_clock::now();
  if (interval_.count() > 0 && now - last_checkpoint_ >= interval_) {
    last_checkpoint_ = now;
    logged("checkpoints", [&] {
      log(LogLevel::Debug, "state directory: ", registry_.checkpoint_all(false), " sessions checkpointed");
    });
  }
  if (now - last_expiry_ >= kExpiry) {
    last_expiry_ = now;
    logged("expiry", [&] { log(LogLevel::Debug, "state directory: ", registry_.expire(ttl_), " files expired"); });
  }
}

}  // namespace squall::rpc
