#include "rpc/metadata.h"

#include <algorithm>

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
