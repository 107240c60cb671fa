#include "rpc/metrics.h"

namespace squall::rpc {
namespace {

// Latency buckets, seconds: 1 ms to 100 s in steps of about x2.5 (a tile is milliseconds, a cloud
// render or a long stream seconds to minutes).
const prometheus::Histogram::BucketBoundaries kDurationBuckets = {0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25,
                                                                  0.5,   1,      2.5,   5,    10,    25,   50,  100};

}  // namespace

prometheus::Labels method_labels(const std::string& method) {
  const size_t slash = method.rfind('/');
  if (method.empty() || method[0] != '/' || slash == 0 || slash == std::string::npos)
    return {{"service", "unknown"}, {"method", method}};
  return {{"service", method.substr(1, slash - 1)}, {"method", method.substr(slash + 1)}};
}

Metrics::Metrics()
    : registry_(std::make_shared<prometheus::Registry>()),
      requests_(prometheus::BuildCounter()
                    .Name("squall_requests_total")
                    .Help("Calls answered, by service, method and final gRPC status code")
                    .Register(*registry_)),
      durations_(prometheus::BuildHistogram()
                     .Name("squall_request_duration_seconds")
                     .Help("Time from a call's start to its status, by service and method")
                     .Register(*registry_)),
      messages_(prometheus::BuildCounter()
                    .Name("squall_messages_sent_total")
                    .Help("Response messages sent (every frame or chunk of a stream), by service and method")
                    .Register(*registry_)),
      bytes_(prometheus::BuildCounter()
                 .Name("squall_sent_bytes_total")
                 .Help("Serialized bytes of the response messages sent, by service and method")
                 .Register(*registry_)) {}

void Metrics::record_call(const std::string& method, const std::string& code, double seconds) {
  prometheus::Labels labels = method_labels(method);
  durations_.Add(labels, kDurationBuckets).Observe(seconds);
  labels.emplace("code", code);
  requests_.Add(labels).Increment();
}

void Metrics::record_sent(const std::string& method, size_t bytes) {
  const prometheus::Labels labels = method_labels(method);
  messages_.Add(labels).Increment();
  bytes_.Add(labels).Increment(double(bytes));
}

}  // namespace squall::rpc
