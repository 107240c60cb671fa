// SessionStore<T>: the live server-side objects of one capability (eWave sessions, stored cloud volumes,
// ...) under unguessable ids. Each entry holds a --max-sessions slot and its bytes against
// --max-session-bytes (both through the LimitGate), is evicted when idle longer than the TTL (measured
// with an injected clock, so tests need no sleeps), and can be checkpointed to versioned bytes and
// restored under the same id (session_checkpoint.h), in this daemon or another. An unknown, closed or
// evicted id is Error(NotFound) naming the id's request field.
//
// With a SessionRegistry that has a state directory (squalld --state-dir) and persist() called, the store
// writes its sessions there when the registry asks (periodically, and when the daemon drains: then each
// written session is released and answers UNAVAILABLE), and resumes an id it does not hold from there, so
// a session outlives the replica it was created on. Closing or evicting a session removes its file.
//
// Threading: the store's map has its own lock; each entry has a lock of its own, held while with() runs,
// so calls on one session are serialized and calls on different sessions are not.
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "common/error.h"
#include "common/limits.h"
#include "common/log.h"
#include "common/session_checkpoint.h"
#include "common/session_registry.h"
#include "common/validate.h"

namespace squall {

// Where a client's proposed session id comes from, for messages: the RPC layer reads it from this
// request metadata (a session-affine proxy hashes on it).
inline constexpr const char* kProposedIdField = "metadata x-squall-session";

using SteadyClock = std::function<std::chrono::steady_clock::time_point()>;

// How a store names and ages its sessions.
struct SessionPolicy {
  std::chrono::milliseconds ttl{std::chrono::minutes(10)};  // squalld --session-ttl
  SteadyClock clock = [] { return std::chrono::steady_clock::now(); };
  SessionRegistry* registry = nullptr;  // the daemon's; null: no state directory, never draining
};

// A fresh id: 128 bits from the kernel's CSPRNG, as 32 hex digits, after `prefix`.
std::string new_session_id(const std::string& prefix = "");

template <typename T>
class SessionStore {
 public:
  // `kind` names the entries in messages ("eWave session"), `id_field` the request field of their ids
  // ("session_id"), `prefix` starts every id ("cloud-"); the checkpoint kind is `kind`.
  SessionStore(LimitGate& gate, SessionPolicy policy, std::string kind, std::string id_field, std::string prefix = "")
      : gate_(gate),
        policy_(std::move(policy)),
        kind_(std::move(kind)),
        id_field_(std::move(id_field)),
        prefix_(std::move(prefix)) {
    // Every store enrolls, so that the registry knows the sessions live here (holds); only a persistent one
    // (persist()) writes checkpoints and hands sessions over.
    if (policy_.registry)
      enrolled_ = policy_.registry->enroll({[this](bool release) { return persistent() ? checkpoint_all(release) : 0; },
                                            [this](const std::string& id) { return persistent() && hand_over(id); },
                                            [this](const std::string& id) { return holds(id); }});
  }
  ~SessionStore() {
    if (enrolled_) policy_.registry->withdraw(*enrolled_);
  }
  SessionStore(const SessionStore&) = delete;
  SessionStore& operator=(const SessionStore&) = delete;

  // Makes the store's sessions persistent in the registry's state directory (if it has one): `save`
  // writes a session's payload and names its format version, `resume` rebuilds a session from a whole
  // checkpoint (open_checkpoint, reserve, add under the checkpoint's id).
  using Save = std::function<VersionedPayload(const T&)>;
  using Resume = std::function<void(const std::string& checkpoint)>;
  // The same for payloads of one format `version`.
  void persist(uint32_t version, std::function<std::string(const T&)> save, Resume resume) {
    persist(
        [version, save = std::move(save)](const T& value) {
          return VersionedPayload{version, save(value)};
        },
        std::move(resume));
  }
  void persist(Save save, Resume resume) {
    if (!policy_.registry || !policy_.registry->state_dir()) return;
    save_ = std::move(save);
    resume_ = std::move(resume);
    persisted_ = true;  // after save_ and resume_, which the registry's thread reads once it sees this
  }

