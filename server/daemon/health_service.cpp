#include "daemon/health_service.h"

#include <chrono>

#include "rpc/status.h"

namespace squall::rpc {

void HealthService::SetServingStatus(const std::string& service_name, bool serving) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    serving_by_name_[service_name] = serving && !shut_down_;
  }
  changed_.notify_all();
}

void HealthService::SetServingStatus(bool serving) { SetReadiness(serving, true); }

void HealthService::SetReadiness(bool serving, bool admitting) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto& [name, value] : serving_by_name_)
      if (name != kLiveness) value = serving && (admitting || name != kAdmission) && !shut_down_;
  }
  changed_.notify_all();
}

void HealthService::Shutdown() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    shut_down_ = true;
    for (auto& [name, value] : serving_by_name_) value = false;
  }
  changed_.notify_all();
}

HealthService::Response::ServingStatus HealthService::status_of(const std::string& name) const {
  auto it = serving_by_name_.find(name);
  if (it == serving_by_name_.end()) return Response::SERVICE_UNKNOWN;
  return it->second ? Response::SERVING : Response::NOT_SERVING;
}

grpc::Status HealthService::Check(grpc::ServerContext* context, const grpc::health::v1::HealthCheckRequest* request,
                                  Response* response) {
  return guarded([&] {
    if (!exempt_) serving_.require_token(*context);
    std::lock_guard<std::mutex> lock(mutex_);
    const Response::ServingStatus status = status_of(request->service());
    if (status == Response::SERVICE_UNKNOWN)
      fail(Code::NotFound, "no health status for service \"" + request->service().substr(0, 128) + "\"");
    response->set_status(status);
    return grpc::Status::OK;
  });
}

grpc::Status HealthService::Watch(grpc::ServerContext* context, const grpc::health::v1::HealthCheckRequest* request,
                                  grpc::ServerWriter<Response>* writer) {
  return guarded([&] {
    if (!exempt_) serving_.require_token(*context);
    int open = watches_.load();
    do {  // counted only when there is room: a refused Watch never holds a place
      if (open >= kMaxWatches)
        fail(Code::ResourceExhausted, "health Watch: " + std::to_string(kMaxWatches) +
                                          " streams are open, the most squalld keeps; poll with Check instead");
    } while (!watches_.compare_exchange_weak(open, open + 1));
    struct Held {
      std::atomic<int>& count;
      ~Held() { --count; }
    } held{watches_};
    std::unique_lock<std::mutex> lock(mutex_);
    Response::ServingStatus sent = Response::UNKNOWN;
    while (!context->IsCancelled()) {
      const Response::ServingStatus now = status_of(request->service());
      if (now != sent) {
        Response response;
        response.set_status(now);
        lock.unlock();
        if (!writer->Write(response)) return grpc::Status::OK;  // the client went
        lock.lock();
        sent = now;
      }
      if (shut_down_) return grpc::Status::OK;
      changed_.wait_for(lock, std::chrono::milliseconds(200));  // and look at IsCancelled again
    }
    return grpc::Status::CANCELLED;
  });
}

}  // namespace squall::rpc
