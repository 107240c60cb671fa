#include "ewave/ewave_engine.h"

#include <optional>
#include <string_view>

#include "common/byte_codec.h"
#include "common/error.h"
#include "ewave/ewave_state_format.h"
#include "ewave/step_kernels.h"
#include "ocean/tile_spec_bytes.h"

namespace squall::ewave {
namespace {

// A checkpoint's payload, version 3 (common/byte_codec.h's layout: little-endian):
//   offset    size  field
//   0         8     u64 state length S
//   8         S     the session's state bytes of version 1 (ewave_state_format.h)
//   8+S       8     u64 ambient ocean length A; 0: the config has no ambient_ocean
//   16+S      A     config.ambient_ocean (ocean/tile_spec_bytes.h)
//   16+S+A    8     u64 retry key length K, 1..kMaxRetryKeyBytes
//   24+S+A    K     the last step's retry_key, and nothing after it
// A session whose last step had no key writes version 2, the same without the key, which daemons before
// version 3 read; version 1 (the state bytes alone, no ambient ocean) is still read.
VersionedPayload save(const EWaveSession& session) {
  const std::optional<ocean::TileSpec>& ambient = session.config().ambient_ocean;
  ByteWriter out;
  out.put_counted(without_ambient_ocean(session.state()));
  out.put_counted(ambient ? ocean::encode_tile_spec(*ambient) : std::string());
  if (session.retry_key().empty()) return {2, out.take()};
  out.put_counted(session.retry_key());
  return {3, out.take()};
}

struct Saved {
  std::string state;
  std::optional<ocean::TileSpec> ambient_ocean;
  std::string retry_key;
};

// A payload of `version` back; InvalidArgument naming "checkpoint" (its ambient ocean: naming
// "checkpoint.ambient_ocean") when it is none.
Saved load(std::string payload, uint32_t version, const LimitGate& gate) {
  if (version == 1) return {std::move(payload), std::nullopt, ""};
  if (version != 2 && version != 3)
    fail(Code::InvalidArgument, "checkpoint has payload version " + std::to_string(version));
  ByteReader in(payload, "checkpoint", "an eWave session payload");
  Saved saved;
  saved.state = std::string(in.get_counted("the state"));
  const std::string_view spec = in.get_counted("the ambient ocean");
  if (version == 3) saved.retry_key = std::string(in.get_counted("the retry key"));
  in.finish(version == 3 ? "the retry key" : "the ambient ocean");
  if (version == 3 && (saved.retry_key.empty() || saved.retry_key.size() > kMaxRetryKeyBytes))
    fail(Code::InvalidArgument, "checkpoint holds a retry key of " + std::to_string(saved.retry_key.size()) +
                                    " bytes, want 1 to " + std::to_string(kMaxRetryKeyBytes));
  if (!spec.empty()) saved.ambient_ocean = ocean::decode_tile_spec(spec, gate, "checkpoint.ambient_ocean");
  return saved;
}

SessionView view_of(const std::string& id, const EWaveSession& s) {
  return {id, s.config(), s.step_index(), s.serial()};
}

}  // namespace

EWaveEngine::EWaveEngine(Runtime& runtime, fft::Fft& fft, LimitGate& gate, EWaveEngineOptions options)
    : runtime_(runtime),
      fft_(fft),
      gate_(gate),
      ocean_(options.ocean),
      coefficients_(cache_bound(gate.limits().memory_budget, runtime.device_info().global_memory_bytes,
                                CoefficientCache::kDefaultMaxBytes),
                    &gate),
      sessions_(gate, std::move(options.sessions), "eWave session", "session_id") {
  sessions_.persist(save, [this](const std::string& bytes) { restore_checkpoint(bytes); });
  // The kernels' argument lists are checked against the device's now, at start-up, not at a first session.
  StepKernels<cl_float> single_precision(runtime);
  make_rasterize_kernel(runtime);
  if (runtime.device_info().double_precision) StepKernels<cl_double> double_precision(runtime);
}

uint64_t state_field_bytes(const EWaveConfig& config) {
  return kStateFields * uint64_t(config.nx) * uint64_t(config.ny) * (config.double_precision ? 8 : 4);
}

uint64_t session_bytes(const EWaveConfig& config) {
  const uint64_t cells = uint64_t(config.nx) * config.ny;
  const uint64_t modes = uint64_t(config.nx / 2 + 1) * config.ny;
  const uint64_t real = config.double_precision ? 8 : 4;
  const uint64_t state = state_field_bytes(config);
  const uint64_t spectrum = kOutputFields * modes * 2 * real, work = kOutputFields * cells * real;
  // Float maps: 5 output planes, the zeros of an absent input, and the inputs a step may upload
  // (obstruction, ambient h and phi, source h and phi, drift x and y); the trim profiles.
  const uint64_t maps = (5 + 1 + 7) * cells * 4, trims = (uint64_t(config.nx) + config.ny) * 4;
  return state + spectrum + work + maps + trims;
}

void EWaveEngine::check_runs_here(const EWaveConfig& config, const std::string& path) const {
  EWaveSession::check_runs_on(runtime_, fft_, ocean_, config, path);
}

void EWaveEngine::check_runs_here(const StepInputs& inputs) const { EWaveSession::check_runs_on(ocean_, inputs); }

EWaveEngine::NewSession EWaveEngine::new_session(const EWaveConfig& config, const OceanCall& call,
                                                 const std::string& path, const std::string& client) {
  validate(config, &gate_, path);
  check_runs_here(config, path);  // before the session's bytes are reserved
  // The initial ocean's kept spectra, held until the session is made: taken back to make room for the
  // session's own bytes, they would have to be built again, which would not fit either.
  const std::vector<cl::Buffer> held = ocean_ && config.initial_ocean
                                           ? ocean_->kept_spectra(ocean_on_grid(*config.initial_ocean, config))
                                           : std::vector<cl::Buffer>{};
  auto reservation = sessions_.reserve(session_bytes(config), client);
  // Those kept when the call reserved its spectra and evicted since, by another call, are reserved now.
  if (call.spectra_memory)
    gate_.top_up(*call.spectra_memory, "config.initial_ocean's spectra, built again",
                 [&] { return ocean_bytes(config, config.initial_ocean).new_spectra; });
  return {std::move(reservation),
          std::make_shared<EWaveSession>(runtime_, fft_, config, ocean_, &gate_, &coefficients_, call)};
}

std::string EWaveEngine::create(const EWaveConfig& config, const std::string& proposed, const OceanCall& call,
                                const std::string& client, SessionView* made) {
  const std::string id = sessions_.id_for(proposed, kProposedIdField);
  auto [reservation, session] = new_session(config, call, "config", client);
  if (made) *made = view_of(id, *session);
  return sessions_.add(id, std::move(reservation), std::move(session));
}

EWaveEngine::NewSession EWaveEngine::from_state(const std::string& bytes, std::optional<ocean::TileSpec> ambient_ocean,
                                                const std::string& client) {
  EWaveConfig config = EWaveSession::config_from_state(bytes, gate_);
  if (!config.ambient_ocean) config.ambient_ocean = std::move(ambient_ocean);
  NewSession made = new_session(config, {}, "state", client);
  made.second->restore(bytes);
  return made;
}

std::string EWaveEngine::create_from_state(const std::string& bytes, const std::string& proposed,
                                           const std::string& client, SessionView* made) {
  const std::string id = sessions_.id_for(proposed, kProposedIdField);
  auto [reservation, session] = from_state(bytes, std::nullopt, client);
  if (made) *made = view_of(id, *session);
  return sessions_.add(id, std::move(reservation), std::move(session));
}

Frame EWaveEngine::step(const std::string& id, const StepInputs& inputs, const StepGuard& guard,
                        const OceanCall& call) {
  return sessions_.with(id, [&](EWaveSession& s) { return s.step(inputs, guard, call); });
}

EWaveEngine::OceanBytes EWaveEngine::ocean_bytes(const EWaveConfig& config,
                                                 const std::optional<ocean::TileSpec>& spec) const {
  if (!spec || !ocean_) return {};
  const ocean::TileSpec on_grid = ocean_on_grid(*spec, config);
  return {ocean_->new_spectra_bytes(on_grid), ocean::surface_device_bytes(on_grid)};
}

std::string EWaveEngine::state(const std::string& id, uint64_t serial) {
  return sessions_.with(id, [&](EWaveSession& s) {
    s.require_serial(serial);
    return s.state();
  });
}

SessionView EWaveEngine::view(const std::string& id) {
  return sessions_.with(id, [&](EWaveSession& s) { return view_of(id, s); });
}

SurfaceCurrent EWaveEngine::surface_current(const std::string& id) {
  return sessions_.with(id, [](EWaveSession& s) { return s.surface_current(); });
}

void EWaveEngine::close(const std::string& id, uint64_t serial) {
  if (serial == 0) return sessions_.close(id);
  sessions_.close(id, [serial](const EWaveSession& s) { return s.serial() == serial; });  // serial_ is const
}

std::string EWaveEngine::checkpoint(const std::string& id) { return sessions_.checkpoint(id, save); }

std::string EWaveEngine::restore_checkpoint(const std::string& bytes) {
  CheckpointHeader header;
  std::string payload =
      sessions_.open_checkpoint(bytes, "checkpoint", kOldestCheckpointVersion, kCheckpointVersion, &header);
  Saved saved = load(std::move(payload), header.version, gate_);
  auto [reservation, session] = from_state(saved.state, std::move(saved.ambient_ocean), header.client);
  session->set_retry_key(std::move(saved.retry_key));  // a retry of its last step finds it here too
  return sessions_.add(header.id, std::move(reservation), std::move(session));
}

size_t EWaveEngine::evict_idle() { return sessions_.evict_idle(); }

}  // namespace squall::ewave
