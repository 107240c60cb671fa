// EWaveEngine: the live eWave sessions of a daemon, kept in a SessionStore (unguessable ids, a
// --max-sessions slot and their bytes against --max-session-bytes each, evicted when idle longer than the
// TTL, checkpointable). An id that is unknown, closed or evicted gives Error(NotFound).
#pragma once

#include <chrono>
#include <memory>
#include <optional>
#include <string>

#include "common/limits.h"
#include "common/session_store.h"
#include "ewave/ewave_session.h"

namespace squall::ewave {

struct EWaveEngineOptions {
  SessionPolicy sessions;  // squalld --session-ttl, and the clock it is measured with (tests replace it)
  // Evaluates the ocean specs of configs and steps (ambient_ocean, initial_ocean); null: such specs give
  // FAILED_PRECONDITION. Must share the runtime and outlive the engine.
  ocean::OceanEngine* ocean = nullptr;
};

// A session as one locked read saw it: its serial (EWaveSession::serial) names it for a later call's
// StepGuard, state() or close(), which then act on that session only.
struct SessionView {
  std::string id;
  EWaveConfig config;
  uint64_t steps = 0, serial = 0;
};

class EWaveEngine {
 public:
  // Versions of the checkpoint payload (ewave_engine.cpp): 3, the session's state bytes, its config's
  // ambient_ocean and its last step's retry key; 2 the same with no key (written when the last step had
  // none); 1 (the state bytes alone, no ambient ocean) still read.
  static constexpr uint32_t kCheckpointVersion = 3;
  static constexpr uint32_t kOldestCheckpointVersion = 1;

  EWaveEngine(Runtime& runtime, fft::Fft& fft, LimitGate& gate, EWaveEngineOptions options = {});

  // A new session of `config` (validated; RESOURCE_EXHAUSTED past --max-sessions), and one continuing a
  // saved state; under the client's `proposed` id when one is given (SessionStore::id_for), counted against
  // `client`'s --max-sessions-per-client (empty: no client's). `call`: what the creating call lends the
  // initial ocean's evaluation: the spectra kept are held while the session's bytes are reserved, and its
  // spectra_memory is then topped up to those that must be built (RESOURCE_EXHAUSTED past --memory-budget).
  // `made`, if given, receives the new session's view, read before any other call can reach it.
  std::string create(const EWaveConfig& config, const std::string& proposed = "", const OceanCall& call = {},
                     const std::string& client = "", SessionView* made = nullptr);
  std::string create_from_state(const std::string& bytes, const std::string& proposed = "",
                                const std::string& client = "", SessionView* made = nullptr);
  Frame step(const std::string& id, const StepInputs& inputs, const StepGuard& guard = {},
             const OceanCall& call = {});  // EWaveSession::step
  // What a session of `config` (EWaveSession::check_runs_on, under `path`) or a step's `inputs` (its ambient
  // ocean's layers) needs of this engine's device and FFT backend: INVALID_ARGUMENT naming the field, for a
  // caller to refuse before it reserves anything. create() and step() check again.
  void check_runs_here(const EWaveConfig& config, const std::string& path = "config") const;
  void check_runs_here(const StepInputs& inputs) const;
  // What an ocean spec of a session of `config` (its initial or ambient ocean, or a step's) holds while it
  // is evaluated on the session's grid: the spectra not kept yet (OceanEngine::new_spectra_bytes) and one
  // layer's fields at a time (ocean::surface_device_bytes). Zero without a spec or an ocean engine.
  struct OceanBytes {
    uint64_t new_spectra = 0, working = 0;
  };
  OceanBytes ocean_bytes(const EWaveConfig& config, const std::optional<ocean::TileSpec>& spec) const;
  // The session's state; with a `serial`, Error(Aborted) unless the id still names that session
  // (EWaveSession::require_serial).
  std::string state(const std::string& id, uint64_t serial = 0);
  // Closes the session; with a `serial`, only that session (NOT_FOUND where the id names another one now).
  void close(const std::string& id, uint64_t serial = 0);
  SessionView view(const std::string& id);  // in one locked read
  // The session's surface current after its last step, for the textures that follow its wakes.
  SurfaceCurrent surface_current(const std::string& id);

  // The session as versioned bytes, and back under its id: to persist sessions or move them between
  // daemons. A restored session continues bit-identically, as one made from state() does, and counts
  // against the --max-sessions-per-client of the client its checkpoint names.
  std::string checkpoint(const std::string& id);
  std::string restore_checkpoint(const std::string& bytes);

  size_t evict_idle();  // closes sessions idle past the TTL; returns how many
  size_t size() const { return sessions_.size(); }
  // The propagator tables its sessions share (one per grid, dispersion and dt).
  const CoefficientCache& coefficients() const { return coefficients_; }

 private:
  // A validated session of `config`, its memory reserved before it is built; and one continuing `bytes`,
  // with the ambient ocean they hold, else `ambient_ocean` (a version-2 checkpoint's, beside its state).
  using NewSession = std::pair<SessionStore<EWaveSession>::Reservation, std::shared_ptr<EWaveSession>>;
  NewSession new_session(const EWaveConfig& config, const OceanCall& call = {}, const std::string& path = "config",
                         const std::string& client = "");
  NewSession from_state(const std::string& bytes, std::optional<ocean::TileSpec> ambient_ocean = std::nullopt,
                        const std::string& client = "");

  Runtime& runtime_;
  fft::Fft& fft_;
  LimitGate& gate_;
  ocean::OceanEngine* ocean_;
  CoefficientCache coefficients_;  // before sessions_: outlives every session
  SessionStore<EWaveSession> sessions_;
};

// Host + device bytes a session of `config` holds: the state (h, phi), the spectrum, the work and output
// buffers and the per-cell input maps, counted against --max-session-bytes.
uint64_t session_bytes(const EWaveConfig& config);
// Bytes of a session's h and phi (its state's fields, in its precision).
uint64_t state_field_bytes(const EWaveConfig& config);

}  // namespace squall::ewave
