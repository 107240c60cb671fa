#include "daemon/beat.h"

namespace squall::rpc {

Beat::Beat(std::chrono::milliseconds period, std::function<void()> tick)
    : thread_([this, period, tick = std::move(tick)] {
        std::unique_lock<std::mutex> lock(mutex_);
        do {
          lock.unlock();
          tick();
          lock.lock();
        } while (!wake_.wait_for(lock, period, [this] { return stopping_; }));
      }) {}

void Beat::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

}  // namespace squall::rpc
