// CheckpointLoop: a thread that writes every live session to the state directory every
// --checkpoint-interval seconds (what a replica killed without SIGTERM loses is at most that much) and
// expires the directory's files older than the session TTL. Stopped (and joined) before the daemon drains.
#pragma once

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "common/session_registry.h"

namespace squall::rpc {

class CheckpointLoop {
 public:
  // Does nothing without a state directory or with a zero interval.
  CheckpointLoop(SessionRegistry& registry, std::chrono::milliseconds interval, std::chrono::milliseconds ttl);
  ~CheckpointLoop() { stop(); }
  void stop();

 private:
  void run();

  SessionRegistry& registry_;
  const std::chrono::milliseconds interval_, ttl_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace squall::rpc
