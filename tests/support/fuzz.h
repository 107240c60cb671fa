// libFuzzer scaffolding for the request-validation harnesses (tests/<capability>/<capability>_fuzz.cpp).
// An input is one request to a service: its first byte picks one of the service's checks (modulo their
// number), the rest are that request's protobuf bytes. A check converts and validates the request the
// way the service does before any device work. It may throw squall::Error: a refusal with a clear code
// (its message must stay short: client strings are cut). Anything else, an exception of another type, a
// crash, a sanitizer report, a hang, is a finding.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include <google/protobuf/stubs/logging.h>

#include "common/error.h"
#include "common/limits.h"

namespace squall::test {

// The longest error message a request may provoke, bytes.
inline constexpr size_t kMaxErrorMessage = 4096;

using RequestCheck = std::function<void(const std::string& request_bytes)>;

inline int fuzz_requests(const uint8_t* data, size_t size, const std::vector<RequestCheck>& checks) {
  static const bool quiet = (google::protobuf::SetLogHandler(nullptr), true);  // no line per invalid UTF-8
  (void)quiet;
  if (size == 0) return 0;
  const std::string bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    checks[data[0] % checks.size()](bytes);
  } catch (const Error& e) {
    if (std::strlen(e.what()) > kMaxErrorMessage) {
      std::fprintf(stderr, "an error message of %zu bytes: %.200s...\n", std::strlen(e.what()), e.what());
      std::abort();
    }
  }
  return 0;
}

// The limits of a squalld started with its default flags.
inline const LimitGate& default_gate() {
  static const LimitGate gate{Limits{}};
  return gate;
}

// Parses `bytes` as Message; false (the input is skipped) when they are not one.
template <typename Message>
bool parse(const std::string& bytes, Message* message) {
  return message->ParseFromString(bytes);
}

}  // namespace squall::test
