// DaemonMetrics: the gauges squalld owns, read from its state at every scrape (a prometheus-cpp
// Collectable next to the calls' metrics of rpc/metrics.h):
//   squall_build_info{version, replica, device, device_type, fft_backend}  1
//   squall_ready                              1 while SERVING, 0 while starting or draining
//   squall_uptime_seconds
//   squall_streams_active, squall_streams_limit           (--max-streams)
//   squall_sessions_active, squall_sessions_limit         (--max-sessions)
//   squall_session_bytes, squall_session_bytes_budget     (--max-session-bytes)
//   squall_device_global_memory_bytes
//   squall_fft_plans, squall_fft_plans_baked_total          (once started)
//   process_resident_memory_bytes             squalld's RSS (/proc/self/statm)
//   and each capability's own gauges (Capability::gauges(), e.g. squall_stored_volume_bytes)
#pragma once

#include <prometheus/collectable.h>
#include <prometheus/metric_family.h>

#include <memory>
#include <vector>

#include "daemon/daemon_state.h"

namespace squall::rpc {

class DaemonMetrics : public prometheus::Collectable {
 public:
  DaemonMetrics(const DaemonState& daemon, const std::vector<std::unique_ptr<Capability>>& capabilities)
      : daemon_(daemon), capabilities_(capabilities) {}
  std::vector<prometheus::MetricFamily> Collect() const override;

 private:
  const DaemonState& daemon_;
  const std::vector<std::unique_ptr<Capability>>& capabilities_;
};

}  // namespace squall::rpc
