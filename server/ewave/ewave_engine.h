// EWaveEngine: the live eWave sessions of a daemon. Each has an unguessable id (128 random bits, hex),
// holds a --max-sessions slot from the LimitGate, and is evicted when idle longer than the TTL. An id
// that is unknown, closed or evicted gives Error(NotFound).
#pragma once

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "common/limits.h"
#include "ewave/ewave_session.h"

namespace squall::ewave {

struct EWaveEngineOptions {
  std::chrono::milliseconds session_ttl{std::chrono::minutes(10)};  // squalld --session-ttl
  // The clock the TTL is measured with (tests replace it).
  std::function<std::chrono::steady_clock::time_point()> clock = [] { return std::chrono::steady_clock::now(); };
  // Evaluates the ocean specs of configs and steps (ambient_ocean, initial_ocean); null: such specs give
  // FAILED_PRECONDITION. Must share the runtime and outlive the engine.
  ocean::OceanEngine* ocean = nullptr;
};

class EWaveEngine {
 public:
  EWaveEngine(Runtime& runtime, fft::Fft& fft, LimitGate& gate, EWaveEngineOptions options = {});

  std::string create(const EWaveConfig& config);          // validated; RESOURCE_EXHAUSTED past --max-sessions
  std::string create_from_state(const std::string& bytes);  // a new session continuing a saved state
  Frame step(const std::string& id, const StepInputs& inputs);
  std::string state(const std::string& id);
  void restore(const std::string& id, const std::string& bytes);
  void close(const std::string& id);
  EWaveConfig config(const std::string& id);

  size_t evict_idle();  // closes sessions idle past the TTL; returns how many
  size_t size() const;

 private:
  struct Entry {
    std::mutex mutex;  // one call at a time per session
    std::unique_ptr<EWaveSession> session;
    Slot slot;
    std::chrono::steady_clock::time_point last_use;
  };
  std::string add(std::unique_ptr<EWaveSession> session, Slot slot);
  // The entry of id, its last use refreshed; NotFound otherwise. `field` names the id in the message.
  std::shared_ptr<Entry> find(const std::string& id);
  static std::string new_id();

  Runtime& runtime_;
  fft::Fft& fft_;
  LimitGate& gate_;
  EWaveEngineOptions options_;
  mutable std::mutex mutex_;
  std::map<std::string, std::shared_ptr<Entry>> sessions_;
};

}  // namespace squall::ewave
