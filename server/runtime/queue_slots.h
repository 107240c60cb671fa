// The device's command queues: a few in-order queues, each used by one request at a time, so that
// independent requests run concurrently where the device has room (one queue: they take turns).
//
// A request's device work runs under a QueueLease (Runtime::exclusive()). The lease takes a free queue
// and makes it the calling thread's queue: Runtime::queue(), Kernel<...>::launch (one kernel object per
// queue) and the FFT plans (one per queue) use it. When the lease ends it waits for its queue (clFinish),
// so no work of a request is still running when the buffers it handed back go to another queue.
//
// Callers wait in line for a queue, first come, first served, with two exceptions for short work:
// - A request expected to hold its queue for much less time than those waiting at the end of the line goes
//   ahead of them (shortest job first: L. Kleinrock, "Queueing Systems, Volume 2: Computer Applications",
//   1976, ch. 3), so a small render does not wait behind a row of large tiles.
// - While much shorter work is about (of the kinds of work that asked for a queue in the last second,
//   some are expected to hold it at most 1 / kPassRatio as long as the longest), the other kinds hold at
//   most about half the queues at once (long_limit(); leases taken while no shorter work was about do not
//   count), and the rest are kept for the shorter work; a caller waiting at that limit takes a free queue
//   within kShortWorkWindow / 8 of the shorter work's going. A
//   request shares the device with the others holding queues (on a CPU device, PoCL's worker threads run
//   the commands of all queues in one line), so each long request added stretches every request beside
//   it, and a short one that finds every queue taken waits for a long one's whole hold. Queues kept for
//   short jobs: M. Harchol-Balter, "Performance Modeling and Design of Computer Systems", 2013, ch. 24
//   (task assignment by size in server farms). With no much shorter work about, or for work of no kind,
//   every queue may be taken.
// Expectations are learned: the pool keeps, per kind of work (WorkKind), running means of how long its
// leases held their queue alone on the device and beside others, and expects the smaller of the two.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

#include "runtime/opencl.h"

namespace squall {

class QueueSlots;

// What a lease is for: the call site (a string literal, e.g. "ocean.tile") and the size of its work in the
// site's own unit (cells, pixels). Sizes within a factor of two share one learned hold time. No site:
// nothing is learned, the caller neither passes nor is passed in line, and no queue is kept from it.
struct WorkKind {
  const char* site = nullptr;
  size_t size = 0;
};

// The queue slot the calling thread's lease holds: 0 .. count - 1, or -1 outside any lease.
int held_queue_slot();
// held_queue_slot(), or 0 outside any lease: the queue (and kernel object, plan) to use.
size_t current_queue_slot();
// A number of the calling thread's lease, distinct from every other lease's in the process, or 0 outside any
// lease. What a lease enqueued has run once another lease holds its slot (the pool finishes a queue before
// handing it on), so whatever a slot's earlier leases used may then be freed.
uint64_t held_lease_serial();

// Exclusive use of one queue by the calling thread, until unlock() or destruction. Movable, but only
// within that thread: the slot is the thread's (a thread_local), and it is that thread's release that
// clears it.
class QueueLease {
 public:
  QueueLease() = default;
  QueueLease(QueueLease&& other) noexcept;
  QueueLease& operator=(QueueLease&& other) noexcept;
  QueueLease(const QueueLease&) = delete;
  QueueLease& operator=(const QueueLease&) = delete;
  ~QueueLease() { unlock(); }

  bool held() const { return slots_ != nullptr; }
  size_t slot() const { return slot_; }
  // Waits for the queue's work and gives the queue back.
  void unlock();

 private:
  friend class QueueSlots;
  QueueLease(QueueSlots* slots, size_t slot, int kind, const char* site);

  QueueSlots* slots_ = nullptr;
  size_t slot_ = 0;
  int kind_ = -1;          // index of the lease's WorkKind in the pool's learned holds, -1 for none
  const char* site_ = "";  // its WorkKind's site
  std::chrono::steady_clock::time_point since_;
};

class QueueSlots {
 public:
  // count queues (1..16) on device; on_settled(slot) runs when a lease of that slot has ended and its
  // queue finished (the buffer pool then lets other queues reuse what was handed back under it).
  QueueSlots(const cl::Context& context, const cl::Device& device, size_t count, cl_command_queue_properties properties,
             std::function<void(size_t)> on_settled);

