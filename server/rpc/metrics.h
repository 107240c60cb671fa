// Metrics: squalld's Prometheus metrics that calls produce, recorded by the request interceptor
// (request_log.h) for every call of every service:
//   squall_requests_total{service, method, code}          calls by final status
//   squall_request_duration_seconds{service, method}      latency histogram, 1 ms .. 100 s
//   squall_messages_sent_total{service, method}           response messages (stream frames included)
//   squall_sent_bytes_total{service, method}              their serialized size
// The daemon adds the gauges it owns (streams, sessions, memory, build info) as a Collectable of its own
// on the same exposer (daemon/daemon_metrics.h).
#pragma once

#include <prometheus/counter.h>
#include <prometheus/family.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>

#include <memory>
#include <string>

namespace squall::rpc {

class Metrics {
 public:
  Metrics();

  // `method` is gRPC's "/package.Service/Method"; `code` a status name ("OK", "NOT_FOUND", ...).
  void record_call(const std::string& method, const std::string& code, double seconds);
  void record_sent(const std::string& method, size_t bytes);

  std::shared_ptr<prometheus::Registry> registry() const { return registry_; }

 private:
  std::shared_ptr<prometheus::Registry> registry_;
  prometheus::Family<prometheus::Counter>& requests_;
  prometheus::Family<prometheus::Histogram>& durations_;
  prometheus::Family<prometheus::Counter>& messages_;
  prometheus::Family<prometheus::Counter>& bytes_;
};

// {"service", "method"} labels of gRPC's "/package.Service/Method" ("squall.v1.Ocean", "GetTile").
prometheus::Labels method_labels(const std::string& method);

}  // namespace squall::rpc
