// Request metadata squall reads and writes, in one place. Keys are lowercase ASCII, as HTTP/2 wants.
//   x-request-id       a client's id for one call, shown in squalld's log (at most 128 bytes kept)
//   x-squall-session   the session a call belongs to: sent back by calls that create one, so that a
//                      proxy in front of several squalld replicas can route a session's calls to the
//                      replica holding it (hash on this header), and sent by clients on later calls
#pragma once

#include <grpcpp/grpcpp.h>

#include <string>

namespace squall::rpc {

inline constexpr const char* kRequestIdKey = "x-request-id";
inline constexpr const char* kSessionKey = "x-squall-session";
inline constexpr size_t kMaxMetadataValue = 128;

// A value of the client's metadata, cut to kMaxMetadataValue bytes; empty when absent.
std::string metadata_value(const std::multimap<grpc::string_ref, grpc::string_ref>& metadata, const char* key);

// The client's x-squall-session, else `request_id` (the id the request itself names): the key a
// session-affine proxy routes on.
std::string session_routing_key(const grpc::ServerContext& context, const std::string& request_id = "");

// Tells the client (and any proxy) which session this call created: x-squall-session in the initial
// metadata. Call before the first message is written.
void announce_session(grpc::ServerContext& context, const std::string& session_id);

}  // namespace squall::rpc
