// The CPU device's worker threads fitted to the CPU time a container or pod may use.
#pragma once

#include <string>

#include "common/cgroup.h"

namespace squall {

// PoCL starts a worker thread per core this process may run on, however few CPUs its control group's quota
// gives it: on a 64-core node under a quota of 4 CPUs, 64 threads take turns at being throttled. Sets
// POCL_MAX_PTHREAD_COUNT (unless the environment already does) to the quota rounded up where that is fewer
// than the cores; the CPU device's compute units, and so FFTW's threads, follow. Call it before any other
// OpenCL call, while the process has one thread. Returns the count set, 0 when none was.
unsigned fit_cpu_threads_to_quota(const std::string& cgroup_root = kCgroupRoot);

}  // namespace squall
