#include "runtime/queue_slots.h"

#include <algorithm>
#include <bit>
#include <chrono>

#include "common/error.h"
#include "common/log.h"

namespace squall {
namespace {

thread_local int t_slot = -1;  // the slot of the lease this thread holds

// A kind's key in the learned holds: its site and its size's power of two; empty for no kind.
std::string kind_key(const WorkKind& kind) {
  return kind.site ? std::string(kind.site) + "/" + std::to_string(std::bit_width(kind.size)) : std::string();
}

}  // namespace

int held_queue_slot() { return t_slot; }
size_t current_queue_slot() { return t_slot < 0 ? 0 : size_t(t_slot); }

QueueLease::QueueLease(QueueSlots* slots, size_t slot, int kind, const char* site)
    : slots_(slots), slot_(slot), kind_(kind), site_(site), since_(std::chrono::steady_clock::now()) {}

QueueLease::QueueLease(QueueLease&& other) noexcept
    : slots_(other.slots_), slot_(other.slot_), kind_(other.kind_), site_(other.site_), since_(other.since_) {
  other.slots_ = nullptr;
}

QueueLease& QueueLease::operator=(QueueLease&& other) noexcept {
  if (this != &other) {
    unlock();
    slots_ = other.slots_;
    slot_ = other.slot_;
    kind_ = other.kind_;
    site_ = other.site_;
    since_ = other.since_;
    other.slots_ = nullptr;
  }
  return *this;
}

void QueueLease::unlock() {
  if (!slots_) return;
  slots_->release(*this);
  slots_ = nullptr;
}

QueueSlots::QueueSlots(const cl::Context& context, const cl::Device& device, size_t count,
                       cl_command_queue_properties properties, std::function<void(size_t)> on_settled)
    : on_settled_(std::move(on_settled)), busy_(std::clamp<size_t>(count, 1, 16), false) {
  for (size_t i = 0; i < busy_.size(); ++i) queues_.emplace_back(context, device, properties);
}

QueueLease QueueSlots::acquire(const WorkKind& kind) {
  if (t_slot >= 0) fail(Code::Internal, "a thread asked for a second device queue while holding one");
  const std::string key = kind_key(kind);
  std::unique_lock<std::mutex> lock(mutex_);
  const int k = kind_index(key);
  const char* site = kind.site ? kind.site : "";
  int slot = -1;
  const auto free_slot = std::find(busy_.begin(), busy_.end(), false);
  if (waiting_.empty() && free_slot != busy_.end()) {
    slot = int(free_slot - busy_.begin());
    busy_[size_t(slot)] = true;
  } else {  // in line behind the callers that came first (or most of them); release() hands it its slot
    Waiter self;
    self.expected = k < 0 ? 0 : holds_[size_t(k)];
    waiting_.insert(place_in_line(self.expected), &self);
    const auto start = std::chrono::steady_clock::now();
    self.handed.wait(lock, [&] { return self.slot >= 0; });
    site_times_[site].wait_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    slot = self.slot;
  }
  ++acquisitions_;
  ++held_;
  t_slot = slot;
  return QueueLease(this, size_t(slot), k, site);
}

double QueueSlots::expected_hold(const WorkKind& kind) {
  const std::string key = kind_key(kind);
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = kinds_.find(key);
  return it == kinds_.end() ? 0 : holds_[size_t(it->second)];
}

void QueueSlots::record_hold(const WorkKind& kind, double seconds) {
  const std::string key = kind_key(kind);
  std::lock_guard<std::mutex> lock(mutex_);
  learn(kind_index(key), seconds);
}

int QueueSlots::kind_index(const std::string& key) {
  if (key.empty()) return -1;
  const auto [it, added] = kinds_.emplace(key, int(holds_.size()));
  if (added) holds_.push_back(0);
  return it->second;
}

// An exponential moving average of the kind's holds with weight 1/8 for the newest, the first hold its
// start: it follows a change of load within some 10 leases.
void QueueSlots::learn(int kind, double seconds) {
  if (kind < 0) return;
  double& hold = holds_[size_t(kind)];
  hold = hold > 0 ? hold + (seconds - hold) / 8 : seconds;
}

// Behind the last waiter that the caller may not pass: one expected to take less than kPassRatio times
// the caller's hold, or of unknown hold, or passed kMaxPassed times already. A caller of unknown hold
// passes none.
std::deque<QueueSlots::Waiter*>::iterator QueueSlots::place_in_line(double expected) {
  auto at = waiting_.end();
  if (expected <= 0) return at;
  while (at != waiting_.begin()) {
    const Waiter* w = *std::prev(at);
    const bool longer = w->expected > 0 && w->expected >= kPassRatio * expected;
    if (!longer || w->passed >= kMaxPassed) break;
    --at;
  }
  for (auto it = at; it != waiting_.end(); ++it) ++(*it)->passed;
  return at;
}

size_t QueueSlots::waiting() {
  std::lock_guard<std::mutex> lock(mutex_);
  return waiting_.size();
}

double QueueSlots::wait_seconds() {
  std::lock_guard<std::mutex> lock(mutex_);
  double seconds = 0;
  for (const auto& [site, times] : site_times_) seconds += times.wait_seconds;
  return seconds;
}

std::map<std::string, QueueSlots::SiteTimes> QueueSlots::site_times() {
  std::lock_guard<std::mutex> lock(mutex_);
  return site_times_;
}

void QueueSlots::release(const QueueLease& lease) {
  const size_t slot = lease.slot_;
  try {
    queues_[slot].finish();
  } catch (const cl::Error& e) {  // the device failed: the next call on it reports it
    log(LogLevel::Error, "finishing device queue ", slot, ": ", e.what(), " (", e.err(), ")");
  }
  if (t_slot == int(slot)) t_slot = -1;
  --held_;
  if (on_settled_) on_settled_(slot);
  const double held = std::chrono::duration<double>(std::chrono::steady_clock::now() - lease.since_).count();
  std::lock_guard<std::mutex> lock(mutex_);
  learn(lease.kind_, held);
  SiteTimes& times = site_times_[lease.site_];
  ++times.leases;
  times.hold_seconds += held;
  if (waiting_.empty()) {
    busy_[slot] = false;
    return;
  }
  Waiter* next = waiting_.front();  // the slot goes straight to the first in line: no caller overtakes it
  waiting_.pop_front();
  next->slot = int(slot);
  next->handed.notify_one();  // under mutex_: the waiter (on its own stack) cannot leave before this ends
}

}  // namespace squall
