#include "rpc/metadata.h"

#include <algorithm>

namespace squall::rpc {

std::string metadata_value(const std::multimap<grpc::string_ref, grpc::string_ref>& metadata, const char* key) {
  auto it = metadata.find(key);
  if (it == metadata.end()) return "";
  return std::string(it->second.data(), std::min(it->second.size(), kMaxMetadataValue));
}

std::string session_routing_key(const grpc::ServerContext& context, const std::string& request_id) {
  std::string key = metadata_value(context.client_metadata(), kSessionKey);
  return key.empty() ? request_id : key;
}

void announce_session(grpc::ServerContext& context, const std::string& session_id) {
  context.AddInitialMetadata(kSessionKey, session_id);
}

}  // namespace squall::rpc
