// EWaveSession's life cycle: construction (initial fields on the device), and its state as bytes
// (ewave_state_format.h). The step pipeline is in ewave_step.cpp.
#include "ewave/ewave_session.h"

#include <algorithm>
#include <atomic>

#include "common/error.h"
#include "ewave/propagator.h"
#include "ocean/tile_spec_bytes.h"
#include "runtime/host_transfer.h"

namespace squall::ewave {
namespace {

uint64_t next_serial() {
  static std::atomic<uint64_t> last{0};
  return ++last;
}

}  // namespace

EWaveSession::EWaveSession(Runtime& runtime, fft::Fft& fft, const EWaveConfig& config, ocean::OceanEngine* ocean,
                           const LimitGate* gate, CoefficientCache* coefficients, const OceanCall& call)
    : runtime_(runtime),
      fft_(fft),
      ocean_(ocean),
      gate_(gate),
      config_(config),
      serial_(next_serial()),
      // A session's own cache keeps at least its own table, however large its grid.
      own_coefficients_(coefficients ? nullptr
                                     : std::make_unique<CoefficientCache>(std::max(
                                           CoefficientCache::kDefaultMaxBytes, CoefficientCache::table_bytes(config)))),
      coefficients_(coefficients ? coefficients : own_coefficients_.get()) {
  validate(config_, gate_);
  if (config_.initial_ocean) ocean_engine("config.initial_ocean");
  if (config_.ambient_ocean) ocean_engine("config.ambient_ocean");
  check_runs_on(runtime_, fft_, ocean_, config_, "config");
  time_ = config_.start_time;
  cells_ = config_.cells();
  half_ = (size_t(config_.nx) / 2 + 1) * size_t(config_.ny);
  real_size_ = config_.double_precision ? sizeof(double) : sizeof(float);
  kernels_ = make_step_kernels(runtime_, config_.double_precision);
  rasterize_ = make_rasterize_kernel(runtime_);
  auto& pool = runtime_.buffers();
  state_ = pool.acquire(kStateFields * cells_ * real_size_);
  spectrum_ = pool.acquire(kOutputFields * half_ * 2 * real_size_);
  work_ = pool.acquire(kOutputFields * cells_ * real_size_);
  out_ = pool.acquire(5 * cells_ * sizeof(float));
  absent_map_ = pool.acquire(cells_ * sizeof(float));
  auto lock = runtime_.exclusive();
  runtime_.queue().enqueueFillBuffer(absent_map_.buffer(), cl_float(0), 0, cells_ * sizeof(float));
  upload_initial_fields(call);
  lock.unlock();  // measuring FFTW plans takes up to seconds: no device queue is held meanwhile
  // The plans of every step, made now rather than during the first step: the state's forward transform,
  // and the inverse one of the state alone or of the state with the derived outputs (step()).
  const size_t nx = size_t(config_.nx), ny = size_t(config_.ny);
  fft_.prepare({nx, ny, kStateFields, fft::Transform::R2C, precision()}, fft::Direction::Forward, false);
  for (int fields : {kStateFields, kOutputFields})
    fft_.prepare({nx, ny, size_t(fields), fft::Transform::C2R, precision()}, fft::Direction::Inverse, false);
}

// The state (h, then phi) zeroed, then each given field written into its plane: no host copy of the whole
// state, which a large session (or one restored, whose state is written over this) would hold for nothing.
void EWaveSession::upload_initial_fields(const OceanCall& call) {
  upload_trim();
  runtime_.queue().enqueueFillBuffer(state_.buffer(), cl_float(0), 0, kStateFields * cells_ * real_size_);
  write_state(0, config_.initial_height);
  write_state(1, config_.initial_phi);
  std::vector<float>().swap(config_.initial_height);  // the config's copies are not kept either
  std::vector<float>().swap(config_.initial_phi);
  if (config_.initial_ocean) initial_from_ocean(call);
}

void EWaveSession::write_state(size_t plane, const std::vector<float>& values) {
  const size_t n = std::min(values.size(), (kStateFields - plane) * cells_), offset = plane * cells_ * real_size_;
  if (n == 0) return;  // zero
  if (!config_.double_precision) {
    runtime_.queue().enqueueWriteBuffer(state_.buffer(), CL_TRUE, offset, n * sizeof(float), values.data());
    return;
  }
  const std::vector<double> widened(values.begin(), values.begin() + ptrdiff_t(n));
  runtime_.queue().enqueueWriteBuffer(state_.buffer(), CL_TRUE, offset, n * sizeof(double), widened.data());
}

void EWaveSession::check_runs_on(const Runtime& runtime, const fft::Fft& fft, const ocean::OceanEngine* ocean,
                                 const EWaveConfig& config, const std::string& path) {
  if (config.double_precision && !runtime.device_info().double_precision)
    fail(Code::InvalidArgument,
         path + ".double_precision = true but device " + runtime.device_info().name + " has no fp64");
  fft.check_length(path + ".nx", size_t(config.nx));
  fft.check_length(path + ".ny", size_t(config.ny));
  if (!ocean) return;  // an ocean then fails where it is evaluated (ocean_engine)
  if (config.initial_ocean) ocean->check_transforms(*config.initial_ocean, path + ".initial_ocean");
  if (config.ambient_ocean) ocean->check_transforms(*config.ambient_ocean, path + ".ambient_ocean");
}

void EWaveSession::check_runs_on(const ocean::OceanEngine* ocean, const StepInputs& inputs) {
  if (inputs.ambient_ocean && ocean) ocean->check_transforms(*inputs.ambient_ocean, "inputs.ambient_ocean");
}

ocean::OceanEngine& EWaveSession::ocean_engine(const std::string& field) const {
  if (!ocean_) fail(Code::FailedPrecondition, field + " needs the ocean engine, which this eWave engine was not given");
  return *ocean_;
}

void EWaveSession::initial_from_ocean(const OceanCall& call) {
  ocean::TileSpec spec = ocean_on_grid(*config_.initial_ocean, config_);
  ocean::OceanEngine& ocean = ocean_engine("config.initial_ocean");
  if (!config_.double_precision) {  // state_ is h then phi in float: the ocean writes it directly
    ocean.surface_on_device(spec, time_, state_.buffer(), call.cancel, call.spectra_memory);
    runtime_.queue().finish();
    return;
  }
  // Double state: one host round trip at creation, converting the float ocean fields.
  BufferLease surface = runtime_.buffers().acquire(kStateFields * cells_ * sizeof(float));
  ocean.surface_on_device(spec, time_, surface.buffer(), call.cancel, call.spectra_memory);
  std::vector<float> values(kStateFields * cells_);
  runtime_.queue().enqueueReadBuffer(surface.buffer(), CL_TRUE, 0, values.size() * sizeof(float), values.data());
  write_state(0, values);
}

const cl::Buffer& EWaveSession::upload(BufferLease& lease, const std::vector<float>& values) {
  size_t bytes = values.size() * sizeof(float);
  if (lease.bytes() != bytes) lease = runtime_.buffers().acquire(bytes);
  write_buffer(runtime_, lease.buffer(), bytes, values.data());
  return lease.buffer();
}

void EWaveSession::upload_trim() {
  double width = config_.effective_trim_width();
  std::vector<float> tx = trim_profile(size_t(config_.nx), config_.dx, width, config_.trim_alpha);
  std::vector<float> ty = trim_profile(size_t(config_.ny), config_.dy, width, config_.trim_alpha);
  upload(trim_x_, tx);
  upload(trim_y_, ty);
  runtime_.queue().finish();
}

uint64_t EWaveSession::device_bytes() const {
  uint64_t bytes = 0;
  for (const BufferLease* lease : {&state_, &spectrum_, &work_, &out_, &trim_x_, &trim_y_, &absent_map_, &obstruction_,
                                   &ambient_, &source_h_, &source_phi_, &drift_x_, &drift_y_})
    bytes += lease->bytes();
  return bytes;
}

void EWaveSession::require_serial(uint64_t serial) const {
  if (serial != 0 && serial != serial_)
    fail(Code::Aborted,
         "session_id names a session made again under that id (closed and created, or resumed from its "
         "checkpoint) since this call read its config: nothing was done; send the call again");
}

void EWaveSession::check_whole() const {
  if (!broken_.empty())
    fail(Code::FailedPrecondition, "the session's " + broken_ +
                                       "; its fields are undefined: close it, and Restore a state taken before as a "
                                       "new session");
}

std::string EWaveSession::state() const {
  check_whole();
  std::string bytes = new_state(config_, step_, time_);
  {
    auto lock = runtime_.exclusive();
    runtime_.queue().enqueueReadBuffer(state_.buffer(), CL_TRUE, 0, kStateFields * cells_ * real_size_,
                                       state_fields(bytes));
  }
  // A state restore() would refuse is not handed out: inputs held to their ranges can still drive a
  // session there (a source stepped for hours at a large dt, a gravity of 1000).
  try {
    check_fields_in_range(bytes, parse_state_header(bytes));
  } catch (const Error& e) {
    fail(Code::FailedPrecondition, std::string("the session's fields have grown past what a state holds (") + e.what() +
                                       "): close it, and Restore a state taken before as a new session");
  }
  return bytes;
}

EWaveConfig EWaveSession::config_from_state(const std::string& bytes, const LimitGate& gate) {
  const StateHeader h = parse_state_header(bytes);
  EWaveConfig config = config_of(h, &gate);
  const std::string_view ambient = ambient_ocean_bytes(bytes, h);
  if (!ambient.empty()) config.ambient_ocean = ocean::decode_tile_spec(ambient, gate, "state.ambient_ocean");
  return config;
}

void EWaveSession::check_same_grid(const StateHeader& h) const {
  if (h.nx != config_.nx || h.ny != config_.ny || (h.double_precision != 0) != config_.double_precision)
    fail(Code::InvalidArgument, "state.grid = " + std::to_string(h.nx) + " x " + std::to_string(h.ny) +
                                    (h.double_precision ? " (double)" : " (float)") + " does not match the session's " +
                                    std::to_string(config_.nx) + " x " + std::to_string(config_.ny));
}

void EWaveSession::restore(const std::string& bytes) {
  StateHeader h = parse_state_header(bytes);
  check_same_grid(h);
  check_fields_in_range(bytes, h);
  EWaveConfig restored = config_of(h);
  restored.ambient_ocean = config_.ambient_ocean;  // the session's own (config_from_state() gives the bytes')
  config_ = std::move(restored);
  auto lock = runtime_.exclusive();
  upload_trim();
  runtime_.queue().enqueueWriteBuffer(state_.buffer(), CL_TRUE, 0, kStateFields * cells_ * real_size_,
                                      state_fields(bytes));
  step_ = h.step;
  time_ = h.time;
  outputs_step_.reset();  // the state holds no step's displacement or normals
  retry_key_.clear();     // a checkpoint's is set by its caller
  broken_.clear();
}

}  // namespace squall::ewave
