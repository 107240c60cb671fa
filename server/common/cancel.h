// squall::Cancellation: whether whoever asked for a piece of long work still wants it (the client went
// away, its deadline passed, squalld is shutting down). Long work asks between slices and stops with
// Error(Code::Cancelled), so a cancelled call frees the device and the cores within one slice. The
// engines stay free of gRPC: the RPC layer makes one from its ServerContext.
#pragma once

#include <functional>
#include <string>
#include <utility>

#include "common/error.h"

namespace squall {

class Cancellation {
 public:
  Cancellation() = default;  // never cancelled
  explicit Cancellation(std::function<bool()> requested) : requested_(std::move(requested)) {}

  bool requested() const { return requested_ && requested_(); }
  bool can_be_requested() const { return bool(requested_); }  // false for the default, never cancelled

  // Throws Error(Cancelled) "<what> cancelled ..." once requested().
  void check(const std::string& what) const {
    if (requested()) stopped(what);
  }
  // The same, for work that saw requested() earlier (in a worker thread) and stopped then.
  [[noreturn]] static void stopped(const std::string& what) {
    fail(Code::Cancelled, what + " cancelled (client gone, deadline passed or squalld shutting down)");
  }

 private:
  std::function<bool()> requested_;
};

}  // namespace squall