  // A session slot and `bytes` of host and device memory, taken before the value is built;
  // RESOURCE_EXHAUSTED past --max-sessions, --max-session-bytes or --memory-budget, and past
  // --max-sessions-per-client for a session of `client` (empty: one no client counts): one it creates, or
  // one resumed from a checkpoint that names it (CheckpointHeader::client). Idle entries are evicted first,
  // so they never block a new one.
  struct Reservation {
    Slot session, client, memory, budget;
    uint64_t bytes = 0;
    std::string counted_client;  // whom `client` is held for, named in checkpoints to the state directory
  };
  Reservation reserve(uint64_t bytes, const std::string& client = "") {
    Reservation r = reserve_session(client);
    reserve_bytes(r, bytes);
    return r;
  }
  // reserve() in two steps, for a value whose bytes are known only once it is made (a cloud volume, once
  // built): the drain, heartbeat and --max-sessions checks before the work, so that it is refused before it
  // is done; then its bytes, moved from `work` (the work's own reservation) where that holds them all.
  Reservation reserve_session(const std::string& client = "") {
    if (policy_.registry && policy_.registry->draining()) refuse_new();  // before the limits: retried elsewhere
    if (persistent()) policy_.registry->require_beating();
    evict_idle();
    Reservation r;
    r.session = gate_.acquire_session();
    if (!client.empty()) r.client = gate_.acquire_client_session(client);
    if (r.client.amount() > 0) r.counted_client = client;
    return r;
  }
  void reserve_bytes(Reservation& r, uint64_t bytes, Slot* work = nullptr) {
    r.memory = gate_.acquire_session_bytes("keeping this " + kind_, bytes);
    r.budget =
        work && work->amount() >= bytes ? work->split(bytes) : gate_.acquire_memory("keeping this " + kind_, bytes);
    r.bytes = bytes;
  }

  // A fresh id for add(): the caller may write it into the value before the value is shared.
  std::string new_id() const { return new_session_id(prefix_); }
  // An id of this store's form: the prefix and 32 lowercase hex digits (another store's ids are not).
  bool is_our_id(const std::string& id) const {
    bool ours = id.size() == prefix_.size() + 32 && id.compare(0, prefix_.size(), prefix_) == 0;
    for (size_t i = prefix_.size(); ours && i < id.size(); ++i)
      ours = (id[i] >= '0' && id[i] <= '9') || (id[i] >= 'a' && id[i] <= 'f');
    return ours;
  }

  // The id of a session about to be created: new_id(), or the client's `proposed` one (so that a proxy
  // routes the creating call and the later ones alike), which must look like one of ours: the prefix and
  // 32 lowercase hex digits; INVALID_ARGUMENT naming `field` otherwise, ALREADY_EXISTS when it is taken.
  std::string id_for(const std::string& proposed, const std::string& field) const {
    if (proposed.empty()) return new_id();
    if (!is_our_id(proposed))
      fail(Code::InvalidArgument, field + " = \"" + validate::printable(proposed) + "\" is no " + kind_ +
                                      " id: " + (prefix_.empty() ? "" : "\"" + prefix_ + "\" and ") +
                                      "32 lowercase hex digits (128 random bits)");
    if (std::lock_guard<std::mutex> lock(mutex_); entries_.count(proposed))  // add() checks again, as it stores
      fail(Code::AlreadyExists, field + " = \"" + proposed + "\" is already a live " + kind_);
    if (const StateDir* dir = state_dir(); dir && (dir->checkpointed(proposed) || dir->owner(proposed)))
      fail(Code::AlreadyExists, field + " = \"" + proposed + "\" names a checkpointed " + kind_);
    return proposed;
  }

  // Stores `value` under `id` (new_id(), or a checkpoint's); ALREADY_EXISTS when `id` is live, and
  // UNAVAILABLE when another live replica claimed it first.
  std::string add(const std::string& id, Reservation reservation, std::shared_ptr<T> value) {
    auto entry = std::make_shared<Entry>();
    entry->id = id;
    entry->value = std::move(value);
    entry->held = std::move(reservation);
    entry->last_use = entry->owner_checked = policy_.clock();
    // Owned here before it is live here, so that a checkpoint never finds it owned by another replica.
    if (persistent()) {
      claim_or_fail(id);
      state_dir()->clear_handover(id);  // a request to its former owner, answered
    }
    bool draining = false, added = false;
    {
      // Checked under the map's lock, which a drain's checkpoint_all(true) takes after begin_drain(): a
      // session added here is either refused or among those the drain writes and releases.
      std::lock_guard<std::mutex> lock(mutex_);
      draining = policy_.registry && policy_.registry->draining();
      if (!draining) added = entries_.emplace(id, std::move(entry)).second;
    }
    if (persistent()) {  // the claim is a live session's now (or one already live here), or given up
      if (draining)
        policy_.registry->release(id);
      else
        policy_.registry->settle(id);
    }
    if (draining) refuse_new();
    if (!added) fail(Code::AlreadyExists, id_field_ + " = \"" + id + "\" is already a live " + kind_);
    return id;
  }
  std::string add(Reservation reservation, std::shared_ptr<T> value) {
    return add(new_id(), std::move(reservation), std::move(value));
  }

