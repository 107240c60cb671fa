// What every service of squalld shares: the device runtime, the FFT layer and the limit gate.
// Built once at start-up; `ready` turns true when every kernel is compiled.
#pragma once

#include <atomic>
#include <chrono>
#include <memory>
#include <string>

#include "common/error.h"
#include "common/limits.h"
#include "clouds/cloud_engine.h"
#include "fft/fft.h"
#include "ewave/ewave_engine.h"
#include "ocean/ocean_engine.h"
#include "runtime/runtime.h"

namespace squall::rpc {

struct Engines {
  Engines(const RuntimeOptions& runtime_options, const Limits& limits)
      : runtime(runtime_options), gate(limits) {}

  Runtime runtime;
  LimitGate gate;
  std::unique_ptr<fft::Fft> fft;  // set during start-up, before ready
  std::string fft_selection;      // "flag", or the start-up measurement that chose the backend
  std::unique_ptr<ocean::OceanEngine> ocean;  // set during start-up, after fft
  std::unique_ptr<ewave::EWaveEngine> ewave;  // set during start-up, after fft
  std::unique_ptr<clouds::CloudEngine> clouds;  // set during start-up
  std::atomic<bool> ready{false};
  const std::chrono::steady_clock::time_point started = std::chrono::steady_clock::now();

  // Engines' request paths call this first: UNAVAILABLE while kernels are still being built.
  void require_ready() const {
    if (!ready) fail(Code::Unavailable, "squalld is still building its kernels; retry when health is SERVING");
  }
};

}  // namespace squall::rpc
