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

struct DaemonState {
  DaemonState(const RuntimeOptions& runtime_options, const Limits& limits) : runtime(runtime_options), serving(limits) {}

  Runtime runtime;
  ServingState serving;
  std::unique_ptr<fft::Fft> fft;            // set during start-up, before SERVING
  std::string fft_selection;                // "flag --fft ...", or the start-up measurement that chose it
  std::unique_ptr<EngineContext> engines;   // set during start-up, after fft
};

}  // namespace squall::rpc
