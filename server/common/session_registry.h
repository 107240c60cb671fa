// SessionRegistry: what every SessionStore of a daemon shares for the daemon's life cycle: whether new
// sessions are taken (not once the daemon drains), this replica's name, and the state directory
// (squalld --state-dir) that sessions are checkpointed to (periodically, on a handover request, when the
// daemon drains) and resumed from. Stores enroll themselves; the daemon's loop calls checkpoint_all() and
// tick(), and its drain checkpoint_all(true).
//
// Ownership: a session lives on one replica at a time. The replica holding it is its owner in the state
// directory; another replica that receives a call for it (a proxy's hash ring changed: a replica joined
// or came back) does not resume the last checkpoint while the owner is alive (its heartbeat is younger
// than `owner_timeout`): it asks the owner to hand the session over and answers UNAVAILABLE, and the
// owner's next tick writes the session and lets it go, so the client's retry resumes the current state.
// An owner whose heartbeat stopped (killed, node lost) is presumed dead and its sessions resume from
// their last checkpoint. The heartbeat has a thread of its own (the daemon's CheckpointLoop), so that a
// replica busy writing checkpoints is not taken for dead. A replica that starts holds no session: begin()
// clears the ownership left under its name by its previous life (killed and restarted), once that one's
// heartbeat has stopped; --replica-id names one live process at a time. Ownership is claimed under the
// session's lock in the state directory (StateDir::claim_owner), so that of replicas resuming, creating
// or closing one session at once, one does and the others answer UNAVAILABLE.
#pragma once

#include <atomic>
#include <chrono>
#include <exception>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>

#include "common/error.h"
#include "common/log.h"
#include "common/state_dir.h"

namespace squall {

class SessionRegistry {
 public:
  explicit SessionRegistry(std::unique_ptr<StateDir> state_dir = nullptr, std::string replica = "replica",
                           std::chrono::milliseconds owner_timeout = std::chrono::seconds(5))
      : state_dir_(std::move(state_dir)), replica_(std::move(replica)), owner_timeout_(owner_timeout) {}

  // Before this replica takes calls: waits (up to twice the owner timeout) for the heartbeat of a former
  // process under its name to stop, beats, then clears the ownership that process left (files that another
  // replica has claimed since are left to it). Throws std::runtime_error when that heartbeat goes on (another
  // live squalld has this --replica-id), and Error(Unavailable) when this one's cannot be written, before
  // any ownership is touched.
  void begin() {
    if (!state_dir_) return;
    const auto deadline = std::chrono::steady_clock::now() + 2 * owner_timeout_;
    while (state_dir_->alive(replica_, owner_timeout_)) {
      if (std::chrono::steady_clock::now() > deadline)
        throw std::runtime_error("another live squalld beats as replica \"" + replica_ + "\" in " + state_dir_->path() +
                                 ": give each replica its own --replica-id");
      std::this_thread::sleep_for(owner_timeout_ / 20);
    }
    heartbeat();
    state_dir_->clear_ownership_of(replica_);
  }

  const StateDir* state_dir() const { return state_dir_.get(); }
  const std::string& replica() const { return replica_; }

  // From now on stores refuse new sessions and resumes (UNAVAILABLE): the daemon is shutting down.
  void begin_drain() { draining_ = true; }
  bool draining() const { return draining_; }

  // Makes this replica the owner of session `id` unless another live replica owns it: false then, with
  // that replica in *holder. Of replicas claiming it at once, one gets it (StateDir::claim_owner). The
  // claim is pending until the store settle()s it (the session is live here) or release()s it.
  bool claim(const std::string& id, std::string* holder = nullptr) {
    {
      std::lock_guard<std::mutex> lock(pending_mutex_);
      pending_.insert(id);
    }
    bool claimed = false;
    try {
      claimed = state_dir_->claim_owner(
          id, replica_, [&](const std::string& owner) { return !state_dir_->alive(owner, owner_timeout_); }, holder);
    } catch (...) {
      settle(id);
      throw;
    }
    if (!claimed) settle(id);
    return claimed;
  }
  void settle(const std::string& id) {
    std::lock_guard<std::mutex> lock(pending_mutex_);
    pending_.erase(id);
  }
  // Gives up this replica's ownership of `id`, and only its own. A failure is logged: the drain that
  // releases its sessions goes on with the others.
  void release(const std::string& id) {
    state_dir_->give_up(id, replica_);
    settle(id);
  }

  // The live replica other than this one that owns session `id`, if any.
  std::optional<std::string> owned_elsewhere(const std::string& id) const {
    std::optional<std::string> owner = state_dir_->owner(id);
    if (!owner || *owner == replica_ || !state_dir_->alive(*owner, owner_timeout_)) return std::nullopt;
    return owner;
  }

  // An enrolled store: checkpoint(release) writes its live sessions and returns how many (with release,
  // each written session then answers UNAVAILABLE); hand_over(id) writes and lets go of session `id`,
  // false when the store does not hold it; holds(id): whether it holds session `id`.
  struct Store {
    std::function<size_t(bool release)> checkpoint;
    std::function<bool(const std::string& id)> hand_over;
    std::function<bool(const std::string& id)> holds;
  };
  // Whether an enrolled store holds session `id` now: a call naming it goes on while the daemon drains.
  // Under stores_mutex_ only, so that it never waits for a checkpoint pass or a handover.
  bool holds(const std::string& id) {
    std::lock_guard<std::mutex> lock(stores_mutex_);
    for (auto& [token, store] : stores_)
      if (store.holds(id)) return true;
    return false;
  }
  // Both under mutex_ too: a pass in progress (which reads stores_ under mutex_) ends first.
  size_t enroll(Store store) {
    std::lock_guard<std::mutex> pass(mutex_);
    std::lock_guard<std::mutex> lock(stores_mutex_);
    stores_.emplace(next_, std::move(store));
    return next_++;
  }
  void withdraw(size_t token) {
    std::lock_guard<std::mutex> pass(mutex_);
    std::lock_guard<std::mutex> lock(stores_mutex_);
    stores_.erase(token);
  }

