// A capability of squalld (ocean tiles, eWave, clouds, ...): one gRPC service over its own engine. The
// daemon registers each capability's service before it listens, then, once the kernels are built and the
// FFT backend chosen, starts each (builds its engine) before health turns SERVING. A capability knows this
// layer and its own engine, never the daemon.
#pragma once

#include <grpcpp/grpcpp.h>

#include <map>
#include <memory>
#include <string>
#include <typeindex>
#include <vector>

#include "common/limits.h"
#include "common/session_store.h"
#include "fft/fft.h"
#include "runtime/runtime.h"

namespace squall::rpc {

// What a capability's engine is built from: the device, the FFT plans, the limits and the session policy
// (--session-ttl). Lives as long as the daemon.
class EngineContext {
 public:
  EngineContext(Runtime& runtime, fft::Fft& fft, LimitGate& gate, SessionPolicy sessions)
      : runtime(runtime), fft(fft), gate(gate), sessions(std::move(sessions)) {}

  Runtime& runtime;
  fft::Fft& fft;
  LimitGate& gate;
  const SessionPolicy sessions;

  // One engine of type E for the whole daemon, made by `make` for the first capability that asks: the
  // ocean tiles and eWave's ambient ocean share one ocean engine (and its spectrum cache).
  template <typename E, typename Make>
  E& shared(Make&& make) {
    auto& slot = shared_[std::type_index(typeid(E))];
    if (!slot) slot = std::shared_ptr<E>(make());
    return *std::static_pointer_cast<E>(slot);
  }

 private:
  std::map<std::type_index, std::shared_ptr<void>> shared_;
};

// A gauge a capability reports about its own state (squalld's /metrics reads them at every scrape).
struct CapabilityGauge {
  std::string name, help;
  double value = 0;
};

class Capability {
 public:
  virtual ~Capability() = default;
  virtual grpc::Service& service() = 0;
  // Its gRPC service's full name ("squall.v1.Ocean"): its name in grpc.health.v1.
  virtual const char* service_name() const = 0;
  // Builds the engine; called once, after the kernels are built and before health turns SERVING.
  virtual void start(EngineContext& context) = 0;
  // Its gauges now (none by default; none before start()). Called from the metrics endpoint's thread.
  virtual std::vector<CapabilityGauge> gauges() const { return {}; }
  // Ends its sessions idle past --session-ttl now (none by default; nothing before start()). The daemon
  // calls it every second from a thread of its own, so an abandoned session's memory comes back without
  // waiting for the next call to its store.
  virtual void evict_idle() {}
};

}  // namespace squall::rpc
