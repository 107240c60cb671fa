#include "rpc/serving.h"

#include <algorithm>
#include <cctype>
#include <string_view>

#include "common/error.h"
#include "rpc/metadata.h"

namespace squall::rpc {

void ServingState::require_serving(const grpc::ServerContext& context) const {
  switch (phase_.load()) {
    case Phase::Serving: return;
    case Phase::Starting:
      fail(Code::Unavailable, "squalld is still building its kernels; retry when health is SERVING");
    case Phase::Draining:
      if (names_live_session(context)) return;
      fail(Code::Unavailable, "squalld is shutting down; retry on another replica");
  }
}

bool ServingState::names_live_session(const grpc::ServerContext& context) const {
  const std::string id = session_routing_key(context.client_metadata());
  return !id.empty() && sessions_ && sessions_->holds(id);
}

namespace {

// Equal, in a time that depends on the longer length only, not on where the first difference is.
bool same_in_constant_time(std::string_view a, std::string_view b) {
  unsigned diff = a.size() != b.size();
  for (size_t i = 0; i < std::max(a.size(), b.size()); ++i)
    diff |= unsigned(i < a.size() ? a[i] : 0) ^ unsigned(i < b.size() ? b[i] : 0);
  return diff == 0;
}

}  // namespace

void ServingState::require_token(const grpc::ServerContext& context) const {
  if (!token_accepted(context))
    fail(Code::Unauthenticated, "a valid bearer token is required (authorization: Bearer ...)");
}

bool ServingState::token_accepted(const grpc::ServerContext& context) const {
  std::shared_ptr<const std::vector<std::string>> tokens;
  {
    std::lock_guard<std::mutex> lock(tokens_mutex_);
    tokens = tokens_;
  }
  if (tokens->empty()) return true;
  constexpr std::string_view kBearer = "bearer ";  // the scheme's case does not matter (RFC 7235 sec. 2.1)
  auto is_bearer = [&](std::string_view value) {
    if (value.size() < kBearer.size()) return false;
    for (size_t i = 0; i < kBearer.size(); ++i)
      if (std::tolower(static_cast<unsigned char>(value[i])) != kBearer[i]) return false;
    return true;
  };
  bool accepted = false;
  for (const auto& [key, ref] : context.client_metadata()) {
    std::string_view value(ref.data(), ref.size());
    if (key != "authorization" || !is_bearer(value)) continue;
    std::string_view token = value.substr(kBearer.size());
    for (const auto& t : *tokens) accepted |= same_in_constant_time(token, t);  // every token, always
  }
  return accepted;
}

}  // namespace squall::rpc
