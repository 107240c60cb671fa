#include "common/limits.h"

#include <algorithm>
#include <functional>
#include <thread>

#include "common/error.h"
#include "common/validate.h"

namespace squall {

Slot& Slot::operator=(Slot&& other) noexcept {
  if (this != &other) {
    release();
    counter_ = other.counter_;
    also_ = other.also_;
    amount_ = other.amount_;
    other.counter_ = nullptr;
  }
  return *this;
}

void Slot::give_back(uint64_t bytes) {
  if (!counter_) return;
  bytes = std::min(bytes, amount_);
  counter_->fetch_sub(bytes);
  if (also_) also_->fetch_sub(bytes);
  amount_ -= bytes;
}

Slot Slot::split(uint64_t bytes) {
  if (!counter_) return Slot();
  bytes = std::min(bytes, amount_);
  amount_ -= bytes;
  Slot part(counter_, bytes);
  part.also_ = also_;
  return part;
}

void Slot::release() {
  if (counter_) counter_->fetch_sub(amount_);
  if (counter_ && also_) also_->fetch_sub(amount_);
  counter_ = nullptr;
}

void LimitGate::check_grid(const std::string& field, int64_t nx, int64_t ny, int64_t nz) const {
  if (nz == 0) return check_grid(field + ".nx", field + ".ny", nx, ny);
  check_extents({field + ".nx", field + ".ny", field + ".nz"}, {nx, ny, nz});
}

void LimitGate::check_grid(const std::string& x_field, const std::string& y_field, int64_t nx, int64_t ny) const {
  check_extents({x_field, y_field}, {nx, ny});
}

void LimitGate::check_extents(const std::vector<std::string>& fields, const std::vector<int64_t>& extents) const {
  double cells = 1;  // in floating point, so that huge extents cannot overflow the product
  std::string product;
  for (size_t a = 0; a < fields.size(); ++a) {
    if (extents[a] < 1) fail(Code::InvalidArgument, fields[a] + " = " + std::to_string(extents[a]) + " must be >= 1");
    cells *= double(extents[a]);
    product += (a ? " * " : "") + fields[a];
  }
  if (cells > double(limits_.max_grid_cells)) {
    const std::string count = cells < 0x1p64 ? std::to_string(uint64_t(cells)) : validate::number(cells);
    fail(Code::ResourceExhausted,
         product + " = " + count + " cells exceeds --max-grid-cells = " + std::to_string(limits_.max_grid_cells));
  }
}

void LimitGate::check_message_bytes(const std::string& what, uint64_t bytes) const {
  if (bytes > limits_.max_message_bytes || limits_.max_message_bytes - bytes < kReplyFieldBytes)
    fail(Code::ResourceExhausted, what + " needs " + std::to_string(bytes) + " bytes and up to " +
                                      std::to_string(kReplyFieldBytes) + " of other fields, more than " +
                                      "--max-message-bytes = " + std::to_string(limits_.max_message_bytes));
}

void LimitGate::check_render_samples(const std::string& field, const std::string& value, double samples,
                                     const std::string& cheaper) const {
  if (!(samples <= limits_.max_render_samples))
    fail(Code::ResourceExhausted, field + " = " + value + " makes an estimated " + validate::number(samples) +
                                      " density samples, more than --max-render-samples = " +
                                      validate::number(limits_.max_render_samples) + " (" + cheaper + " cost less)");
}

void LimitGate::check_bake_work(const std::string& what, double tests) const {
  if (!(tests <= limits_.max_bake_work))
    fail(Code::ResourceExhausted,
         what + " makes an estimated " + validate::number(tests) +
             " wall and polygon tests, more than --max-bake-work = " + validate::number(limits_.max_bake_work) +
             " (fewer nodes, a smaller search_radius or fewer wall points cost less)");
}

// Adds `amount` to `counter` unless that would pass `limit`; the message names what and the flag:
// "streams: 16 already open, the limit is --max-streams = 16".
Slot LimitGate::take(std::atomic<uint64_t>& counter, uint64_t amount, uint64_t limit, const std::string& what,
                     const char* flag, const char* held_as) {
  uint64_t held = counter.load();
  do {
    if (amount > limit || held > limit - amount)
      fail(Code::ResourceExhausted, what + ": " + std::to_string(held) + " " + held_as + ", the limit is " + flag +
                                        " = " + std::to_string(limit));
  } while (!counter.compare_exchange_weak(held, held + amount));
  return Slot(&counter, amount);
}

Slot LimitGate::acquire_stream() {
  return take(streams_, 1, limits_.max_streams, "streams", "--max-streams", "already open");
}

Slot LimitGate::acquire_call() { return take(calls_, 1, limits_.max_calls, "calls", "--max-calls", "running"); }

Slot LimitGate::acquire_client_stream(const std::string& client) {
  if (limits_.max_streams_per_client == 0) return Slot();
  auto& bucket = client_streams_[std::hash<std::string>{}(client) % kClientBuckets];
  return take(bucket, 1, limits_.max_streams_per_client, "streams of " + validate::printable(client),
              "--max-streams-per-client", "already open");
}

Slot LimitGate::acquire_client_session(const std::string& client) {
  if (limits_.max_sessions_per_client == 0) return Slot();
  auto& bucket = client_sessions_[std::hash<std::string>{}(client) % kClientBuckets];
  return take(bucket, 1, limits_.max_sessions_per_client, "sessions of " + validate::printable(client),
              "--max-sessions-per-client", "already live");
}

Slot LimitGate::acquire_session() {
  return take(sessions_, 1, limits_.max_sessions, "sessions", "--max-sessions", "already live");
}

Slot LimitGate::acquire_session_bytes(const std::string& what, uint64_t bytes) {
  return take(session_bytes_, bytes, limits_.max_session_bytes,
              what + " (" + std::to_string(bytes) + " bytes) would pass the session memory cap", "--max-session-bytes",
              "bytes already held");
}

bool LimitGate::memory_room(uint64_t bytes, uint64_t given_back) const {
  const uint64_t held = memory_bytes_.load();
  const uint64_t others = held - std::min(given_back, held);
  return others <= limits_.memory_budget && bytes <= limits_.memory_budget - others;
}

bool LimitGate::await_memory_room(uint64_t bytes) const {
  const auto until = std::chrono::steady_clock::now() + kReleaseWait;
  while (!memory_room(bytes)) {
    if (std::chrono::steady_clock::now() >= until) return false;
    std::this_thread::sleep_for(std::chrono::microseconds(250));
  }
  return true;
}

namespace {
std::string past_the_budget(const std::string& what, uint64_t bytes) {
  return what + " (" + std::to_string(bytes) + " bytes) would pass the memory budget";
}
}  // namespace

Slot LimitGate::take_memory(const std::string& what, uint64_t bytes) {
  return take(memory_bytes_, bytes, limits_.memory_budget, past_the_budget(what, bytes), "--memory-budget",
              "bytes already in use");
}

void LimitGate::check_memory(const std::string& what, uint64_t bytes) const {
  if (bytes > limits_.memory_budget)
    fail(Code::ResourceExhausted, past_the_budget(what, bytes) + " on its own, the limit is --memory-budget = " +
                                      std::to_string(limits_.memory_budget));
}

void LimitGate::top_up(Slot& slot, const std::string& what, const std::function<uint64_t()>& needed) {
  for (uint64_t now; (now = needed()) > slot.amount();) {
    slot = Slot();  // given back first: the new one may need all of the room
    slot = acquire_memory(what, now);
  }
}

// The room the caches give back may be taken by another holder before this call takes it (a buffer handed
// back to the pool): the caches are asked again, a few times, while they could still make room.
Slot LimitGate::acquire_memory(const std::string& what, uint64_t bytes) {
  constexpr int kAttempts = 3;
  bool waited = false;
  for (int attempt = 1;; ++attempt) {
    uint64_t coming = 0;  // let go of by the caches, not given back yet: not asked of them again
    if (!memory_room(bytes) && memory_room(bytes, cached_bytes_.load())) {  // the caches can make room
      std::lock_guard<std::mutex> lock(reclaimers_mutex_);
      for (MemoryReclaimer* cache : reclaimers_) {
        const uint64_t now = memory_bytes_.load(), held = now - std::min(coming, now);
        if (held <= limits_.memory_budget - bytes) break;
        coming += cache->reclaim(held - (limits_.memory_budget - bytes));
      }
    }
    if (coming > 0 && !waited) {  // once a call, as long as what is coming takes
      await_memory_room(bytes);
      waited = true;
    }
    try {
      return take_memory(what, bytes);
    } catch (const Error&) {
      if (attempt == kAttempts || !memory_room(bytes, cached_bytes_.load())) throw;
    }
  }
}

Slot LimitGate::acquire_cache_memory(const std::string& what, uint64_t bytes) {
  Slot slot = take_memory(what, bytes);
  cached_bytes_ += bytes;
  slot.also_ = &cached_bytes_;
  return slot;
}

Slot LimitGate::cache_from(Slot& held, uint64_t bytes) {
  if (held.counter_ != &memory_bytes_ || held.also_ || held.amount_ < bytes) return Slot();
  held.amount_ -= bytes;
  Slot slot(&memory_bytes_, bytes);
  cached_bytes_ += bytes;
  slot.also_ = &cached_bytes_;
  return slot;
}

void LimitGate::uncache(Slot& cached) {
  if (!cached.counter_ || cached.also_ != &cached_bytes_) return;
  cached_bytes_ -= cached.amount_;
  cached.also_ = nullptr;
}

void LimitGate::add_reclaimer(MemoryReclaimer* cache) {
  std::lock_guard<std::mutex> lock(reclaimers_mutex_);
  reclaimers_.push_back(cache);
}

void LimitGate::remove_reclaimer(MemoryReclaimer* cache) {
  std::lock_guard<std::mutex> lock(reclaimers_mutex_);
  std::erase(reclaimers_, cache);
}

}  // namespace squall
