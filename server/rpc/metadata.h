// Request metadata squall reads and writes, in one place. Keys are lowercase ASCII, as HTTP/2 wants.
//   x-request-id       a client's id for one call, shown in squalld's log (at most 128 bytes kept)
//   x-squall-session   the session a call belongs to: sent back by calls that create one; a client
//                      that sends it on the session's later calls lets a proxy in front of several
//                      squalld replicas route them to the replica holding the session (hash on it).
//                      On a call that creates a session it proposes the new session's id, so that the
//                      creating call is routed like the later ones
//   x-squall-replica   sent back on every call: the replica that answered (squalld --replica-id), in
//                      the initial metadata, or for a call that fails at once in the trailing metadata
#pragma once

#include <grpcpp/grpcpp.h>

#include <string>

namespace squall::rpc {

inline constexpr const char* kRequestIdKey = "x-request-id";
inline constexpr const char* kSessionKey = "x-squall-session";
inline constexpr const char* kReplicaKey = "x-squall-replica";
inline constexpr size_t kMaxMetadataValue = 128;

// A value of the client's metadata, cut to kMaxMetadataValue bytes; empty when absent.
std::string metadata_value(const std::multimap<grpc::string_ref, grpc::string_ref>& metadata, const char* key);

// The session a call names in x-squall-session (empty when none): the key a session-affine proxy routes
// on, shown in the request log.
std::string session_routing_key(const std::multimap<grpc::string_ref, grpc::string_ref>& metadata);

// The id a session-creating call proposes in x-squall-session (empty: squalld picks one); INVALID_ARGUMENT
// when the call gives the key more than once.
std::string proposed_session(const grpc::ServerContext& context);

// Who is calling, for per-client limits: the peer's address without its port ("ipv4:127.0.0.1",
// "ipv6:[::1]"). Behind a proxy every client is the proxy: limit per client there.
std::string client_address(const grpc::ServerContext& context);
// The same from gRPC's peer string: "ipv4:127.0.0.1:5000" -> "ipv4:127.0.0.1", "ipv6:[::1]:5000" -> "ipv6:[::1]";
// one with no port ("unix:/run/squalld.sock") is returned as it is.
std::string client_of_peer(const std::string& peer);

// Tells the client (and any proxy) which session this call created: x-squall-session in the initial
// metadata. Call before the first message is written.
void announce_session(grpc::ServerContext& context, const std::string& session_id);

}  // namespace squall::rpc
