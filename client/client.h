// squall's C++ client library: a channel to squalld (TLS, token, retries) and the contexts of its calls
// (deadline, request id, session routing). The server's own RPCs are methods here (info, health).
// The capabilities' RPCs are called through the client classes that gRPC generates for their services
// (v1::Ocean, v1::EWave, v1::Clouds, v1::Textures), made on this client's channel() with NewStub, and
// each call takes a context() of this client.
// check() turns the call's failed status into the RpcError that the methods here throw.
// client/cloud_cli.cpp calls Clouds.BuildVolume and Clouds.Render in this way.
#pragma once

#include <grpcpp/grpcpp.h>

#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

#include "grpc/health/v1/health.grpc.pb.h"
#include "squall/v1/server.grpc.pb.h"

namespace squall::client {

struct ClientOptions {
  ClientOptions() = default;
  // The common case, `{address, timeout}`: the other members keep their defaults.
  ClientOptions(std::string address, double timeout_seconds, std::string request_id = "")
      : address(std::move(address)), timeout_seconds(timeout_seconds), request_id(std::move(request_id)) {}

  std::string address = "127.0.0.1:50051";  // host:port of squalld
  double timeout_seconds = 30;              // deadline of each call
  std::string request_id;                   // sent as x-request-id; empty: none
  // TLS (any of the three set): the CA that signed squalld's certificate (PEM file; empty: the system's
  // roots), and for mutual TLS this client's certificate chain and private key (PEM files).
  std::string tls_ca, tls_cert, tls_key;
  std::string token;  // sent as "authorization: Bearer <token>" (squalld --auth-tokens); empty: none
  // Attempts of a call answered UNAVAILABLE (squalld starting or draining, a replica gone behind a proxy),
  // with exponential backoff from 0.1 s to 2 s; 1: no retries. gRPC retries only calls the server has not
  // begun to answer, and squalld answers UNAVAILABLE before it touches a session; a step whose reply was
  // lost (a broken connection, a proxy's retry on another replica) is made twice unless its request has a
  // retry_key (EWaveStepRequest), which the caller sets.
  int attempts = 5;
  // A TCP connection of its own. By default, Clients of one address in a process share one connection,
  // which is what one program wants; a load generator wants each of its clients to have its own.
  bool own_connection = false;
};

// A fresh session id to propose when creating a session (x-squall-session on the creating call, so a
// session-affine proxy routes it like the session's later calls): `prefix` and 32 hex digits from the
// system's random device ("" for eWave sessions, "cloud-" for stored volumes).
std::string propose_session_id(const std::string& prefix = "");

// A call that creates a session under `id` (sent as x-squall-session by a context(id)), or closes it.
using SessionCall = std::function<grpc::Status(const std::string& id)>;

// create(id) under id = propose_session_id(prefix), which *id receives. When it ends DEADLINE_EXCEEDED or
// CANCELLED squalld may have made the session all the same, which nothing would then close: close(id) is
// made, best effort (the session's idle TTL ends it otherwise). ALREADY_EXISTS for a drawn id (128 random
// bits) means that an earlier attempt of the call made the session and its answer was lost (gRPC retried
// after a broken connection): that session is closed and create made once more under a fresh id (so such
// a call may take twice its timeout). Returns create's last status.
grpc::Status create_session(const std::string& prefix, const SessionCall& create, const SessionCall& close,
                            std::string* id);

// Whether gRPC target `address` is this machine: localhost, a loopback IP (127.0.0.0/8, ::1; "host:port" or
// "[host]:port", with or without an ipv4:, ipv6: or dns:/// scheme; every one of a list) or a unix socket.
// A token sent without TLS anywhere else can be read on the way.
bool is_loopback_address(const std::string& address);

// ClientOptions that cannot be used (a --tls-* file that is no readable file, a certificate without its key):
// the caller's mistake, found before any call.
struct OptionsError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

class RpcError : public std::runtime_error {
 public:
  RpcError(const std::string& method, const grpc::Status& status);
  grpc::StatusCode code() const { return code_; }

 private:
  grpc::StatusCode code_;
};

// Throws RpcError(method, status) unless the status is OK.
void check(const grpc::Status& status, const std::string& method);

class Client {
 public:
  explicit Client(const ClientOptions& options);

  squall::v1::GetInfoResponse info();
  // The health status of `service` ("" = the whole server): SERVING, NOT_SERVING, ...
  grpc::health::v1::HealthCheckResponse::ServingStatus health(const std::string& service = "");
  // Polls health until SERVING; false when `seconds` pass first (or the server is unreachable).
  bool wait_until_serving(double seconds);

  const std::shared_ptr<grpc::Channel>& channel() const { return channel_; }
  // A context with this client's deadline and request id, for services' own stubs; with `session`, the
  // call names that session (or proposes that id) in x-squall-session, which a proxy routes on.
  // A stream of `calls` messages gets `calls` times the timeout; any deadline is at most 1e9 s away (a farther
  // one overflows the clock's nanoseconds and expires at once).
  std::unique_ptr<grpc::ClientContext> context(const std::string& session = "", double calls = 1) const;
  // A context() of `session` for the call that undoes a creation (create_session's close): it adds at most
  // kUndoSeconds to a call the client gave up on.
  static constexpr double kUndoSeconds = 1;
  std::unique_ptr<grpc::ClientContext> undo_context(const std::string& session) const;

 private:
  ClientOptions options_;
  std::shared_ptr<grpc::Channel> channel_;
};

}  // namespace squall::client
