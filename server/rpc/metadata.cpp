#include "rpc/metadata.h"

#include <algorithm>

#include "common/error.h"

namespace squall::rpc {

std::string metadata_value(const std::multimap<grpc::string_ref, grpc::string_ref>& metadata, const char* key) {
  auto it = metadata.find(key);
  if (it == metadata.end()) return "";
  return std::string(it->second.data(), std::min(it->second.size(), kMaxMetadataValue));
}

std::string session_routing_key(const std::multimap<grpc::string_ref, grpc::string_ref>& metadata) {
  return metadata_value(metadata, kSessionKey);
}

std::string proposed_session(const grpc::ServerContext& context) {
  // A proxy may hash on one value and squalld take another: a creating call names its session once.
  if (const size_t given = context.client_metadata().count(kSessionKey); given > 1)
    fail(Code::InvalidArgument, std::string("metadata ") + kSessionKey + " is given " + std::to_string(given) +
                                    " times; a call that creates a session proposes one id");
  return metadata_value(context.client_metadata(), kSessionKey);
}

void announce_session(grpc::ServerContext& context, const std::string& session_id) {
  context.AddInitialMetadata(kSessionKey, session_id);
}

std::string client_address(const grpc::ServerContext& context) { return client_of_peer(context.peer()); }

std::string client_of_peer(const std::string& peer) {
  const size_t colon = peer.rfind(':');
  const bool has_port = colon != std::string::npos && colon > peer.find(':') && peer.back() != ']';
  return has_port ? peer.substr(0, colon) : peer;
}

}  // namespace squall::rpc