  // Every enrolled store's sessions; 0 without a state directory.
  size_t checkpoint_all(bool release) {
    if (!state_dir_) return 0;
    std::lock_guard<std::mutex> lock(mutex_);
    size_t written = 0;
    for (auto& [token, store] : stores_) written += store.checkpoint(release);
    return written;
  }

  // An expiry pass over the state directory (StateDir::expire), which keeps the checkpoints of the sessions
  // live here and removes those of an owner file of this replica's that no store holds (one left behind).
  size_t expire(std::chrono::milliseconds ttl) {
    return state_dir_->expire(ttl, replica_, [this](const std::string& id) { return holds(id); });
  }

  // Sessions that a checkpoint pass releasing them (a drain) could not write: they resume elsewhere from their
  // last checkpoint, and what they did since is lost.
  void count_unsaved() { ++unsaved_; }
  size_t unsaved() const { return unsaved_; }

  // "Alive now": this replica's heartbeat (none without a state directory). Throws Error(Unavailable) when
  // it cannot be written.
  void heartbeat() const {
    if (!state_dir_) return;
    try {
      state_dir_->heartbeat(replica_);
    } catch (...) {
      beat_failing_ = true;
      throw;
    }
    last_beat_ = std::chrono::steady_clock::now().time_since_epoch().count();
    beat_failing_ = false;
  }
  // UNAVAILABLE while this replica's heartbeat was last written more than half the owner timeout ago
  // (its writes fail, or hang on a file server that is gone): the other replicas take it for dead at the
  // full timeout and resume its sessions from their checkpoints, so from then on it serves none of them (nor
  // takes new ones), and no session is stepped on two replicas. Once a beat is written again its sessions
  // are served again (those taken over meanwhile are let go at their next call).
  void require_beating() const {
    if (!beating())
      fail(Code::Unavailable,
           "this replica cannot write its heartbeat in the state directory (its writes fail or hang; see its log), so "
           "other replicas take its sessions over; retry: another replica serves it");
  }
  // Whether the latest heartbeat could not be written.
  bool heartbeat_failing() const { return beat_failing_; }
  // False from then on: what require_beating() refuses for (health turns NOT_SERVING too). The daemon beats
  // every 250 ms (a twentieth of its owner timeout) on a thread of its own, from begin() on.
  bool beating() const {
    if (!state_dir_) return true;
    const auto last = std::chrono::steady_clock::time_point(std::chrono::steady_clock::duration(last_beat_.load()));
    return std::chrono::steady_clock::now() - last <= owner_timeout_ / 2;
  }

  // One beat of the daemon's loop: the handover requests for sessions this replica holds (other
  // replicas' requests are theirs to answer). A handover that fails is logged and tried again at the next
  // beat; the others go on. Returns how many sessions were handed over.
  size_t tick() {
    if (!state_dir_) return 0;
    size_t handed = 0;
    std::lock_guard<std::mutex> lock(mutex_);
    for (const std::string& id : state_dir_->handover_requests()) {
      try {
        if (hand_over(id)) ++handed;
      } catch (const std::exception& e) {
        log(LogLevel::Error, "handing session ", id, " over: ", e.what());
      }
    }
    return handed;
  }

 private:
  bool hand_over(const std::string& id) {  // under mutex_
    for (auto& [token, store] : stores_)
      if (store.hand_over(id)) {
        state_dir_->clear_handover(id);
        return true;
      }
    return give_up_stray_claim(id);
  }

  // A request for a session that this replica owns while no store holds it and no claim of it is pending (a
  // claim left behind by a resume whose file system failed it) is answered by giving the ownership up, so
  // that the session resumes where it was asked for. Checked again, and given up, under pending_mutex_: a
  // claim that starts meanwhile waits, and a claim settled since is a live session that holds() sees.
  bool give_up_stray_claim(const std::string& id) {
    const auto stray = [&] {
      if (state_dir_->owner(id) != replica_) return false;
      for (auto& [token, store] : stores_)
        if (store.holds(id)) return false;
      return true;
    };
    if (!stray()) return false;  // most requests: another replica's session, or one live here
    std::lock_guard<std::mutex> lock(pending_mutex_);
    if (pending_.count(id) || !stray()) return false;
    log(LogLevel::Warn, "session ", id, " owned here but not live: ownership given up for the replica that asked");
    state_dir_->remove_owner_if(id, replica_);
    state_dir_->clear_handover(id);
    return true;
  }

  std::unique_ptr<StateDir> state_dir_;
  const std::string replica_;
  const std::chrono::milliseconds owner_timeout_;
  std::atomic<bool> draining_{false};
  // When this replica's heartbeat was last written (steady clock ticks; 0 before its first), and whether
  // the latest try failed.
  mutable std::atomic<std::chrono::steady_clock::rep> last_beat_{0};
  mutable std::atomic<bool> beat_failing_{false};
  std::atomic<size_t> unsaved_{0};
  std::mutex mutex_;         // one checkpoint pass or handover beat at a time; stores_ changes under it too
  std::mutex stores_mutex_;  // stores_ for holds(), which takes no other lock of the registry
  std::map<size_t, Store> stores_;
  size_t next_ = 0;
  std::mutex pending_mutex_;
  std::set<std::string> pending_;  // ids claimed here whose sessions are not live here yet
};

}  // namespace squall
