#include "runtime/queue_slots.h"

#include <algorithm>
#include <bit>
#include <chrono>

#include "common/error.h"
#include "common/log.h"

namespace squall {
namespace {

thread_local int t_slot = -1;        // the slot of the lease this thread holds
thread_local uint64_t t_serial = 0;  // that lease's serial
std::atomic<uint64_t> g_serials{0};  // leases taken in the process

// A kind's key in the learned holds: its site and its size's power of two; empty for no kind.
std::string kind_key(const WorkKind& kind) {
  return kind.site ? std::string(kind.site) + "/" + std::to_string(std::bit_width(kind.size)) : std::string();
}

// At most count, and about half of it from 4 queues on: 1 -> 1, 2 -> 2, 3 -> 2, 4 -> 2, 8 -> 4.
size_t long_limit_of(size_t count) { return std::max(std::min<size_t>(count, 2), count - count / 2); }

}  // namespace

int held_queue_slot() { return t_slot; }
size_t current_queue_slot() { return t_slot < 0 ? 0 : size_t(t_slot); }
uint64_t held_lease_serial() { return t_serial; }

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
    : on_settled_(std::move(on_settled)),
      busy_(std::clamp<size_t>(count, 1, 16), false),
      holders_(busy_.size()),
      long_limit_(long_limit_of(busy_.size())) {
  for (size_t i = 0; i < busy_.size(); ++i) queues_.emplace_back(context, device, properties);
}

QueueLease QueueSlots::acquire(const WorkKind& kind) {
  if (t_slot >= 0) fail(Code::Internal, "a thread asked for a second device queue while holding one");
  const std::string key = kind_key(kind);
  std::unique_lock<std::mutex> lock(mutex_);
  const int k = kind_index(key);
  const char* site = kind.site ? kind.site : "";
  const double hold = expected(k);
  if (k >= 0) holds_[size_t(k)].asked = std::chrono::steady_clock::now();
  serve_line();  // a waiter whose kind is no longer limited may take a free queue before this caller
  const bool limited = is_limited(hold);
  int slot = -1;
  // A free queue with callers waiting is now one that none of them may take: a caller that may take it
  // passes nobody who could.
  const auto free_slot = std::find(busy_.begin(), busy_.end(), false);
  if (free_slot != busy_.end() && may_take_queue(limited)) {
    slot = int(free_slot - busy_.begin());
    occupy(size_t(slot), limited);
  } else {  // in line behind the callers that came first (or most of them); serve_line() hands it a slot
    Waiter self;
    self.expected = hold;
    waiting_.insert(place_in_line(self.expected), &self);
    const auto start = std::chrono::steady_clock::now();
    // Shorter work that stops asking stops limiting the others with no call to the pool: a waiter looks
    // again now and then, so that it does not wait for a queue left free.
    while (!self.handed.wait_for(lock, kShortWorkWindow / 8, [&] { return self.slot >= 0; })) serve_line();
    site_times_[site].wait_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    slot = self.slot;
  }
  ++acquisitions_;
  ++held_;
  t_slot = slot;
  t_serial = ++g_serials;
  return QueueLease(this, size_t(slot), k, site);
}

double QueueSlots::expected_hold(const WorkKind& kind) {
  const std::string key = kind_key(kind);
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = kinds_.find(key);
  return it == kinds_.end() ? 0 : expected(it->second);
}

void QueueSlots::record_hold(const WorkKind& kind, double seconds, bool alone) {
  const std::string key = kind_key(kind);
  std::lock_guard<std::mutex> lock(mutex_);
  const int k = kind_index(key);
  learn(k, seconds, alone);
  if (k >= 0) holds_[size_t(k)].asked = std::chrono::steady_clock::now();
  serve_line();  // what is limited may have changed
}

int QueueSlots::kind_index(const std::string& key) {
  if (key.empty()) return -1;
  const auto [it, added] = kinds_.emplace(key, int(holds_.size()));
  if (added) holds_.push_back({});
  return it->second;
}

// Exponential moving averages of the kind's holds, alone and beside others, with weight 1/8 for the
// newest, the first hold their start: each follows a change within some 10 leases.
void QueueSlots::learn(int kind, double seconds, bool alone) {
  if (kind < 0) return;
  double& hold = alone ? holds_[size_t(kind)].alone : holds_[size_t(kind)].beside_others;
  hold = hold > 0 ? hold + (seconds - hold) / 8 : seconds;
}

// A hold beside other leases overstates the kind's own work (its commands wait behind theirs), and a hold
// alone may include one-off costs (a first plan): the smaller mean is expected, either if only one is known.
double QueueSlots::expected(int kind) const {
  if (kind < 0) return 0;
  const Learned& l = holds_[size_t(kind)];
  if (l.alone > 0 && l.beside_others > 0) return std::min(l.alone, l.beside_others);
  return std::max(l.alone, l.beside_others);
}

// Among the kinds that asked for a queue in the last kShortWorkWindow, those expected to hold it at most
// 1 / kPassRatio as long as the longest are short; while there are any, the others are limited. Work of
// no kind, or of a kind not learned yet, is not limited.
bool QueueSlots::is_limited(double expected) const {
  if (expected <= 0) return false;
  const auto since = std::chrono::steady_clock::now() - kShortWorkWindow;
  double longest = expected, shortest = expected;
  for (size_t k = 0; k < holds_.size(); ++k) {
    const double other = this->expected(int(k));
    if (other <= 0 || holds_[k].asked < since) continue;
    longest = std::max(longest, other);
    shortest = std::min(shortest, other);
  }
  return kPassRatio * shortest <= longest && kPassRatio * expected > longest;
}

bool QueueSlots::may_take_queue(bool limited) const { return !limited || long_held_ < long_limit_; }

// Marks `slot` busy. The leases held beside it no longer have the device to themselves, and it has the
// device to itself only if none is held.
void QueueSlots::occupy(size_t slot, bool limited) {
  bool alone = true;
  for (size_t i = 0; i < busy_.size(); ++i)
    if (busy_[i] && i != slot) alone = holders_[i].alone = false;
  busy_[slot] = true;
  holders_[slot] = {limited, alone};
  if (limited) ++long_held_;
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
  if (t_slot == int(slot)) t_slot = -1, t_serial = 0;
  --held_;
  if (on_settled_) on_settled_(slot);
  const double held = std::chrono::duration<double>(std::chrono::steady_clock::now() - lease.since_).count();
  std::lock_guard<std::mutex> lock(mutex_);
  const Holder& holder = holders_[slot];
  learn(lease.kind_, held, holder.alone);
  if (holder.limited) --long_held_;
  busy_[slot] = false;
  SiteTimes& times = site_times_[lease.site_];
  ++times.leases;
  times.hold_seconds += held;
  serve_line();  // the slot goes straight to the first in line that may take it: no caller overtakes it
}

// Hands free queues to the first callers in line that may take one, by the limits as they stand now (a
// kind's class changes as shorter work comes and goes).
// One pass suffices: a queue handed on only raises the count of limited leases, so a waiter passed over
// stays one that may not take a queue.
void QueueSlots::serve_line() {
  auto free_slot = std::find(busy_.begin(), busy_.end(), false);
  for (auto it = waiting_.begin(); free_slot != busy_.end() && it != waiting_.end();) {
    const bool limited = is_limited((*it)->expected);
    if (!may_take_queue(limited)) {
      ++it;
      continue;
    }
    Waiter* waiter = *it;
    it = waiting_.erase(it);
    occupy(size_t(free_slot - busy_.begin()), limited);
    waiter->slot = int(free_slot - busy_.begin());
    waiter->handed.notify_one();  // under mutex_: the waiter (on its own stack) cannot leave before this ends
    free_slot = std::find(busy_.begin(), busy_.end(), false);
  }
}

}  // namespace squall
