// squalld's life: select the device, listen (health NOT_SERVING), build every kernel and pick the FFT
// backend, turn SERVING, then on SIGTERM or SIGINT drain (NOT_SERVING, no new calls, running calls get
// --grace-period seconds before they are cancelled) and exit 0.
#pragma once

#include "daemon/options.h"

namespace squall::rpc {

// Exit codes of squalld.
enum ExitCode {
  kExitOk = 0,
  kExitKernelBuild = 1,  // a kernel program failed to build (its log is printed), or the FFT backend's set-up
  kExitUsage = 2,        // bad flags, or no device matches --device
  kExitListen = 3,       // the address could not be bound
  kExitOverran = 4,      // on SIGTERM, a call outlived --grace-period + --shutdown-bound: the watchdog ended it
  kExitUnsaved = 5,      // on SIGTERM, sessions could not be checkpointed (each logged): they resume elsewhere
                         // from their last checkpoint, what they did since is lost
};

int run_daemon(const DaemonOptions& options);

}  // namespace squall::rpc
