// A capability's gRPC service in the test process, on a free loopback port: started on the binary's
// runtime and VkFFT plans like squalld starts it, with a session clock the test moves (no sleeps against
// TTLs) and its serving state at hand.
#pragma once

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <string>

#include "rpc/capability.h"
#include "rpc/serving.h"
#include "support/test_runtime.h"

namespace squall::test {

template <typename Service>
class InProcess {
 public:
  explicit InProcess(Limits limits = {}, std::chrono::milliseconds session_ttl = std::chrono::minutes(10))
      : serving_(limits),
        engines_(runtime(), fft(), serving_.gate(), SessionPolicy{session_ttl, [this] { return now(); }, &sessions_}),
        service_(serving_) {
    serving_.set_sessions(&sessions_);
    service_.start(engines_);
    serving_.set_phase(rpc::ServingState::Phase::Serving);
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(&service_);
    server_ = builder.BuildAndStart();
  }
  ~InProcess() { server_->Shutdown(); }

  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  std::shared_ptr<grpc::Channel> channel() const {
    return grpc::CreateChannel("127.0.0.1:" + std::to_string(port_), grpc::InsecureChannelCredentials());
  }
  void advance(std::chrono::milliseconds dt) { offset_ms_ += dt.count(); }
  rpc::ServingState& serving() { return serving_; }

 private:
  std::chrono::steady_clock::time_point now() const {
    return std::chrono::steady_clock::time_point{} + std::chrono::milliseconds(offset_ms_.load());
  }

  std::atomic<int64_t> offset_ms_{0};
  SessionRegistry sessions_;  // no state directory
  rpc::ServingState serving_;
  rpc::EngineContext engines_;
  Service service_;
  int port_ = 0;
  std::unique_ptr<grpc::Server> server_;
};

}  // namespace squall::test
