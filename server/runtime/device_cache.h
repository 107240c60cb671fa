// Device buffers that the next calls would compute again (a layer's wave spectrum, a propagator table), kept
// by key: the least recently used are evicted past a byte limit, and the buffers kept hold their bytes in
// the daemon's memory budget. A miss is computed with no lock held; callers missing the same key meanwhile
// wait for it, not for the others.
#pragma once

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <iterator>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "common/cancel.h"
#include "common/error.h"
#include "common/limits.h"
#include "common/log.h"
#include "runtime/opencl.h"

namespace squall {

// The byte bound of one of the daemon's device caches: a quarter of its memory budget, but no more than an
// eighth of the device's global memory (a GPU's is not the host's, and what the caches keep there is
// reclaimed only when a call finds no room in the budget), and at least `least`. A buffer that no call holds
// any more goes back to such a call (MemoryReclaimer), so the bound says how much of an idle budget a cache
// may keep: enough for the spectrum of one 4096^2 ocean layer (384 MiB) on a machine of a few GiB.
inline size_t cache_bound(uint64_t memory_budget, uint64_t device_memory, size_t least) {
  return size_t(std::max<uint64_t>(least, std::min(memory_budget / 4, device_memory / 8)));
}

template <typename Key>  // compared with ==
class DeviceCache : public MemoryReclaimer {
 public:
  // What a miss computes: a buffer whose contents are complete (any queue may read it at once), its bytes.
  struct Made {
    cl::Buffer buffer;
    size_t bytes = 0;
  };

  // A buffer larger than `max_bytes` is returned but not kept. Each buffer kept holds its bytes in `gate`'s
  // memory budget (none: not counted) as cached memory, as `what`, until it is released by the cache and by
  // every call that got it (an evicted buffer still in use still holds its memory): where the budget has no
  // room for a new one, the least recently used are evicted, and where even all of theirs would not make room
  // it is returned but not kept (the others stay); a call that needs the room takes it back.
  DeviceCache(size_t max_bytes, LimitGate* gate, std::string what)
      : max_bytes_(max_bytes), gate_(gate), what_(std::move(what)) {
    if (gate_) gate_->add_reclaimer(this);
  }
  // Waits (at most kUnreleasedWait) for the destructor callbacks of the buffers it kept, so that none gives
  // bytes back to a budget that has gone: a cache goes after the calls that use its buffers. Those that come
  // later give nothing back.
  ~DeviceCache() override {
    if (!gate_) return;
    gate_->remove_reclaimer(this);
    {
      std::lock_guard<std::mutex> guard(mutex_);
      for (Entry& e : entries_) gate_->uncache(e.held->memory);  // what calls still hold is no cache's now
      entries_.clear();
    }
    std::unique_lock<std::mutex> lock(unreleased_->mutex);
    if (unreleased_->none_left.wait_for(lock, kUnreleasedWait, [this] { return unreleased_->count == 0; })) return;
    unreleased_->orphaned = true;
    log(LogLevel::Warn, unreleased_->count, " buffer(s) of the ", what_,
        " cache outlived it; their bytes stay counted in the memory budget");
  }
  DeviceCache(const DeviceCache&) = delete;
  DeviceCache& operator=(const DeviceCache&) = delete;

  // The buffer of `key`, from compute() (returning a Made) on a miss. Thread-safe; compute() runs with no
  // lock held. A call that finds another computing `key` waits for it, and looks at `cancel` every
  // kCancelLook meanwhile (Error(Cancelled)): a cancelled call need not wait out another's computation.
  // `reserved`, when given, is call memory of the budget that counted the buffer computed (the caller's
  // reservation): a kept buffer moves its bytes from there to the cache (LimitGate::cache_from) rather than
  // asking the budget for them twice.
  template <typename Compute>
  cl::Buffer get(const Key& key, Compute&& compute, const Cancellation& cancel = {}, Slot* reserved = nullptr) {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      if (cl::Buffer found = find(key); found()) return found;
      if (std::find(computing_.begin(), computing_.end(), key) == computing_.end()) break;
      if (!cancel.can_be_requested()) {
        computed_one_.wait(lock);
        continue;
      }
      computed_one_.wait_for(lock, kCancelLook);
      lock.unlock();  // the call's cancellation may take locks of its own
      const bool cancelled = cancel.requested();
      lock.lock();
      if (cancelled) Cancellation::stopped("waiting for another call to make " + what_);
    }
    computing_.push_back(key);
    lock.unlock();
    Made made;
    try {
      made = compute();
    } catch (...) {
      lock.lock();
      std::erase(computing_, key);
      computed_one_.notify_all();
      throw;
    }
    lock.lock();
    ++computed_;
    try {
      if (made.bytes <= max_bytes_) keep(key, made, lock, reserved);
    } catch (...) {
      std::erase(computing_, key);
      computed_one_.notify_all();
      throw;
    }
    std::erase(computing_, key);  // after keep(), which may let go of the lock: the waiters then find it
    computed_one_.notify_all();
    return made.buffer;
  }

