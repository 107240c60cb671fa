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
    return std::make_unique<OceanEngine>(context.runtime, context.fft, limits,
                                         cache_bound(limits.memory_budget, OceanEngine::kDefaultMaxCachedBytes),
                                         &context.gate);
  });
}

}  // namespace squall::ocean
