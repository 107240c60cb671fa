// What squalld itself holds, for its own Server service and its life cycle: the device runtime, the FFT
// layer, the serving state the capabilities share, and the context their engines are built from.
// Only daemon/ includes this.
#pragma once

#include <memory>
#include <string>

#include "fft/fft.h"
#include "rpc/capability.h"
#include "rpc/serving.h"
#include "runtime/runtime.h"

namespace squall::rpc {

// --max-session-bytes 0 (the default) is half the selected device's global memory.
inline Limits with_session_budget(Limits limits, const Runtime& runtime) {
  if (limits.max_session_bytes == 0) limits.max_session_bytes = runtime.device_info().global_memory_bytes / 2;
  return limits;
}

struct DaemonState {
  DaemonState(const RuntimeOptions& runtime_options, const Limits& limits)
      : runtime(runtime_options), serving(with_session_budget(limits, runtime)) {}

  Runtime runtime;
  ServingState serving;
  std::unique_ptr<fft::Fft> fft;           // set during start-up, before SERVING
  std::string fft_selection;               // "flag --fft ...", or the start-up measurement that chose it
  std::unique_ptr<EngineContext> engines;  // set during start-up, after fft
};

}  // namespace squall::rpc
