// StateDir: a directory shared by the replicas of a deployment (squalld --state-dir). Per session, named
// by its id:
//   <id>.session   its last checkpoint, the bytes of encode_checkpoint()
//   <id>.owner     the replica that holds it live (written when a replica creates or resumes it, removed
//                  when it releases, closes or evicts it)
//   <id>.handover  another replica's request that the owner release it (a proxy now routes it there)
//   <id>.lock      held by a replica while it changes the session's owner (milliseconds)
// and per replica, replicas/<name>: a heartbeat whose age tells whether an owner is still alive.
// Writes are atomic (a temporary file, fsync, rename, fsync of the directory), so a reader on another
// replica sees the previous file or the new one, never half of one. Ownership changes only under
// <id>.lock, a file made by link(2) of an empty temporary, which fails where the name exists: one replica
// at a time reads, removes and links a session's owner file. Ids name files only when they are made of
// [a-z0-9-] (every id squalld makes or accepts is), so no id reaches outside the directory. File names are
// session ids, which are what lets a client use a session: a directory squalld creates is its user's
// alone (0700), and its files are written 0600. Only regular files are read, without blocking (a FIFO in
// the directory is damage, not a reader's wait).
#pragma once

#include <sys/types.h>

#include <chrono>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace squall {

// A time stamped on a file by the file system (an NFS server stamps by its own clock), since the Unix epoch.
using FileTime = std::chrono::nanoseconds;

// Creates `path` if needed and checks that a file can be written in it: "" when it can, else why not.
std::string unwritable_directory(const std::string& path);

class StateDir {
 public:
  // Creates `path` if needed; std::runtime_error naming `flag` when it cannot be created or written, or
  // makes no hard links (ownership is claimed by link(2)).
  StateDir(std::string path, const std::string& flag);

  void write(const std::string& id, const std::string& bytes) const;
  // write() for the owner of `id`: the bytes are written and synced first, then put in place under the
  // session's ownership lock only while its owner file names `replica` (or cannot be read: a glitch of a
  // network file system drops no session). False, and nothing changed, where another replica has taken the
  // session over meanwhile (this one was presumed dead): its older state never lands over the new owner's.
  bool write_owned(const std::string& id, const std::string& bytes, const std::string& replica) const;
  std::optional<std::string> read(const std::string& id) const;  // nullopt: no such file (or no such id)
  bool checkpointed(const std::string& id) const;                // whether read() finds a file
  // The session's checkpoint and handover request, and its owner file if it names `owner`.
  void remove(const std::string& id, const std::string& owner) const;

  // Ownership changes under a lock of the session's own, so that of replicas claiming it at once one gets
  // it. claim_owner() makes `replica` the owner of `id` where it has none, or one that `may_take` says may
  // be replaced (a dead replica); true too where `replica` owns it already; false, with the owner in
  // *holder, where another keeps it. create_owner() claims only an id with no owner. remove_owner_if()
  // removes the owner file only while it names `replica` (false where it names another or there is none).
  // UNAVAILABLE when the lock stays taken for seconds.
  bool claim_owner(const std::string& id, const std::string& replica,
                   const std::function<bool(const std::string& owner)>& may_take, std::string* holder = nullptr) const;
  bool create_owner(const std::string& id, const std::string& replica) const;
  bool remove_owner_if(const std::string& id, const std::string& replica) const;
  // remove_owner_if(), a failure logged rather than thrown: a session given up or removed goes on being so,
  // and a later handover request (a claim left behind) or the owner's next start clears the file.
  void give_up(const std::string& id, const std::string& owner) const;
  std::optional<std::string> owner(const std::string& id) const;
  void clear_ownership_of(const std::string& replica) const;  // every owner file naming `replica`
  // No owner file, beyond doubt: false where it cannot be told, and in a directory that is no longer the one
  // opened (an unmounted volume's empty mount point).
  bool owner_missing(const std::string& id) const;

  // Heartbeats: a replica rewrites its file ("alive now") and removes it when it exits ("gone"). It is
  // alive while its file was written within `timeout` of now, both times as the file system stamps them
  // (now: this process's own last heartbeat, plus the time since), so that where the file server stamps
  // them (NFS) the replicas' clocks need not agree with it or each other.
  // A beat that cannot be written throws Error(Unavailable): the other replicas will take this one for dead.
  void heartbeat(const std::string& replica) const;
  void retire(const std::string& replica) const;
  bool alive(const std::string& replica, std::chrono::milliseconds timeout) const;

  void request_handover(const std::string& id) const;
  std::vector<std::string> handover_requests() const;  // the ids of the pending requests
  void clear_handover(const std::string& id) const;

  // Removes the checkpoints, handover requests, locks and temporaries last written more than `ttl` ago (by
  // the file system's clock), except the checkpoints of sessions held live (their owner evicts them itself,
  // however seldom it checkpoints): by another replica that has beaten within `ttl`, or by replica `self`
  // (the caller's) where `held_here` says so; the owner files of sessions with no checkpoint whose owner
  // has not beaten for `ttl` (a replica killed holding them), and such replicas' heartbeats; returns how many.
  using HeldHere = std::function<bool(const std::string& id)>;
  size_t expire(std::chrono::milliseconds ttl, const std::string& self = "", const HeldHere& held_here = {}) const;
  // Whether id's checkpoint is one expire() removes at its next pass.
  bool expired(const std::string& id, std::chrono::milliseconds ttl, const std::string& self = "",
               const HeldHere& held_here = {}) const;

  const std::string& path() const { return path_; }

 private:
  std::optional<std::string> file_of(const std::string& id, const char* suffix) const;
  std::string replica_file(const std::string& replica) const;
  FileTime file_system_now() const;
  void with_owner_lock(const std::string& id, const std::function<void()>& f) const;
  // Writes `bytes` to a synced temporary file beside id's `suffix` file, then under with_owner_lock(id) asks
  // put(temporary, file) to put it in place (true) or not; the temporary is removed after, and the directory
  // synced where it was put. Returns put's answer.
  using Put = std::function<bool(const std::string& temporary, const std::string& file)>;
  bool put_under_owner_lock(const std::string& id, const char* suffix, const std::string& bytes, const Put& put) const;
  void break_if_stale(const std::string& lock) const;
  bool expire_owner(const std::string& id, std::chrono::milliseconds ttl, FileTime now) const;
  bool held_live(const std::string& id, std::chrono::milliseconds ttl, FileTime now, const std::string& self,
                 const HeldHere& held_here) const;
  bool silent_for(const std::string& replica, std::chrono::milliseconds ttl, FileTime now) const;
  size_t expire_heartbeats(std::chrono::milliseconds ttl, FileTime now) const;
  // Whether path_ is still the directory opened at construction (not a mount point's empty directory
  // after an unmount, nor one moved or replaced); UNAVAILABLE from the require_ form when not.
  bool same_directory() const;
  void require_same_directory() const;
  std::string path_;
  std::pair<dev_t, ino_t> identity_{};  // of path_ at construction
  mutable std::mutex beat_mutex_;
  mutable std::pair<std::string, std::chrono::steady_clock::time_point> beat_;  // this process's last heartbeat
};

}  // namespace squall