  // Evicts the least recently used buffers that no call holds now (evicting one in use frees nothing).
  uint64_t reclaim(uint64_t bytes) override {
    std::lock_guard<std::mutex> guard(mutex_);
    const uint64_t before = coming();
    for (uint64_t freed = 0; freed < bytes;) {
      auto unused = oldest_unused();
      if (unused == entries_.end()) break;
      freed += unused->bytes;
      evict(unused);
    }
    const uint64_t after = coming();  // less where older ones came back meanwhile: the caller asks more
    return after > before ? after - before : 0;
  }

  uint64_t computed() const {  // misses computed so far
    std::lock_guard<std::mutex> guard(mutex_);
    return computed_;
  }
  size_t bytes() const {  // held now
    std::lock_guard<std::mutex> guard(mutex_);
    return bytes_;
  }
  size_t entries() const {  // buffers kept now
    std::lock_guard<std::mutex> guard(mutex_);
    return entries_.size();
  }
  size_t max_bytes() const { return max_bytes_; }  // a buffer larger than this is not kept
  // Buffers kept at most, however small: a lookup walks them under the cache's lock, so that a client
  // asking for ever new tiny ones (a 2 x 2 ocean layer's spectrum is 96 bytes) cannot slow every call.
  static constexpr size_t kMaxEntries = 256;
  // The buffer of `key` if it is kept now, none otherwise; nothing is computed. While a caller holds it,
  // reclaim() leaves it alone (it takes back only the buffers nobody else holds).
  cl::Buffer kept(const Key& key) {
    std::lock_guard<std::mutex> guard(mutex_);
    return find(key);
  }
  // Whether `key` is kept now (a get() of it may still miss: it may be evicted meanwhile).
  bool holds(const Key& key) const {
    std::lock_guard<std::mutex> guard(mutex_);
    for (const Entry& e : entries_)
      if (e.key == key) return true;
    return false;
  }

 private:
  struct Held;
  struct Entry {
    Key key;
    cl::Buffer buffer;
    size_t bytes = 0;
    Held* held = nullptr;  // its bytes in the budget, owned by the buffer's destructor callback; none: no gate
  };

  static constexpr auto kUnreleasedWait = std::chrono::seconds(2);
  static constexpr auto kCancelLook = std::chrono::milliseconds(50);

  // The kept buffers whose destructor callbacks have not run yet. OpenCL runs them once the runtime has
  // freed the buffer (OpenCL 1.2 s5.4.1), which may be later, on a thread of the runtime's.
  struct Unreleased {
    std::mutex mutex;
    std::condition_variable none_left;
    size_t count = 0;
    uint64_t evicted_bytes = 0;  // of those, the bytes of buffers the cache let go of while no call held them
    bool orphaned = false;       // the cache has gone before them
  };
  struct Held {  // what a kept buffer's destructor callback owns
    Slot memory;
    std::shared_ptr<Unreleased> unreleased;
    uint64_t evicted_bytes = 0;  // its bytes in unreleased->evicted_bytes (under its mutex)
  };

  static void release_held(cl_mem, void* p) {
    auto* held = static_cast<Held*>(p);
    std::shared_ptr<Unreleased> unreleased = std::move(held->unreleased);
    std::lock_guard<std::mutex> lock(unreleased->mutex);
    unreleased->evicted_bytes -= held->evicted_bytes;
    if (unreleased->orphaned) held->memory.abandon();  // its budget may have gone with the cache
    delete held;                                       // its bytes go back to the budget
    if (--unreleased->count == 0) unreleased->none_left.notify_all();
  }

