// squall::Watchdog: ends the process with `exit_code` unless it is destroyed within `timeout`. The last
// resort of a shutdown that must end in bounded time even when some piece of work ignores cancellation.
#pragma once

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

namespace squall {

class Watchdog {
 public:
  // Arms it: after `timeout`, logs `message` as an error and calls std::_Exit(exit_code) (no destructors
  // run: the work that holds them is what overran).
  Watchdog(std::chrono::milliseconds timeout, int exit_code, std::string message);
  ~Watchdog();  // disarms it
  Watchdog(const Watchdog&) = delete;
  Watchdog& operator=(const Watchdog&) = delete;

 private:
  std::mutex mutex_;
  std::condition_variable disarm_;
  bool disarmed_ = false;
  std::thread thread_;
};

}  // namespace squall