  size_t count() const { return queues_.size(); }
  const cl::CommandQueue& queue(size_t slot) const { return queues_.at(slot); }

  // A caller in line is passed by at most this many shorter requests, each expected to hold its queue at
  // most 1 / kPassRatio as long as the caller: it waits at most kMaxPassed / kPassRatio of its own hold
  // longer than in turn, but for the time that it may not take a queue (long_limit()), during which any
  // caller that may take one does.
  static constexpr int kMaxPassed = 4;
  static constexpr double kPassRatio = 2;
  // How recently a much shorter kind of work must have asked for a queue for queues to be kept for it.
  static constexpr std::chrono::milliseconds kShortWorkWindow{1000};

  // Leases of limited kinds (much shorter work about) held at once: at most count(), and at most about
  // half of it from 4 queues on: 1 -> 1, 2 -> 2, 3 -> 2, 4 -> 2, 8 -> 4, 16 -> 8.
  size_t long_limit() const { return long_limit_; }

  // Waits for a free queue (the wait is counted) and leases it to the calling thread, which must not
  // hold one already. Waiting callers get queues in the order they asked, but for the shorter requests
  // that may pass them and those that may take the queues kept for them (see above); a caller of no kind,
  // or of a kind not learned yet, neither passes nor is passed, and is not limited.
  QueueLease acquire(const WorkKind& kind = {});

  // The expected hold of `kind`, s: the smaller of its running means alone and beside other leases (0
  // before its first lease ends).
  double expected_hold(const WorkKind& kind);
  // Learns one hold of `kind`, s, alone on the device or beside other leases, as the end of each of its
  // leases does, and notes that the kind asked for a queue now (tests, warm-up).
  void record_hold(const WorkKind& kind, double seconds, bool alone = true);

  uint64_t acquisitions() const { return acquisitions_; }
  size_t waiting();                      // callers waiting for a queue now
  size_t held() const { return held_; }  // leases held now
  double wait_seconds();                 // waited for a queue since start-up, all call sites together
  // Per call site (WorkKind::site, "" for work of no kind), since start-up: the leases that have ended,
  // and the seconds they waited for a queue and held one. Where a request's time on the device goes.
  struct SiteTimes {
    uint64_t leases = 0;
    double wait_seconds = 0;
    double hold_seconds = 0;
  };
  std::map<std::string, SiteTimes> site_times();

 private:
  friend class QueueLease;
  struct Waiter;
  void release(const QueueLease& lease);
  int kind_index(const std::string& key);                        // under mutex_; -1 for the empty key (no kind)
  void learn(int kind, double seconds, bool alone);              // under mutex_
  double expected(int kind) const;                               // under mutex_
  bool is_limited(double expected) const;                        // under mutex_
  bool may_take_queue(bool limited) const;                       // under mutex_
  void occupy(size_t slot, bool limited);                        // under mutex_
  void serve_line();                                             // under mutex_
  std::deque<Waiter*>::iterator place_in_line(double expected);  // under mutex_; counts the passed

  std::vector<cl::CommandQueue> queues_;
  std::function<void(size_t)> on_settled_;
  struct Waiter {
    std::condition_variable handed;
    int slot = -1;        // the slot serve_line() handed it
    double expected = 0;  // its kind's expected hold, s; 0: not known
    int passed = 0;       // by how many callers that came after it
  };
  // A held slot's lease: whether it counts toward long_limit(), whether it has had the device to itself
  // so far.
  struct Holder {
    bool limited = false;
    bool alone = false;
  };
  // Running means of a kind's holds, s (0: none yet), and when it last asked for a queue.
  struct Learned {
    double alone = 0, beside_others = 0;
    std::chrono::steady_clock::time_point asked;
  };
  std::mutex mutex_;
  std::vector<bool> busy_;
  std::vector<Holder> holders_;  // per slot, while busy
  const size_t long_limit_;
  size_t long_held_ = 0;                         // busy slots whose lease is limited
  std::deque<Waiter*> waiting_;                  // callers of acquire() waiting for a slot, in line order
  std::unordered_map<std::string, int> kinds_;   // "site/log2 size" -> index in holds_
  std::vector<Learned> holds_;                   // per kind
  std::atomic<uint64_t> acquisitions_{0};        // statistics, read without mutex_
  std::atomic<size_t> held_{0};                  // leases from acquire() to the end of release()
  std::map<std::string, SiteTimes> site_times_;  // under mutex_
};

}  // namespace squall