  uint64_t coming() const {  // bytes let go of unused whose callbacks have not run
    std::lock_guard<std::mutex> lock(unreleased_->mutex);
    return unreleased_->evicted_bytes;
  }

  // `memory` is released with the buffer's last reference (its destructor callback), not with the cache's;
  // the Held it is moved into, which stays valid while the cache holds a reference.
  Held* hold_until_released(cl::Buffer& buffer, Slot memory) {
    auto* held = new Held{std::move(memory), unreleased_};
    {
      std::lock_guard<std::mutex> lock(unreleased_->mutex);
      ++unreleased_->count;
    }
    try {
      buffer.setDestructorCallback(release_held, held);
    } catch (...) {
      release_held(nullptr, held);
      throw;
    }
    return held;
  }

  using Entries = std::list<Entry>;

  // The least recently used entry whose buffer only the cache holds (an OpenCL reference count of 1: no
  // call, and no command queued); end() if none.
  typename Entries::iterator oldest_unused() {
    for (auto it = entries_.end(); it != entries_.begin();) {
      --it;
      if (it->buffer.template getInfo<CL_MEM_REFERENCE_COUNT>() == 1) return it;
    }
    return entries_.end();
  }

  // Lets go of an entry; a buffer that calls still use keeps its bytes in the budget, as call memory.
  void evict(typename Entries::iterator it) {  // under mutex_
    if (it->held) {
      gate_->uncache(it->held->memory);
      const bool unused = it->buffer.template getInfo<CL_MEM_REFERENCE_COUNT>() == 1;  // else a call's to give back
      std::lock_guard<std::mutex> lock(unreleased_->mutex);
      it->held->evicted_bytes = unused ? it->bytes : 0;
      unreleased_->evicted_bytes += it->held->evicted_bytes;
    }
    bytes_ -= it->bytes;
    entries_.erase(it);  // its callback may run now, or later on the runtime's thread
  }

  cl::Buffer find(const Key& key) {  // under mutex_; none on a miss
    for (auto it = entries_.begin(); it != entries_.end(); ++it)
      if (it->key == key) {
        entries_.splice(entries_.begin(), entries_, it);
        return it->buffer;
      }
    return cl::Buffer();
  }

  // Under `lock` (of mutex_), which it lets go of while it waits for evicted bytes to come back (once).
  void keep(const Key& key, Made& made, std::unique_lock<std::mutex>& lock, Slot* reserved) {
    Slot memory = reserved && gate_ ? gate_->cache_from(*reserved, made.bytes) : Slot();
    if (memory.amount() > 0)
      while (!entries_.empty() && bytes_ + made.bytes > max_bytes_) evict_oldest();
    for (bool waited = false; memory.amount() == 0;) {  // again after a wait, which lets go of the lock
      // It serves its caller alone where even all the cache's bytes would not make room; the kept stay.
      if (gate_ && !gate_->memory_room(made.bytes, bytes_ + coming())) return;
      while (!entries_.empty() && bytes_ + made.bytes > max_bytes_) evict_oldest();
      if (!gate_) break;
      try {
        memory = gate_->acquire_cache_memory(what_, made.bytes);
        break;
      } catch (const Error&) {
        if (!waited && coming() > 0) {  // what it let go of comes back from the runtime's thread
          lock.unlock();
          gate_->await_memory_room(made.bytes);
          lock.lock();
          waited = true;
          continue;
        }
        auto unused = oldest_unused();
        if (unused == entries_.end()) return;  // the others' holdings grew meanwhile, or are in use
        evict(unused);                         // the budget the least recently used hold goes to the newest
      }
    }
    while (entries_.size() >= kMaxEntries) evict_oldest();
    Held* held = gate_ ? hold_until_released(made.buffer, std::move(memory)) : nullptr;
    entries_.push_front(Entry{key, made.buffer, made.bytes, held});
    bytes_ += made.bytes;
  }

  void evict_oldest() { evict(std::prev(entries_.end())); }  // under mutex_, with entries

  const size_t max_bytes_;
  LimitGate* gate_;
  const std::string what_;
  mutable std::mutex mutex_;
  std::condition_variable computed_one_;
  Entries entries_;             // most recently used first
  std::vector<Key> computing_;  // misses being computed now
  std::shared_ptr<Unreleased> unreleased_ = std::make_shared<Unreleased>();
  size_t bytes_ = 0;
  uint64_t computed_ = 0;
};

}  // namespace squall
