#include "common/limits.h"

#include "common/error.h"

namespace squall {

Slot& Slot::operator=(Slot&& other) noexcept {
  if (this != &other) {
    release();
    counter_ = other.counter_;
    other.counter_ = nullptr;
  }
  return *this;
}

void Slot::release() {
  if (counter_) counter_->fetch_sub(1);
  counter_ = nullptr;
}

void LimitGate::check_grid(const std::string& field, int64_t nx, int64_t ny, int64_t nz) const {
  const struct { const char* axis; int64_t n; } extents[] = {{"nx", nx}, {"ny", ny}, {"nz", nz}};
  for (const auto& e : extents) {
    bool is_optional_z = e.axis[1] == 'z' && e.n == 0;
    if (e.n < 1 && !is_optional_z)
      fail(Code::InvalidArgument, field + "." + e.axis + " = " + std::to_string(e.n) + " must be >= 1");
  }
  // Compare in floating point first so that huge extents cannot overflow the product.
  double cells_f = double(nx) * double(ny) * double(nz > 0 ? nz : 1);
  if (cells_f > double(limits_.max_grid_cells)) {
    std::string product = field + ".nx * " + field + ".ny" + (nz > 0 ? " * " + field + ".nz" : "");
    fail(Code::ResourceExhausted, product + " = " + std::to_string(uint64_t(cells_f)) +
                                      " cells exceeds --max-grid-cells = " +
                                      std::to_string(limits_.max_grid_cells));
  }
}

void LimitGate::check_message_bytes(const std::string& what, uint64_t bytes) const {
  if (bytes > limits_.max_message_bytes)
    fail(Code::ResourceExhausted, what + " needs " + std::to_string(bytes) +
                                      " bytes, more than --max-message-bytes = " +
                                      std::to_string(limits_.max_message_bytes));
}

Slot LimitGate::acquire(std::atomic<uint32_t>& counter, uint32_t limit, const char* what, const char* flag) {
  uint32_t held = counter.load();
  do {
    if (held >= limit)
      fail(Code::ResourceExhausted, std::string(what) + ": " + std::to_string(held) +
                                        " already open, the limit is " + flag + " = " +
                                        std::to_string(limit));
  } while (!counter.compare_exchange_weak(held, held + 1));
  return Slot(&counter);
}

Slot LimitGate::acquire_stream() { return acquire(streams_, limits_.max_streams, "streams", "--max-streams"); }

Slot LimitGate::acquire_session() {
  return acquire(sessions_, limits_.max_sessions, "sessions", "--max-sessions");
}

}  // namespace squall
