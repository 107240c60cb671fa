#include "daemon/daemon_metrics.h"

#include <unistd.h>

#include <fstream>
#include <map>

namespace squall::rpc {
namespace {

prometheus::MetricFamily counter(const std::string& name, const std::string& help, double value) {
  prometheus::ClientMetric metric;
  metric.counter.value = value;
  return {name, help, prometheus::MetricType::Counter, {metric}};
}

prometheus::MetricFamily gauge(const std::string& name, const std::string& help, double value,
                               std::vector<prometheus::ClientMetric::Label> labels = {}) {
  prometheus::ClientMetric metric;
  metric.label = std::move(labels);
  metric.gauge.value = value;
  return {name, help, prometheus::MetricType::Gauge, {metric}};
}

// One counter per call site of device work (WorkKind::site; "other" for work of no kind).
prometheus::MetricFamily counter_by_site(const std::string& name, const std::string& help,
                                         const std::map<std::string, QueueSlots::SiteTimes>& sites,
                                         double (*value)(const QueueSlots::SiteTimes&)) {
  prometheus::MetricFamily family{name, help, prometheus::MetricType::Counter, {}};
  for (const auto& [site, times] : sites) {
    prometheus::ClientMetric metric;
    metric.label = {{"site", site.empty() ? "other" : site}};
    metric.counter.value = value(times);
    family.metric.push_back(std::move(metric));
  }
  return family;
}

double resident_bytes() {
  std::ifstream statm("/proc/self/statm");
  double pages = 0, resident = 0;
  statm >> pages >> resident;
  return resident * double(sysconf(_SC_PAGESIZE));
}

}  // namespace

std::vector<prometheus::MetricFamily> DaemonMetrics::Collect() const {
  const ServingState& serving = daemon_.serving;
  const LimitGate& gate = serving.gate();
  const DeviceInfo& device = daemon_.runtime.device_info();
  const Runtime::DeviceWait wait = daemon_.runtime.device_wait();
  const auto sites = daemon_.runtime.device_site_times();
  const bool ready = serving.phase() == ServingState::Phase::Serving;
  // The FFT backend and the capabilities' engines are made during start-up, which a scrape may come in:
  // read once the daemon has served (the phase is set after them).
  const bool started = serving.phase() != ServingState::Phase::Starting;
  const std::string fft = started ? daemon_.fft->name() : "";
  std::vector<prometheus::MetricFamily> families = {
      gauge("squall_build_info", "squalld's version, replica, device and FFT backend (value 1)", 1,
            {{"version", SQUALL_VERSION},
             {"replica", serving.replica_id()},
             {"device", device.name},
             {"device_type", device.type},
             {"fft_backend", fft}}),
      gauge("squall_ready", "1 while squalld is SERVING, 0 while it starts or drains", ready ? 1 : 0),
      gauge("squall_uptime_seconds", "Seconds since squalld started", serving.uptime_seconds()),
      gauge("squall_streams_active", "Streaming calls in progress", gate.open_streams()),
      gauge("squall_streams_limit", "Streaming calls allowed at once (--max-streams)", gate.limits().max_streams),
      gauge("squall_sessions_active", "Live sessions: eWave sessions and stored cloud volumes", gate.live_sessions()),
      gauge("squall_sessions_limit", "Live sessions allowed (--max-sessions)", gate.limits().max_sessions),
      gauge("squall_session_bytes", "Host and device bytes the live sessions hold", double(gate.session_bytes())),
      gauge("squall_session_bytes_budget", "Bytes the live sessions may hold (--max-session-bytes)",
            double(gate.limits().max_session_bytes)),
      gauge("squall_memory_bytes",
            "Bytes held against the memory budget: sessions, stored volumes, calls' working memory",
            double(gate.memory_bytes())),
      gauge("squall_memory_cached_bytes",
            "Of squall_memory_bytes, what caches keep for the next calls and give back to a call that needs it",
            double(gate.cached_memory_bytes())),
      gauge("squall_memory_budget_bytes", "The memory budget (--memory-budget)", double(gate.limits().memory_budget)),
      gauge("squall_device_global_memory_bytes", "Global memory of the OpenCL device in use",
            double(device.global_memory_bytes)),
      gauge("process_resident_memory_bytes", "Resident memory of the squalld process", resident_bytes()),
      counter("squall_device_lock_acquisitions_total",
              "Times device work took one of the device's queues (--device-queues)", double(wait.acquisitions)),
      counter("squall_device_lock_wait_seconds_total",
              "Seconds device work waited for a free device queue: requests queued behind each other", wait.seconds),
      gauge("squall_device_lock_waiting", "Device work waiting for a free device queue now", double(wait.waiting)),
      counter_by_site("squall_device_queue_leases_total", "Device queue leases ended, by call site", sites,
                      [](const QueueSlots::SiteTimes& t) { return double(t.leases); }),
      counter_by_site("squall_device_queue_wait_seconds_total", "Seconds waited for a free device queue, by call site",
                      sites, [](const QueueSlots::SiteTimes& t) { return t.wait_seconds; }),
      counter_by_site("squall_device_queue_hold_seconds_total",
                      "Seconds a device queue was held (the work's time on the device), by call site", sites,
                      [](const QueueSlots::SiteTimes& t) { return t.hold_seconds; }),
  };
  if (started) {
    families.push_back(gauge("squall_fft_plans", "FFT plans kept, all device queues together (32 a queue at most)",
                             double(daemon_.fft->cached_plans())));
    families.push_back(counter("squall_fft_plans_baked_total",
                               "FFT plans baked: rising while squall_fft_plans stays, calls' sizes cycle past the "
                               "plans kept",
                               double(daemon_.fft->baked())));
  }
  if (started)
    for (const auto& capability : capabilities_)
      for (const CapabilityGauge& g : capability->gauges()) families.push_back(gauge(g.name, g.help, g.value));
  return families;
}

}  // namespace squall::rpc