  // Runs f(T&) under the entry's lock and returns what f returns. From the call's lookup to its end (its wait
  // for the lock included) the entry is not evicted, however long f runs; its idle time starts again then.
  template <typename F>
  auto with(const std::string& id, F&& f) {
    std::shared_ptr<Entry> entry = find(id, true);
    const Call call{*this, *entry};
    std::lock_guard<std::mutex> lock(entry->mutex);
    require_held(entry);
    return f(*entry->value);
  }

  // The value itself, for callers that only read it (its idle time restarts). The pointer shares the
  // entry: the value's reservation (slot, bytes, budget) is held until the last such pointer goes, even
  // when the session is closed or evicted meanwhile.
  std::shared_ptr<T> get(const std::string& id) {
    std::shared_ptr<Entry> entry = find(id);
    std::lock_guard<std::mutex> lock(entry->mutex);
    require_held(entry);
    return std::shared_ptr<T>(entry, entry->value.get());
  }

  // Removes the entry once a call in flight on it has finished, and its checkpoint. An id this store does
  // not hold but the state directory does (its replica drained) is closed by removing its checkpoint; one
  // that another live replica holds is UNAVAILABLE (that replica is asked to hand it over, so the retry
  // closes it here). NOT_FOUND when absent, and for a second close while the first one waits (even where the
  // first then finds the session released: UNAVAILABLE). With `accepts`, only an entry live here whose
  // value it accepts (called under the map's lock, without the entry's: it must read what never changes,
  // such as a serial), NOT_FOUND otherwise: a call closing the session it made, not one made under its id since.
  void close(const std::string& id, const std::function<bool(const T&)>& accepts = {}) {
    std::shared_ptr<Entry> entry;
    {
      std::lock_guard<std::mutex> moving(moving_);  // no resume of `id` between looking and removing
      entry = take(id, accepts);
      // Another close or an eviction is removing it (and its files): that one answers for it.
      if (!entry && (accepts || closing(id))) fail(Code::NotFound, not_found(id));
      if (!entry) return close_checkpoint(id);
    }
    const Closing closing{*this, id};  // until its checkpoint is gone, a call on `id` resumes nothing
    std::lock_guard<std::mutex> wait(entry->mutex);
    // Released by a drain, or taken over: another replica may hold it by now, and closes it when asked.
    if (entry->released || let_go_if_taken_over(*entry)) fail(Code::Unavailable, released(id));
    entry->removed = true;
    if (const StateDir* dir = persistent() ? state_dir() : nullptr) dir->remove(id, policy_.registry->replica());
  }
  bool erase(const std::string& id) {
    std::shared_ptr<Entry> entry = take(id);
    if (!entry) return false;
    const Closing closing{*this, id};
    remove_files(*entry);
    return true;
  }

  // Writes every live session to the state directory; with `release`, each written session then answers
  // UNAVAILABLE (the daemon is draining: another replica resumes it). Returns how many were written; a
  // session that cannot be written is logged and skipped, and one that another replica owns now is let go
  // unwritten (let_go_if_taken_over).
  size_t checkpoint_all(bool release) {
    std::vector<std::pair<std::string, std::shared_ptr<Entry>>> live;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      live.assign(entries_.begin(), entries_.end());
    }
    size_t written = 0;
    for (auto& [id, entry] : live) {
      std::lock_guard<std::mutex> lock(entry->mutex);   // waits for a call in flight on the session
      if (entry->released || entry->removed) continue;  // a close or an eviction took it meanwhile
      if (let_go_if_taken_over(*entry)) {
        forget(entry);
        continue;
      }
      try {
        if (!write_owned(*entry)) {  // taken over between the look above and the write
          forget(entry);
          continue;
        }
        if (release) policy_.registry->release(id);
        entry->released = release;
        ++written;
      } catch (const std::exception& e) {
        log(LogLevel::Error, kind_, " ", id, " not checkpointed: ", e.what(),
            release ? "; released: it resumes elsewhere from its last checkpoint" : "");
        if (release) {  // let go all the same: another replica resumes it at once, not once this one exits
          policy_.registry->release(id);
          entry->released = true;
          // A session with no state to save (broken) loses nothing it had not lost already.
          const auto* error = dynamic_cast<const Error*>(&e);
          if (!error || error->code() != Code::FailedPrecondition) policy_.registry->count_unsaved();
        }
      }
    }
    return written;
  }

