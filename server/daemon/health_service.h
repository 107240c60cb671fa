// grpc.health.v1.Health served by squalld itself, in place of gRPC's built-in service, which cannot ask
// for a token: with --auth-exempt-health off, Check and Watch need the bearer token the other services
// need. The daemon sets the server's status through it (grpc::HealthCheckServiceInterface), as it did
// through the built-in one: the status "" (the server as a whole) and of any service name set; Check of
// an unknown name is NOT_FOUND, Watch of one SERVICE_UNKNOWN, as the health protocol says.
//
// Three kinds of name: readiness names ("" and each service's, "squall.v1.Ocean"), NOT_SERVING while the
// kernels build, while the daemon drains and while it cannot write its heartbeat (take the replica out of
// rotation: its sessions move); kAdmission, a readiness name that is also NOT_SERVING while the memory
// budget is nearly spent (send new stateless work elsewhere, but leave the sessions where they live: a
// balancer hashing sessions to replicas must not move them because one call is large); and kLiveness,
// SERVING from the moment the daemon listens until shutdown (restart the process only when it stops
// answering, never because it is busy or still building kernels).
#pragma once

#include <grpcpp/health_check_service_interface.h>

#include <atomic>
#include <condition_variable>
#include <map>
#include <mutex>
#include <string>

#include "grpc/health/v1/health.grpc.pb.h"
#include "rpc/serving.h"

namespace squall::rpc {

class HealthService final : public grpc::health::v1::Health::Service, public grpc::HealthCheckServiceInterface {
 public:
  using Response = grpc::health::v1::HealthCheckResponse;

  // exempt: Check and Watch need no token (--auth-exempt-health on: balancers and kubelets probe it).
  HealthService(const ServingState& serving, bool exempt) : serving_(serving), exempt_(exempt) {}

  static constexpr const char* kLiveness = "liveness";
  static constexpr const char* kAdmission = "admission";
  // Watch streams open at once: each holds a server thread, and with health exempt from the token anyone
  // may open them; a balancer or kubelet needs a few. RESOURCE_EXHAUSTED past it.
  static constexpr int kMaxWatches = 64;

  void SetServingStatus(const std::string& service_name, bool serving) override;
  void SetServingStatus(bool serving) override;  // every readiness name's (all but kLiveness)
  // Every readiness name's status `serving`, and kAdmission's `serving && admitting`, in one change: a Watch
  // of kAdmission sees no SERVING in between.
  void SetReadiness(bool serving, bool admitting);
  // NOT_SERVING from now on, whatever is set later, and every Watch ends.
  void Shutdown() override;

  grpc::Status Check(grpc::ServerContext* context, const grpc::health::v1::HealthCheckRequest* request,
                     Response* response) override;
  // Writes the status, then each change, until the client goes or Shutdown(); at most kMaxWatches at once.
  grpc::Status Watch(grpc::ServerContext* context, const grpc::health::v1::HealthCheckRequest* request,
                     grpc::ServerWriter<Response>* writer) override;

 private:
  Response::ServingStatus status_of(const std::string& name) const;  // under mutex_

  const ServingState& serving_;
  const bool exempt_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::map<std::string, bool> serving_by_name_{{"", false}};
  bool shut_down_ = false;
  std::atomic<int> watches_{0};
};

}  // namespace squall::rpc
