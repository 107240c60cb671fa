#include "common/cgroup.h"

#include <algorithm>
#include <cmath>
#include <fstream>

namespace squall {
namespace {

// The first two words of the file at `path` (the second empty where there is none); false when it cannot be read.
bool read_words(const std::string& path, std::string& first, std::string& second) {
  std::ifstream in(path);
  first.clear();
  second.clear();
  return bool(in >> first) && ((in >> second), true);
}

// `text`, wholly a finite number; false otherwise.
bool read_number(const std::string& text, double& value) {
  try {
    size_t used = 0;
    value = std::stod(text, &used);
    return used == text.size() && std::isfinite(value);
  } catch (const std::exception&) {
    return false;
  }
}

// The quota over the period, both numbers of microseconds; 0 for no quota ("max", -1) or one unreadable.
double quota_over_period(const std::string& quota, const std::string& period) {
  double q = 0, p = 0;
  return read_number(quota, q) && read_number(period, p) && q > 0 && p > 0 ? q / p : 0;
}

}  // namespace

uint64_t cgroup_memory_limit(const std::string& root) {
  for (const std::string& file : {root + "/memory.max", root + "/memory/memory.limit_in_bytes"}) {
    std::string text, unused;
    double bytes = 0;
    if (!read_words(file, text, unused) || !read_number(text, bytes) || bytes <= 0) continue;  // "max": none
    if (bytes < 0x1p60) return uint64_t(bytes);  // version 1 writes a huge number for "no limit"
  }
  return 0;
}

double cgroup_cpu_limit(const std::string& root) {
  std::string quota, period, unused;
  if (read_words(root + "/cpu.max", quota, period)) return quota_over_period(quota, period);  // "max 100000"
  if (read_words(root + "/cpu/cpu.cfs_quota_us", quota, unused) &&                            // -1: no limit
      read_words(root + "/cpu/cpu.cfs_period_us", period, unused))
    return quota_over_period(quota, period);
  return 0;
}

unsigned threads_within(double cpus, unsigned cores) {
  cores = std::max(cores, 1u);
  if (!(cpus > 0)) return cores;
  return unsigned(std::clamp(std::ceil(cpus), 1.0, double(cores)));
}

}  // namespace squall
