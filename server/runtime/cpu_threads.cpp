#include "runtime/cpu_threads.h"

#include <sched.h>

#include <cstdlib>
#include <thread>

#include "common/log.h"

namespace squall {

unsigned fit_cpu_threads_to_quota(const std::string& cgroup_root) {
  if (const char* set = std::getenv("POCL_MAX_PTHREAD_COUNT"); set && *set) return 0;
  cpu_set_t mask;
  const unsigned cores =
      sched_getaffinity(0, sizeof mask, &mask) == 0 ? unsigned(CPU_COUNT(&mask)) : std::thread::hardware_concurrency();
  const double cpus = cgroup_cpu_limit(cgroup_root);
  const unsigned threads = threads_within(cpus, cores);
  if (threads >= cores) return 0;
  setenv("POCL_MAX_PTHREAD_COUNT", std::to_string(threads).c_str(), 1);
  log(LogLevel::Info, "the control group's CPU quota is ", cpus, " of ", cores,
      " cores: POCL_MAX_PTHREAD_COUNT=", threads);
  return threads;
}

}  // namespace squall
