// The daemon's one ocean engine (and its spectrum cache), made by the first capability that starts:
// the ocean tiles, and eWave's ambient and initial oceans, share it.
#pragma once

#include <memory>

#include "ocean/ocean_engine.h"
#include "rpc/capability.h"
#include "runtime/device_cache.h"

namespace squall::ocean {

inline OceanEngine& shared_engine(::squall::rpc::EngineContext& context) {
  return context.shared<OceanEngine>([&] {
    const Limits& limits = context.gate.limits();
    const size_t cached = cache_bound(limits.memory_budget, context.runtime.device_info().global_memory_bytes,
                                      OceanEngine::kDefaultMaxCachedBytes);
    return std::make_unique<OceanEngine>(context.runtime, context.fft, limits, cached, &context.gate);
  });
}

}  // namespace squall::ocean
