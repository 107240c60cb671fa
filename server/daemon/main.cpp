// squalld: the squall daemon. See README.md for the flags and the services.
#include <cstdio>
#include <cstdlib>

#include "absl/synchronization/mutex.h"
#include "daemon/daemon.h"

int main(int argc, char** argv) {
  // Abseil's mutexes (gRPC's) check every lock for lock-order cycles in a build without NDEBUG, as
  // Debian's is: a graph update per lock, 0.66% of the two cores of a CPU device at 8 clients. squalld never takes
  // those mutexes itself, so the check only finds gRPC's own cycles, and costs every call.
  absl::SetMutexDeadlockDetectionMode(absl::OnDeadlockCycle::kIgnore);
  squall::rpc::DaemonOptions options;
  bool help = false;
  std::string error;
  if (!squall::rpc::parse_options(argc, argv, &options, &help, &error, std::getenv)) {
    std::fprintf(stderr, "squalld: %s\n%s", error.c_str(), squall::rpc::usage().c_str());
    return squall::rpc::kExitUsage;
  }
  if (help) {
    std::fputs(squall::rpc::usage().c_str(), stdout);
    return 0;
  }
  return squall::rpc::run_daemon(options);
}
