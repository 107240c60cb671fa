#include "client/client.h"

#include <arpa/inet.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <random>
#include <thread>
#include <tuple>

#include "common/error.h"
#include "common/regular_file.h"
#include "server/common/status_names.h"

namespace squall::client {

void check(const grpc::Status& status, const std::string& method) {
  if (!status.ok()) throw RpcError(method, status);
}

RpcError::RpcError(const std::string& method, const grpc::Status& status)
    : std::runtime_error(method + ": " + status_code_name(status.error_code()) + ": " + status.error_message()),
      code_(status.error_code()) {}

namespace {

std::string read_file(const std::string& path, const char* flag) {
  const std::string name = std::string(flag) + " " + path;
  try {
    if (std::optional<std::string> bytes = read_regular_file(path, name)) return *bytes;
  } catch (const Error&) {  // a FIFO, a directory, a read error: said the same way
  }
  throw OptionsError(name + ": cannot read");
}

std::shared_ptr<grpc::ChannelCredentials> credentials(const ClientOptions& o) {
  if (o.tls_ca.empty() && o.tls_cert.empty() && o.tls_key.empty()) return grpc::InsecureChannelCredentials();
  grpc::SslCredentialsOptions ssl;  // each file named read first, then the pair checked
  if (!o.tls_ca.empty()) ssl.pem_root_certs = read_file(o.tls_ca, "--tls-ca");
  if (!o.tls_cert.empty()) ssl.pem_cert_chain = read_file(o.tls_cert, "--tls-cert");
  if (!o.tls_key.empty()) ssl.pem_private_key = read_file(o.tls_key, "--tls-key");
  if (o.tls_cert.empty() != o.tls_key.empty()) throw OptionsError("--tls-cert and --tls-key go together");
  // gRPC takes any bytes here and fails every call later ("empty address list"): a file must hold PEM blocks.
  for (const auto& [flag, path, pem] : {std::tuple{"--tls-ca", &o.tls_ca, &ssl.pem_root_certs},
                                        {"--tls-cert", &o.tls_cert, &ssl.pem_cert_chain},
                                        {"--tls-key", &o.tls_key, &ssl.pem_private_key}})
    if (!path->empty() && pem->find("-----BEGIN ") == std::string::npos)
      throw OptionsError(std::string(flag) + " " + *path + ": no PEM block (-----BEGIN ...) in the file");
  return grpc::SslCredentials(ssl);
}

// gRPC's service config: every squall service retries UNAVAILABLE (see ClientOptions::attempts).
std::string retry_config(int attempts) {
  std::string names;
  for (const char* service : {"Server", "Ocean", "EWave", "Clouds", "Textures"})
    names += std::string(names.empty() ? "" : ",") + "{\"service\":\"squall.v1." + service + "\"}";
  // An eWave Run is never retried (the most specific name wins): its steps carry no retry key, and a
  // connection lost after a step but before its frame would replay that step.
  return "{\"methodConfig\":[{\"name\":[" + names + "],\"retryPolicy\":{\"maxAttempts\":" + std::to_string(attempts) +
         ",\"initialBackoff\":\"0.1s\",\"maxBackoff\":\"2s\",\"backoffMultiplier\":2,"
         "\"retryableStatusCodes\":[\"UNAVAILABLE\"]}},"
         "{\"name\":[{\"service\":\"squall.v1.EWave\",\"method\":\"Run\"}]}]}";
}

}  // namespace

bool is_loopback_address(const std::string& address) {
  std::string target = address;
  for (const char* scheme : {"dns:///", "ipv4:", "ipv6:"})
    if (target.rfind(scheme, 0) == 0) target.erase(0, std::string(scheme).size());
  if (target.rfind("unix:", 0) == 0 || target.rfind("unix-abstract:", 0) == 0) return true;
  if (const size_t comma = target.find(','); comma != std::string::npos)  // a list: every address
    return is_loopback_address(target.substr(0, comma)) && is_loopback_address(target.substr(comma + 1));
  std::string host = target;
  if (!target.empty() && target[0] == '[' && target.find(']') != std::string::npos)
    host = target.substr(1, target.find(']') - 1);
  else if (std::count(target.begin(), target.end(), ':') == 1)
    host = target.substr(0, target.find(':'));
  if (host == "localhost") return true;
  in_addr v4{};
  in6_addr v6{};
  if (inet_pton(AF_INET, host.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  return inet_pton(AF_INET6, host.c_str(), &v6) == 1 && IN6_IS_ADDR_LOOPBACK(&v6);
}

std::string propose_session_id(const std::string& prefix) {
  std::random_device device;
  std::string id = prefix;
  for (int word = 0; word < 4; ++word) {
    char hex[9];
    std::snprintf(hex, sizeof(hex), "%08x", static_cast<unsigned>(device()));
    id += hex;
  }
  return id;
}

grpc::Status create_session(const std::string& prefix, const SessionCall& create, const SessionCall& close,
                            std::string* id) {
  grpc::Status status;
  for (int attempt = 0; attempt < 2; ++attempt) {
    *id = propose_session_id(prefix);
    status = create(*id);
    const grpc::StatusCode code = status.error_code();
    if (code == grpc::StatusCode::DEADLINE_EXCEEDED || code == grpc::StatusCode::CANCELLED ||
        code == grpc::StatusCode::ALREADY_EXISTS)
      close(*id);  // its status: the session was made or not, and either way nothing more can be done
    if (code != grpc::StatusCode::ALREADY_EXISTS) break;
  }
  return status;
}

Client::Client(const ClientOptions& options) : options_(options) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(-1);  // the server enforces its own limit
  args.SetMaxSendMessageSize(-1);
  if (options.attempts > 1) args.SetServiceConfigJSON(retry_config(std::min(options.attempts, 5)));
  if (options.own_connection) args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  channel_ = grpc::CreateCustomChannel(options.address, credentials(options), args);
}

std::unique_ptr<grpc::ClientContext> Client::context(const std::string& session, double calls) const {
  auto ctx = std::make_unique<grpc::ClientContext>();
  const double seconds = std::min(options_.timeout_seconds * std::max(calls, 1.0), 1e9);
  ctx->set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(std::llround(seconds * 1000)));
  if (!options_.request_id.empty()) ctx->AddMetadata("x-request-id", options_.request_id);
  if (!options_.token.empty()) ctx->AddMetadata("authorization", "Bearer " + options_.token);
  if (!session.empty()) ctx->AddMetadata("x-squall-session", session);
  return ctx;
}

std::unique_ptr<grpc::ClientContext> Client::undo_context(const std::string& session) const {
  auto ctx = context(session);
  ctx->set_deadline(std::min(ctx->deadline(), std::chrono::system_clock::now() +
                                                  std::chrono::milliseconds(std::llround(kUndoSeconds * 1000))));
  return ctx;
}

squall::v1::GetInfoResponse Client::info() {
  auto stub = squall::v1::Server::NewStub(channel_);
  squall::v1::GetInfoRequest request;  // the request id goes as x-request-id, as on every call (no 128-byte cap)
  squall::v1::GetInfoResponse response;
  auto ctx = context();
  grpc::Status status = stub->GetInfo(ctx.get(), request, &response);
  check(status, "GetInfo");
  return response;
}

grpc::health::v1::HealthCheckResponse::ServingStatus Client::health(const std::string& service) {
  auto stub = grpc::health::v1::Health::NewStub(channel_);
  grpc::health::v1::HealthCheckRequest request;
  request.set_service(service);
  grpc::health::v1::HealthCheckResponse response;
  auto ctx = context();
  grpc::Status status = stub->Check(ctx.get(), request, &response);
  check(status, "Health.Check");
  return response.status();
}

bool Client::wait_until_serving(double seconds) {
  auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(static_cast<long long>(seconds * 1000));
  while (std::chrono::steady_clock::now() < end) {
    try {
      if (health() == grpc::health::v1::HealthCheckResponse::SERVING) return true;
    } catch (const RpcError&) {
      // not listening yet
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return false;
}

}  // namespace squall::client
