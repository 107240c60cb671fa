// squalld: the squall daemon. See README.md for the flags and the services.
#include <cstdio>
#include <cstdlib>

#include "daemon/daemon.h"

int main(int argc, char** argv) {
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
