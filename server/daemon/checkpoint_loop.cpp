#include "daemon/checkpoint_loop.h"

#include <exception>

#include "common/log.h"

namespace squall::rpc {

CheckpointLoop::CheckpointLoop(SessionRegistry& registry, std::chrono::milliseconds interval,
                               std::chrono::milliseconds ttl)
    : registry_(registry), interval_(interval), ttl_(ttl) {
  if (registry_.state_dir()) thread_ = std::thread([this] { run(); });
}

void CheckpointLoop::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void CheckpointLoop::run() {
  constexpr auto kBeat = std::chrono::milliseconds(250);
  constexpr auto kExpiry = std::chrono::minutes(1);
  auto last_checkpoint = std::chrono::steady_clock::now(), last_expiry = last_checkpoint;
  std::unique_lock<std::mutex> lock(mutex_);
  do {
    lock.unlock();
    try {
      registry_.tick();
      const auto now = std::chrono::steady_clock::now();
      if (interval_.count() > 0 && now - last_checkpoint >= interval_) {
        last_checkpoint = now;
        log(LogLevel::Debug, "state directory: ", registry_.checkpoint_all(false), " sessions checkpointed");
      }
      if (now - last_expiry >= kExpiry) {
        last_expiry = now;
        log(LogLevel::Debug, "state directory: ", registry_.state_dir()->expire(ttl_), " files expired");
      }
    } catch (const std::exception& e) {
      log(LogLevel::Error, "state directory: ", e.what());
    }
    lock.lock();
  } while (!wake_.wait_for(lock, kBeat, [this] { return stopping_; }));
}

}  // namespace squall::rpc
