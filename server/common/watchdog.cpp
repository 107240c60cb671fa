#include "common/watchdog.h"

#include <cstdlib>

#include "common/log.h"

namespace squall {

Watchdog::Watchdog(std::chrono::milliseconds timeout, int exit_code, std::string message)
    : thread_([this, timeout, exit_code, message = std::move(message)] {
        std::unique_lock<std::mutex> lock(mutex_);
        if (disarm_.wait_for(lock, timeout, [this] { return disarmed_; })) return;
        log(LogLevel::Error, message);
        std::_Exit(exit_code);
      }) {}

Watchdog::~Watchdog() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    disarmed_ = true;
  }
  disarm_.notify_all();
  thread_.join();
}

}  // namespace squall