  // Removes entries idle longer than the TTL (no call of with() on them meanwhile), and their files; returns
  // how many.
  size_t evict_idle() {
    std::vector<std::shared_ptr<Entry>> evicted;  // destroyed outside the map's lock
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const auto now = policy_.clock();
      for (auto it = entries_.begin(); it != entries_.end();) {
        if (it->second->calls == 0 && now - it->second->last_use > policy_.ttl) {
          closing_.insert(it->first);  // a call that comes before its files are gone resumes nothing
          evicted.push_back(std::move(it->second));
          it = entries_.erase(it);
        } else {
          ++it;
        }
      }
    }
    if (!evicted.empty()) log(LogLevel::Info, kind_, ": evicted ", evicted.size(), " idle past the TTL");
    for (const auto& entry : evicted) {
      const Closing closing{*this, entry->id};
      remove_files(*entry);
    }
    return evicted.size();
  }

  size_t size() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return entries_.size();
  }
  uint64_t bytes() const {
    std::lock_guard<std::mutex> lock(mutex_);
    uint64_t total = 0;
    for (const auto& [id, entry] : entries_) total += entry->held.bytes;
    return total;
  }

  // The entry as versioned bytes: `save(const T&)` writes the payload, tagged with its `version`.
  std::string checkpoint(const std::string& id, uint32_t version, const std::function<std::string(const T&)>& save) {
    return with(id, [&](T& value) { return encode_checkpoint({kind_, version, id}, save(value)); });
  }
  // The same, the payload's version named by `save`.
  std::string checkpoint(const std::string& id, const Save& save) {
    return with(id, [&](T& value) { return encoded(id, value, save, ""); });
  }

  // The header and payload of a checkpoint of this store's kind and payload `version`, before anything
  // is built from it; INVALID_ARGUMENT naming `field` for bytes that are no such checkpoint, UNAVAILABLE
  // for a payload version newer than this squalld reads, ALREADY_EXISTS when its id is live. The
  // caller then reserve()s, builds the value and add()s it under header.id.
  std::string open_checkpoint(const std::string& data, const std::string& field, uint32_t version,
                              CheckpointHeader* header) {
    return open_checkpoint(data, field, version, version, header);
  }
  // The same for a store that still reads older payload formats: any version in [oldest, newest], which
  // the caller finds in header->version.
  std::string open_checkpoint(const std::string& data, const std::string& field, uint32_t oldest, uint32_t newest,
                              CheckpointHeader* header) {
    std::string payload = decode_checkpoint(data, kind_, field, header);
    if (header->version < oldest || header->version > newest) {
      const std::string what =
          field + " holds " + kind_ + " payload version " + std::to_string(header->version) + "; this squalld reads " +
          (oldest == newest ? "version " + std::to_string(newest)
                            : "versions " + std::to_string(oldest) + " to " + std::to_string(newest));
      // A newer squalld's (a rolling update): a replica that reads it can take the call.
      if (header->version > newest) fail(Code::Unavailable, what + ": retry on a newer squalld");
      fail(Code::InvalidArgument, what);
    }
    std::lock_guard<std::mutex> lock(mutex_);
    if (entries_.count(header->id))
      fail(Code::AlreadyExists, id_field_ + " = \"" + header->id + "\" is already a live " + kind_);
    return payload;
  }

  // Writes session `id` to the state directory and lets it go (another replica asked for it: a proxy
  // routes it there now); false when this store does not hold it, or no more (released, or taken over by
  // another replica since: the request is that one's to answer).
  bool hand_over(const std::string& id) {
    std::shared_ptr<Entry> entry = lookup(id);
    if (!entry) return false;
    bool handed = false;  // not a session taken over since: the request is for its new owner
    {
      std::lock_guard<std::mutex> lock(entry->mutex);  // waits for a call in flight on the session
      if (!entry->released && !entry->removed && !let_go_if_taken_over(*entry)) {
        bool owned = true;  // false: taken over between the look above and the write, and let go
        try {
          owned = write_owned(*entry);
        } catch (const Error& e) {  // a session with no state to save (broken) goes at its last checkpoint
          if (e.code() != Code::FailedPrecondition) throw;  // the writing failed: asked again at the next tick
          log(LogLevel::Error, kind_, " ", id, " not written (", e.what(), "): handed over at its last checkpoint");
        }
        if (owned) {
          policy_.registry->release(id);
          entry->released = handed = true;  // a call already waiting for this entry answers UNAVAILABLE
        }
      }
    }
    forget(entry);
    if (handed) log(LogLevel::Info, kind_, " ", id, " handed over to the replica that asked for it");
    return handed;
  }

  const std::string& kind() const { return kind_; }
  const std::string& id_field() const { return id_field_; }

 private:
  struct Entry {
    std::string id;
    std::mutex mutex;  // one call at a time per entry; `released` changes under it
    // Checkpointed for another replica: calls answer UNAVAILABLE. Atomic for holds(), which reads it under the
    // map's lock only.
    std::atomic<bool> released = false;
    // Closed or evicted (its files removed: no checkpoint writes it again); a call that found it before
    // answers NOT_FOUND. Set under `mutex`, except by an eviction with no files, which does not wait.
    std::atomic<bool> removed = false;
    std::shared_ptr<T> value;
    Reservation held;
    std::chrono::steady_clock::time_point last_use;       // under the store's mutex_
    int calls = 0;                                        // under the store's mutex_: with() calls running or waiting
    std::chrono::steady_clock::time_point owner_checked;  // when its ownership was last read (require_held)
  };

  // How often a call reads its session's ownership in the state directory: a replica taken for dead
  // stops serving a session another one resumed within about this long.
  static constexpr std::chrono::seconds kOwnerCheckInterval{1};

  // Under entry->mutex: UNAVAILABLE for a session released, or found taken over by another replica at a
  // read of its ownership (at most one per kOwnerCheckInterval; then it leaves the store).
  void require_held(const std::shared_ptr<Entry>& entry) {
    if (persistent()) policy_.registry->require_beating();
    if (!entry->released && persistent() && policy_.clock() - entry->owner_checked >= kOwnerCheckInterval) {
      entry->owner_checked = policy_.clock();
      if (let_go_if_taken_over(*entry)) forget(entry);
    }
    if (entry->released) fail(Code::Unavailable, released(entry->id));
    if (entry->removed) fail(Code::NotFound, not_found(entry->id));  // closed or evicted while the call waited
  }

  std::string not_found(const std::string& id) const {
    return id_field_ + " = \"" + validate::printable(id) + "\" is not a live " + kind_ +
           " (unknown, closed or expired)";
  }

  std::string released(const std::string& id) const {
    return kind_ + " " + id +
           " moved to the state directory (squalld is shutting down, or another replica asked for it); retry: "
           "another replica resumes it";
  }

  const StateDir* state_dir() const { return policy_.registry ? policy_.registry->state_dir() : nullptr; }
  bool persistent() const { return persisted_ && state_dir(); }

  [[noreturn]] void refuse_new() const {
    fail(Code::Unavailable, "squalld is shutting down: it takes no new " + kind_ + "; retry on another replica");
  }

  // The files of an entry taken out of the map. Not those of one released or taken over: they are the
  // state another replica resumes, and holds by now.
  void remove_files(Entry& entry) {
    const StateDir* dir = persistent() ? state_dir() : nullptr;
    if (!dir) {
      entry.removed = true;  // a call that found it and waits for its lock answers NOT_FOUND
      return;
    }
    std::lock_guard<std::mutex> lock(entry.mutex);  // waits for a call in flight on the session
    if (entry.released || let_go_if_taken_over(entry)) return;
    entry.removed = true;
    dir->remove(entry.id, policy_.registry->replica());
  }

  // Under entry.mutex: whether another replica owns the entry's session in the state directory now (this
  // replica was presumed dead, its heartbeat late, and that one resumed the session), in which case the
  // entry is released, so that its calls answer UNAVAILABLE and its state, older than the new owner's, is
  // never written over the new owner's files. An entry live here has its ownership written (add()) and
  // given up only when it is released here, so no owner file at all means another replica took it over
  // and gave it up since (or an expiry pass removed it once this replica's heartbeat had stopped for the
  // TTL); an owner file that cannot be read, or a state directory that is not the one opened, counts as
  // this replica's (a glitch of a network file system drops no session).
  bool let_go_if_taken_over(Entry& entry) {
    if (!persistent()) return false;
    const std::optional<std::string> owner = state_dir()->owner(entry.id);
    if (owner ? *owner == policy_.registry->replica() : !state_dir()->owner_missing(entry.id)) return false;
    log(LogLevel::Warn, kind_, " ", entry.id, " was taken over by ", owner ? "replica " + *owner : "another replica",
        ": let go here");
    entry.released = true;
    return true;
  }

  // Under entry.mutex: writes the entry's checkpoint while this replica owns its session; false, the entry
  // released, where another replica took it over since let_go_if_taken_over() looked.
  bool write_owned(Entry& entry) {
    const std::string bytes = encoded(entry.id, *entry.value, save_, entry.held.counted_client);
    if (state_dir()->write_owned(entry.id, bytes, policy_.registry->replica()))
      return true;
    log(LogLevel::Warn, kind_, " ", entry.id, " was taken over by another replica as it was written: let go here");
    entry.released = true;
    return false;
  }

  void forget(const std::shared_ptr<Entry>& entry) {  // out of the map, if it is still there
    std::lock_guard<std::mutex> lock(mutex_);
    if (auto it = entries_.find(entry->id); it != entries_.end() && it->second == entry) entries_.erase(it);
  }

  // The live entry of `id`, resumed from its checkpoint if need be; with `call`, counted among the entry's
  // calls (Call ends it). NOT_FOUND when there is none.
  std::shared_ptr<Entry> find(const std::string& id, bool call = false) {
    evict_idle();
    if (auto entry = lookup(id, call)) return entry;
    resume(id);
    if (auto entry = lookup(id, call)) return entry;
    fail(Code::NotFound, not_found(id));
  }

  std::shared_ptr<Entry> lookup(const std::string& id, bool call = false) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = entries_.find(id);
    if (it == entries_.end()) return nullptr;
    it->second->last_use = policy_.clock();
    it->second->calls += call;
    return it->second;
  }

  // A with() call on an entry, from its lookup (find(id, true)) on: its end restarts the entry's idle time.
  struct Call {
    SessionStore& store;
    Entry& entry;
    ~Call() {
      std::lock_guard<std::mutex> lock(store.mutex_);
      --entry.calls;
      entry.last_use = store.policy_.clock();
    }
  };

  // When another live replica owns `id`, a handover is requested and the call answered UNAVAILABLE (its
  // retry finds the checkpoint).
  void require_not_owned_elsewhere(const std::string& id) {
    if (std::optional<std::string> owner = policy_.registry->owned_elsewhere(id)) {
      if (!policy_.registry->draining()) state_dir()->request_handover(id);
      fail(Code::Unavailable,
           kind_ + " " + id + " is live on replica " + *owner + ", which is asked to hand it over; retry in a moment");
    }
  }

  // close() of an id this store does not hold, under moving_: its checkpoint removed, else NOT_FOUND. It
  // is claimed first, so that no other replica resumes it meanwhile.
  void close_checkpoint(const std::string& id) {
    if (persistent() && is_our_id(id)) {
      require_not_owned_elsewhere(id);
      if (state_dir()->checkpointed(id)) {
        claim_or_fail(id);
        state_dir()->remove(id, policy_.registry->replica());  // the ownership just claimed too
        policy_.registry->settle(id);
        return;
      }
    }
    fail(Code::NotFound, not_found(id));
  }

  // UNAVAILABLE when another live replica claimed `id` first (it resumed, created or closed the session
  // just now).
  void claim_or_fail(const std::string& id) {
    std::string holder;
    if (policy_.registry->claim(id, &holder)) return;
    fail(Code::Unavailable,
         kind_ + " " + id + " was claimed first by replica " + holder + ", which holds it now; retry in a moment");
  }

  bool holds(const std::string& id) const {  // live here, and not released for another replica
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = entries_.find(id);
    return it != entries_.end() && !it->second->released;
  }

  // An id this store does not hold and no other live replica owns: resumed from its checkpoint when there
  // is one (while draining: UNAVAILABLE, so that the client retries on another replica). The session is
  // claimed before its checkpoint is read: of replicas resuming it at once one gets it, and a replica that
  // handed it over since wrote it before giving it up.
  void resume(const std::string& id) {
    if (!persistent() || !is_our_id(id)) return;
    std::lock_guard<std::mutex> moving(moving_);
    if (live_or_closing(id)) return;  // resumed by a call before this one, or being closed or evicted
    require_not_owned_elsewhere(id);
    if (!state_dir()->checkpointed(id)) return;
    // Idle past the TTL: evicted, as it would be if live (an owner file naming this replica, which does not hold
    // the session, keeps nothing).
    if (state_dir()->expired(id, policy_.ttl, policy_.registry->replica())) return;
    if (policy_.registry->draining())
      fail(Code::Unavailable,
           kind_ + " " + id + " is checkpointed and squalld is shutting down; retry on another replica");
    policy_.registry->require_beating();
    try {
      claim_or_fail(id);
      std::optional<std::string> checkpoint = state_dir()->read(id);
      if (!checkpoint) {  // closed since
        policy_.registry->release(id);
        return;
      }
      try {
        CheckpointHeader header;  // whose it is, before anything is built from it
        decode_checkpoint(*checkpoint, kind_, "the checkpoint", &header);
        if (header.id != id) fail(Code::DataLoss, kind_ + " checkpoint " + id + " holds another session's id");
        resume_(*checkpoint);
      } catch (const Error& e) {  // the file's fault, never the request's
        if (e.code() != Code::InvalidArgument) throw;
        fail(Code::DataLoss,
             kind_ + " " + id +
                 "'s checkpoint in the state directory is damaged or of a format this squalld does not read: " +
                 e.what());
      }
      log(LogLevel::Info, kind_, " ", id, " resumed from the state directory");
    } catch (...) {
      if (lookup(id)) return;  // live here already (a session created under its id), and owned
      policy_.registry->release(id);
      throw;
    }
  }

  // A checkpoint naming `client` (for a session resumed in another replica, whose --max-sessions-per-client
  // it counts against there), or no client.
  std::string encoded(const std::string& id, const T& value, const Save& save, const std::string& client) const {
    VersionedPayload payload = save(value);
    return encode_checkpoint({kind_, payload.version, id, client}, payload.bytes);
  }

  std::shared_ptr<Entry> take(const std::string& id, const std::function<bool(const T&)>& accepts = {}) {
    evict_idle();  // an expired id is NOT_FOUND here too
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = entries_.find(id);
    if (it == entries_.end() || (accepts && !accepts(*it->second->value))) return nullptr;
    std::shared_ptr<Entry> entry = std::move(it->second);
    entries_.erase(it);
    closing_.insert(id);  // until the caller's Closing: a call that comes meanwhile resumes nothing
    return entry;
  }

  LimitGate& gate_;
  const SessionPolicy policy_;
  const std::string kind_, id_field_, prefix_;
  mutable std::mutex mutex_;
  std::mutex moving_;              // a checkpoint resumed or closed from the state directory, one id at a time
  std::set<std::string> closing_;  // under mutex_: ids taken out of the map whose files are not removed yet

  // The mark on an id taken out of the map by a close, an erase or an eviction, from then to removing its
  // checkpoint: a call that comes meanwhile (while the removal waits for the call in flight, or for a
  // periodic checkpoint being written) does not resume the session from that checkpoint.
  struct Closing {
    SessionStore& store;
    std::string id;
    ~Closing() {
      std::lock_guard<std::mutex> lock(store.mutex_);
      store.closing_.erase(id);
    }
  };
  bool live_or_closing(const std::string& id) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return entries_.count(id) || closing_.count(id);
  }
  bool closing(const std::string& id) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return closing_.count(id) > 0;
  }
  std::map<std::string, std::shared_ptr<Entry>> entries_;
  // persist(): the payload format and its writer and reader, persisted_ once both are set.
  Save save_;
  std::function<void(const std::string&)> resume_;
  std::atomic<bool> persisted_{false};
  std::optional<size_t> enrolled_;  // the registry's token for this store
};

}  // namespace squall
