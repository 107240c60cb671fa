// The limits of squalld's control group, read from the cgroup file system mounted at `root`: version 2's
// files (memory.max, cpu.max) where they are, else version 1's (memory/memory.limit_in_bytes,
// cpu/cpu.cfs_quota_us over cpu/cpu.cfs_period_us). A container's or a pod's limits are these.
#pragma once

#include <cstdint>
#include <string>

namespace squall {

inline constexpr const char* kCgroupRoot = "/sys/fs/cgroup";

// The memory limit, bytes; 0 when there is none. PoCL reports the host's RAM as a CPU device's global
// memory even in a container limited to less, so memory budgets must look here too.
uint64_t cgroup_memory_limit(const std::string& root = kCgroupRoot);

// The CPU quota, in CPUs: the time the group may run per period over the period (2.5 for cpu.max's
// "250000 100000"); 0 when there is none.
double cgroup_cpu_limit(const std::string& root = kCgroupRoot);

// Worker threads for `cores` cores under a quota of `cpus` CPUs (0: none): the quota rounded up, at least
// 1 and at most `cores`. More threads than that only take turns at being throttled.
unsigned threads_within(double cpus, unsigned cores);

}  // namespace squall
