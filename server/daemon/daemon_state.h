// What squalld itself holds, for its own Server service and its life cycle: the device runtime, the FFT
// layer, the serving state the capabilities share, and the context their engines are built from.
// Only daemon/ includes this.
#pragma once

#include <algorithm>
#include <memory>
#include <string>

#include "common/cgroup.h"
#include "common/session_registry.h"
#include "fft/fft.h"
#include "rpc/capability.h"
#include "rpc/serving.h"
#include "runtime/runtime.h"

namespace squall::rpc {

// The memory squalld may use: its control group's limit, else the physical memory.
uint64_t usable_memory();

// --max-session-bytes 0 (the default) is half the selected device's global memory, and on a CPU device
// at most half the control group's memory limit; --memory-budget 0 (the default) is 3/4 of usable_memory().
inline Limits with_memory_budgets(Limits limits, const Runtime& runtime) {
  const uint64_t cgroup = cgroup_memory_limit();
  if (limits.max_session_bytes == 0) {
    limits.max_session_bytes = runtime.device_info().global_memory_bytes / 2;
    if (runtime.device_info().type == "cpu" && cgroup != 0)
      limits.max_session_bytes = std::min<uint64_t>(limits.max_session_bytes, cgroup / 2);
  }
  if (limits.memory_budget == 0) limits.memory_budget = usable_memory() / 4 * 3;
  return limits;
}

struct DaemonState {
  DaemonState(const RuntimeOptions& runtime_options, const Limits& limits, std::unique_ptr<StateDir> state_dir,
              const std::string& replica)
      : runtime(runtime_options),
        serving(with_memory_budgets(limits, runtime)),
        sessions(std::move(state_dir), replica) {
    runtime.buffers().attach(&serving.gate());  // idle device buffers count in --memory-budget
    serving.set_sessions(&sessions);            // calls naming a live session go on while draining
  }
  ~DaemonState() { runtime.buffers().attach(nullptr); }  // before the gate goes

  Runtime runtime;
  ServingState serving;
  SessionRegistry sessions;                // every session store's, with the --state-dir
  std::unique_ptr<fft::Fft> fft;           // set during start-up, before SERVING
  std::string fft_selection;               // "flag --fft ...", or the start-up measurement that chose it
  std::unique_ptr<EngineContext> engines;  // set during start-up, after fft
};

}  // namespace squall::rpc
