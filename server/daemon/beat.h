// Beat: calls `tick` at once and then every `period` on a thread of its own, until stop() (or the
// destructor) wakes and joins it. The daemon's background loops (checkpoints, admission) run on one.
#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

namespace squall::rpc {

class Beat {
 public:
  Beat(std::chrono::milliseconds period, std::function<void()> tick);
  ~Beat() { stop(); }
  Beat(const Beat&) = delete;
  Beat& operator=(const Beat&) = delete;
  void stop();

 private:
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace squall::rpc
