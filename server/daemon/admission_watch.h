// AdmissionWatch: while squalld serves, a thread that four times a second turns gRPC health NOT_SERVING
// when the memory budget is nearly spent (at least kFullShare of --memory-budget reserved: new work would
// be refused RESOURCE_EXHAUSTED, so balancers should send it elsewhere) and SERVING again once the
// reservations fall below kFreeShare (the gap keeps it from flapping). Stopped (and joined) before the
// daemon drains, which turns health NOT_SERVING for good.
#pragma once

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include <grpcpp/health_check_service_interface.h>

#include "common/limits.h"

namespace squall::rpc {

class AdmissionWatch {
 public:
  static constexpr double kFullShare = 0.9, kFreeShare = 0.8;

  AdmissionWatch(const LimitGate& gate, grpc::HealthCheckServiceInterface& health);
  ~AdmissionWatch() { stop(); }
  void stop();

 private:
  void run();

  const LimitGate& gate_;
  grpc::HealthCheckServiceInterface& health_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace squall::rpc
