// CheckpointLoop: with a state directory, a thread that beats four times a second (this replica's
// heartbeat, and handing over the sessions other replicas ask for: SessionRegistry::tick), writes every
// live session to the directory every --checkpoint-interval seconds (what a replica killed without
// SIGTERM loses is at most that much) and, once a minute, expires files older than the session TTL.
// Stopped (and joined) before the daemon drains.
#pragma once

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "common/session_registry.h"

namespace squall::rpc {

class CheckpointLoop {
 public:
  // Does nothing without a state directory; a zero interval: no periodic checkpoints.
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
