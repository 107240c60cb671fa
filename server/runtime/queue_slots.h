// The device's command queues: a few in-order queues, each used by one request at a time, so that
// independent requests run concurrently where the device has room (one queue: they take turns).
//
// A request's device work runs under a QueueLease (Runtime::exclusive()). The lease takes a free queue
// and makes it the calling thread's queue: Runtime::queue(), Kernel<...>::launch (one kernel object per
// queue) and the FFT plans (one per queue) use it. When the lease ends it waits for its queue (clFinish),
// so no work of a request is still running when the buffers it handed back go to another queue.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <vector>

#include "runtime/opencl.h"

namespace squall {

class QueueSlots;

// The queue slot the calling thread's lease holds: 0 .. count - 1, or -1 outside any lease.
int held_queue_slot();
// held_queue_slot(), or 0 outside any lease: the queue (and kernel object, plan) to use.
size_t current_queue_slot();

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
  QueueLease(QueueSlots* slots, size_t slot) : slots_(slots), slot_(slot) {}

  QueueSlots* slots_ = nullptr;
  size_t slot_ = 0;
};

class QueueSlots {
 public:
  // count queues (1..16) on device; on_settled(slot) runs when a lease of that slot has ended and its
  // queue finished (the buffer pool then lets other queues reuse what was handed back under it).
  QueueSlots(const cl::Context& context, const cl::Device& device, size_t count, cl_command_queue_properties properties,
             std::function<void(size_t)> on_settled);

  size_t count() const { return queues_.size(); }
  const cl::CommandQueue& queue(size_t slot) const { return queues_.at(slot); }

  // Waits for a free queue (the wait is counted) and leases it to the calling thread, which must not
  // hold one already. Waiting callers get queues in the order they asked: none waits behind a later one.
  QueueLease acquire();

  uint64_t acquisitions() const { return acquisitions_; }
  size_t waiting();  // callers waiting for a queue now
  uint64_t wait_ns() const { return wait_ns_; }

 private:
  friend class QueueLease;
  void release(size_t slot);

  std::vector<cl::CommandQueue> queues_;
  std::function<void(size_t)> on_settled_;
  struct Waiter {
    std::condition_variable handed;
    int slot = -1;  // the slot release() handed it
  };
  std::mutex mutex_;
  std::vector<bool> busy_;
  std::deque<Waiter*> waiting_;  // callers of acquire() waiting for a slot, first come, first served
  std::atomic<uint64_t> acquisitions_{0}, wait_ns_{0};  // statistics, read without mutex_
};

}  // namespace squall
