// SessionRegistry: what every SessionStore of a daemon shares for the daemon's life cycle: whether new
// sessions are taken (not once the daemon drains), and the state directory (squalld --state-dir) that
// live sessions are checkpointed to, periodically and when the daemon drains, and that a store resumes an
// unknown id from. Stores enroll themselves; the daemon checkpoints them all through here.
#pragma once

#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <mutex>

#include "common/state_dir.h"

namespace squall {

class SessionRegistry {
 public:
  explicit SessionRegistry(std::unique_ptr<StateDir> state_dir = nullptr) : state_dir_(std::move(state_dir)) {}

  const StateDir* state_dir() const { return state_dir_.get(); }

  // From now on stores refuse new sessions and resumes (UNAVAILABLE): the daemon is shutting down.
  void begin_drain() { draining_ = true; }
  bool draining() const { return draining_; }

  // checkpoint(release) writes a store's live sessions to the state directory and returns how many; with
  // release, each written session then answers UNAVAILABLE, so that another replica resumes it.
  using Checkpoint = std::function<size_t(bool release)>;
  size_t enroll(Checkpoint checkpoint) {
    std::lock_guard<std::mutex> lock(mutex_);
    stores_.emplace(next_, std::move(checkpoint));
    return next_++;
  }
  void withdraw(size_t token) {
    std::lock_guard<std::mutex> lock(mutex_);
    stores_.erase(token);
  }

  // Every enrolled store's sessions; 0 without a state directory.
  size_t checkpoint_all(bool release) {
    if (!state_dir_) return 0;
    std::lock_guard<std::mutex> lock(mutex_);
    size_t written = 0;
    for (auto& [token, checkpoint] : stores_) written += checkpoint(release);
    return written;
  }

 private:
  std::unique_ptr<StateDir> state_dir_;
  std::atomic<bool> draining_{false};
  std::mutex mutex_;
  std::map<size_t, Checkpoint> stores_;
  size_t next_ = 0;
};

}  // namespace squall
