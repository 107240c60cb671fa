// The daemon's one eWave engine (its sessions), made by the first capability that starts: the eWave
// service steps its sessions, the textures service reads their surface currents.
#pragma once

#include <memory>

#include "ewave/ewave_engine.h"
#include "ocean/shared_engine.h"
#include "rpc/capability.h"

namespace squall::ewave {

inline EWaveEngine& shared_engine(::squall::rpc::EngineContext& context) {
  return context.shared<EWaveEngine>([&] {
    EWaveEngineOptions options;
    options.sessions = context.sessions;
    // ambient_ocean / initial_ocean of eWave sessions, evaluated by the daemon's one ocean engine
    options.ocean = &ocean::shared_engine(context);
    return std::make_unique<EWaveEngine>(context.runtime, context.fft, context.gate, options);
  });
}

}  // namespace squall::ewave
