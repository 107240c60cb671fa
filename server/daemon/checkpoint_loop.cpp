#include "daemon/checkpoint_loop.h"

#include <exception>

#include "common/log.h"

namespace squall::rpc {

CheckpointLoop::CheckpointLoop(SessionRegistry& registry, std::chrono::milliseconds interval,
                               std::chrono::milliseconds ttl)
    : registry_(registry), interval_(interval), ttl_(ttl) {
  if (registry_.state_dir() && interval_.count() > 0) thread_ = std::thread([this] { run(); });
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
  std::unique_lock<std::mutex> lock(mutex_);
  while (!wake_.wait_for(lock, interval_, [this] { return stopping_; })) {
    lock.unlock();
    try {
      size_t written = registry_.checkpoint_all(false);
      size_t expired = registry_.state_dir()->expire(ttl_);
      log(LogLevel::Debug, "state directory: ", written, " sessions checkpointed, ", expired, " expired");
    } catch (const std::exception& e) {
      log(LogLevel::Error, "state directory: ", e.what());
    }
    lock.lock();
  }
}

}  // namespace squall::rpc
