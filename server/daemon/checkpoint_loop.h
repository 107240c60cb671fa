// CheckpointLoop: with a state directory, this replica's heartbeat four times a second on a thread of its
// own (waiting for no session and no write, so that a replica busy writing is not taken for dead), and a
// thread that beats four times a second: hands over the sessions other replicas ask for
// (SessionRegistry::tick), writes every live session to the directory every --checkpoint-interval seconds
// (what a replica killed without SIGTERM loses is at most that much) and, once a minute, expires files
// older than the session TTL; a failure of one of these is logged and does not keep the others from
// running. The daemon's drain stops the work first and the heartbeat once its sessions are written.
#pragma once

#include <chrono>
#include <memory>

#include "common/session_registry.h"
#include "daemon/beat.h"

namespace squall::rpc {

class CheckpointLoop {
 public:
  // Does nothing without a state directory; a zero interval: no periodic checkpoints.
  CheckpointLoop(SessionRegistry& registry, std::chrono::milliseconds interval, std::chrono::milliseconds ttl);
  // Stops the handovers, checkpoints and expiry; the heartbeat goes on (a draining replica writing its
  // sessions must not be taken for dead meanwhile).
  void stop_work() {
    if (beat_) beat_->stop();
  }
  // Stops everything, the heartbeat too.
  void stop() {
    stop_work();
    if (heartbeat_) heartbeat_->stop();
  }

 private:
  void tick();
  void beat();  // logs a heartbeat that fails, once until one is written again

  SessionRegistry& registry_;
  const std::chrono::milliseconds interval_, ttl_;
  std::chrono::steady_clock::time_point last_checkpoint_, last_expiry_;  // the beat's thread only
  std::unique_ptr<Beat> heartbeat_, beat_;  // last: they start once the members above exist
};

}  // namespace squall::rpc
