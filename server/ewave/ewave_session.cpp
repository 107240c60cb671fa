#include "ewave/ewave_session.h"

#include <cmath>
#include <cstring>
#include <numbers>

#include "common/error.h"
#include "ewave/propagator.h"

namespace squall::ewave {
namespace {

constexpr int kStateFields = 2;   // h, phi
constexpr int kOutputFields = 9;  // h, phi, eps_x, eps_y, D_x, D_y, dDx/dx, dDy/dy, dDx/dy (step.cl)
constexpr size_t kCachedTables = 4;
constexpr char kMagic[8] = {'S', 'Q', 'E', 'W', 'A', 'V', 'E', '1'};

// The fixed part of a state (all 8-byte members, no padding), followed by 2 nx ny floats (h, phi).
struct StateHeader {
  char magic[8];
  int64_t nx, ny;
  double dx, dy;
  int64_t dispersion;
  double gravity, depth, capillary_length;
  int64_t trim;
  double trim_width, trim_alpha, friction_time, source_scale;
  int64_t mask_phi;
  int64_t double_precision;
  double displacement_scale;
  uint64_t step;
  double time;
};

bool wants_outputs(const OutputSelection& o) { return o.displacement || o.normals; }

}  // namespace

EWaveSession::EWaveSession(Runtime& runtime, fft::Fft& fft, const EWaveConfig& config, ocean::OceanEngine* ocean)
    : runtime_(runtime), fft_(fft), ocean_(ocean), config_(config) {
  validate(config_);
  if (config_.initial_ocean) ocean_engine("config.initial_ocean");
  if (config_.ambient_ocean) ocean_engine("config.ambient_ocean");
  time_ = config_.start_time;
  if (config_.double_precision && !runtime_.device_info().double_precision)
    fail(Code::InvalidArgument, "config.double_precision = true but device " + runtime_.device_info().name + " has no fp64");
  cells_ = config_.cells();
  half_ = (size_t(config_.nx) / 2 + 1) * size_t(config_.ny);
  real_size_ = config_.double_precision ? sizeof(double) : sizeof(float);
  const char* program = config_.double_precision ? "ewave/step_f64.cl" : "ewave/step.cl";
  prepare_ = runtime_.kernel(program, "ewave_prepare");
  propagate_ = runtime_.kernel(program, "ewave_propagate");
  finish_ = runtime_.kernel(program, "ewave_finish");
  rasterize_ = runtime_.kernel("ewave/obstruction.cl", "ewave_rasterize");
  auto& pool = runtime_.buffers();
  state_ = pool.acquire(kStateFields * cells_ * real_size_);
  spectrum_ = pool.acquire(kOutputFields * half_ * 2 * real_size_);
  work_ = pool.acquire(kOutputFields * cells_ * real_size_);
  out_ = pool.acquire(5 * cells_ * sizeof(float));
  placeholder_ = pool.acquire(sizeof(float));
  auto lock = runtime_.exclusive();
  upload_trim();
  std::vector<double> fields(kStateFields * cells_, 0.0);
  std::copy(config_.initial_height.begin(), config_.initial_height.end(), fields.begin());
  std::copy(config_.initial_phi.begin(), config_.initial_phi.end(), fields.begin() + cells_);
  config_.initial_height.clear();
  config_.initial_phi.clear();
  std::vector<char> bytes = to_state_type(fields);
  runtime_.queue().enqueueWriteBuffer(state_.buffer(), CL_TRUE, 0, bytes.size(), bytes.data());
  if (config_.initial_ocean) initial_from_ocean();
  // Bake the plans of every step now, not during the first step.
  fft_.plan({size_t(config_.nx), size_t(config_.ny), kStateFields, fft::Transform::R2C, precision()});
  fft_.plan({size_t(config_.nx), size_t(config_.ny), kStateFields, fft::Transform::C2R, precision()});
}

ocean::OceanEngine& EWaveSession::ocean_engine(const std::string& field) const {
  if (!ocean_) fail(Code::FailedPrecondition, field + " needs the ocean engine, which this eWave engine was not given");
  return *ocean_;
}

void EWaveSession::initial_from_ocean() {
  ocean::TileSpec spec = ocean_on_grid(*config_.initial_ocean, config_);
  ocean::OceanEngine& ocean = ocean_engine("config.initial_ocean");
  if (!config_.double_precision) {  // state_ is h then phi in float: the ocean writes it directly
    ocean.surface_on_device(spec, time_, state_.buffer());
    runtime_.queue().finish();
    return;
  }
  // Double state: one host round trip at creation, converting the float ocean fields.
  BufferLease surface = runtime_.buffers().acquire(kStateFields * cells_ * sizeof(float));
  ocean.surface_on_device(spec, time_, surface.buffer());
  std::vector<float> values(kStateFields * cells_);
  runtime_.queue().enqueueReadBuffer(surface.buffer(), CL_TRUE, 0, values.size() * sizeof(float), values.data());
  std::vector<char> bytes = to_state_type(std::vector<double>(values.begin(), values.end()));
  runtime_.queue().enqueueWriteBuffer(state_.buffer(), CL_TRUE, 0, bytes.size(), bytes.data());
}

const cl::Buffer* EWaveSession::ambient(const StepInputs& in, bool has_obstruction) {
  if (!in.ambient_height.empty()) return &upload(ambient_, in.ambient_height);
  const std::optional<ocean::TileSpec>& spec = in.ambient_ocean ? in.ambient_ocean : config_.ambient_ocean;
  if (!spec || !has_obstruction) return nullptr;  // h_A (1 - O) = 0 without an obstruction: skip the ocean
  ocean::OceanEngine& ocean = ocean_engine(in.ambient_ocean ? "inputs.ambient_ocean" : "config.ambient_ocean");
  size_t bytes = kStateFields * cells_ * sizeof(float);  // h_A, then the unused phi_A plane
  if (ambient_.bytes() != bytes) ambient_ = runtime_.buffers().acquire(bytes);
  ocean.surface_on_device(ocean_on_grid(*spec, config_), time_, ambient_.buffer());
  return &ambient_.buffer();
}

std::vector<char> EWaveSession::to_state_type(const std::vector<double>& values) const {
  std::vector<char> bytes(values.size() * real_size_);
  if (config_.double_precision) {
    std::memcpy(bytes.data(), values.data(), bytes.size());
  } else {
    for (size_t i = 0; i < values.size(); ++i) {
      float f = float(values[i]);
      std::memcpy(bytes.data() + i * sizeof(float), &f, sizeof(float));
    }
  }
  return bytes;
}

void EWaveSession::set_real(cl::Kernel& kernel, int index, double value) const {
  if (config_.double_precision)
    kernel.setArg(index, cl_double(value));
  else
    kernel.setArg(index, cl_float(value));
}

const cl::Buffer& EWaveSession::upload(BufferLease& lease, const std::vector<float>& values) {
  size_t bytes = values.size() * sizeof(float);
  if (lease.bytes() != bytes) lease = runtime_.buffers().acquire(bytes);
  runtime_.queue().enqueueWriteBuffer(lease.buffer(), CL_FALSE, 0, bytes, values.data());
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

const cl::Buffer& EWaveSession::coefficients(double dt) {
  ++uses_;
  auto found = coefficients_.find(dt);
  if (found == coefficients_.end()) {
    if (coefficients_.size() >= kCachedTables) {
      auto oldest = coefficients_.begin();
      for (auto it = coefficients_.begin(); it != coefficients_.end(); ++it)
        if (it->second.last_use < oldest->second.last_use) oldest = it;
      coefficients_.erase(oldest);
    }
    std::vector<char> table = to_state_type(propagator_coefficients(config_, dt));
    found = coefficients_.emplace(dt, Coefficients{}).first;
    found->second.buffer = runtime_.buffers().acquire(table.size());
    runtime_.queue().enqueueWriteBuffer(found->second.buffer.buffer(), CL_TRUE, 0, table.size(), table.data());
  }
  found->second.last_use = uses_;
  return found->second.buffer.buffer();
}

// O = (the obstruction field, or 1) times the uncovered fraction of the shapes. False when neither is given.
bool EWaveSession::build_obstruction(const StepInputs& in) {
  if (in.obstruction.empty() && in.shapes.empty()) return false;
  if (in.obstruction.empty()) {
    if (obstruction_.bytes() != cells_ * sizeof(float)) obstruction_ = runtime_.buffers().acquire(cells_ * sizeof(float));
    runtime_.queue().enqueueFillBuffer(obstruction_.buffer(), cl_float(1.0f), 0, cells_ * sizeof(float));
  } else {
    upload(obstruction_, in.obstruction);
  }
  if (in.shapes.empty()) return true;
  std::vector<float> vertices;
  std::vector<EWaveShape> shapes = device_shapes(in.shapes, &vertices);
  if (vertices.empty()) vertices.assign(2, 0.0f);
  size_t shape_bytes = shapes.size() * sizeof(EWaveShape);
  if (shapes_.bytes() != shape_bytes) shapes_ = runtime_.buffers().acquire(shape_bytes);
  runtime_.queue().enqueueWriteBuffer(shapes_.buffer(), CL_FALSE, 0, shape_bytes, shapes.data());
  upload(vertices_, vertices);
  int a = 0;
  rasterize_.setArg(a++, obstruction_.buffer());
  rasterize_.setArg(a++, shapes_.buffer());
  rasterize_.setArg(a++, cl_int(shapes.size()));
  rasterize_.setArg(a++, vertices_.buffer());
  rasterize_.setArg(a++, cl_uint(config_.nx));
  rasterize_.setArg(a++, cl_uint(config_.ny));
  rasterize_.setArg(a++, cl_float(config_.dx));
  rasterize_.setArg(a++, cl_float(config_.dy));
  runtime_.queue().enqueueNDRangeKernel(rasterize_, cl::NullRange, cl::NDRange(config_.nx, config_.ny));
  // The host vectors must outlive the non-blocking writes.
  runtime_.queue().finish();
  return true;
}

void EWaveSession::prepare(const StepInputs& in, bool has_obstruction) {
  const cl::Buffer& none = placeholder_.buffer();
  auto optional = [&](BufferLease& lease, const std::vector<float>& values) -> const cl::Buffer& {
    return values.empty() ? none : upload(lease, values);
  };
  double decay = 1, gain = in.dt;  // eq 60-61
  if (config_.friction_time > 0) {  // eq 72-73
    decay = std::exp(-in.dt / config_.friction_time);
    gain = -config_.friction_time * std::expm1(-in.dt / config_.friction_time);
  }
  int a = 0;
  prepare_.setArg(a++, state_.buffer());
  prepare_.setArg(a++, cl_uint(config_.nx));
  prepare_.setArg(a++, cl_uint(config_.ny));
  prepare_.setArg(a++, has_obstruction ? obstruction_.buffer() : none);
  prepare_.setArg(a++, cl_int(has_obstruction));
  const cl::Buffer* ambient_height = ambient(in, has_obstruction);
  prepare_.setArg(a++, ambient_height ? *ambient_height : none);
  prepare_.setArg(a++, cl_int(ambient_height != nullptr));
  prepare_.setArg(a++, trim_x_.buffer());
  prepare_.setArg(a++, trim_y_.buffer());
  prepare_.setArg(a++, cl_int(config_.trim));
  prepare_.setArg(a++, optional(source_h_, in.source_height));
  prepare_.setArg(a++, cl_int(!in.source_height.empty()));
  prepare_.setArg(a++, optional(source_phi_, in.source_phi));
  prepare_.setArg(a++, cl_int(!in.source_phi.empty()));
  set_real(prepare_, a++, config_.source_scale);
  set_real(prepare_, a++, decay);
  set_real(prepare_, a++, gain);
  runtime_.queue().enqueueNDRangeKernel(prepare_, cl::NullRange, cl::NDRange(config_.nx, config_.ny));
}

void EWaveSession::finish(const StepInputs& in, int fields, bool has_obstruction) {
  const cl::Buffer& none = placeholder_.buffer();
  bool field_drift = !in.drift_field_x.empty();
  bool uniform_drift = !field_drift && (in.drift_x != 0 || in.drift_y != 0);
  int a = 0;
  finish_.setArg(a++, work_.buffer());
  finish_.setArg(a++, cl_int(fields));
  finish_.setArg(a++, state_.buffer());
  finish_.setArg(a++, out_.buffer());
  finish_.setArg(a++, cl_uint(config_.nx));
  finish_.setArg(a++, cl_uint(config_.ny));
  finish_.setArg(a++, cl_int(field_drift ? 2 : uniform_drift ? 1 : 0));
  set_real(finish_, a++, in.drift_x * in.dt / config_.dx);  // eq 68-69: departure x - U dt, in cells
  set_real(finish_, a++, in.drift_y * in.dt / config_.dy);
  finish_.setArg(a++, field_drift ? upload(drift_x_, in.drift_field_x) : none);
  finish_.setArg(a++, field_drift ? upload(drift_y_, in.drift_field_y) : none);
  set_real(finish_, a++, in.dt / config_.dx);
  set_real(finish_, a++, in.dt / config_.dy);
  finish_.setArg(a++, has_obstruction ? obstruction_.buffer() : none);
  finish_.setArg(a++, cl_int(has_obstruction));
  finish_.setArg(a++, cl_int(config_.mask_phi));
  finish_.setArg(a++, trim_x_.buffer());
  finish_.setArg(a++, trim_y_.buffer());
  finish_.setArg(a++, cl_int(config_.trim));
  set_real(finish_, a++, config_.displacement_scale);
  runtime_.queue().enqueueNDRangeKernel(finish_, cl::NullRange, cl::NDRange(config_.nx, config_.ny));
}

Frame EWaveSession::step(const StepInputs& in) {
  validate(in, config_);
  const int fields = wants_outputs(in.outputs) ? kOutputFields : kStateFields;
  const size_t nx = size_t(config_.nx), ny = size_t(config_.ny);
  auto lock = runtime_.exclusive();
  bool has_obstruction = build_obstruction(in);
  prepare(in, has_obstruction);  // §3.7 steps 1-3 and the sources of step 4
  fft_.plan({nx, ny, kStateFields, fft::Transform::R2C, precision()})
      .enqueue(runtime_.queue(), fft::Direction::Forward, state_.buffer(), spectrum_.buffer());  // eq 62-63
  int a = 0;
  propagate_.setArg(a++, spectrum_.buffer());
  propagate_.setArg(a++, coefficients(in.dt));
  propagate_.setArg(a++, cl_uint(nx));
  propagate_.setArg(a++, cl_uint(ny));
  set_real(propagate_, a++, 2 * std::numbers::pi / config_.length_x());
  set_real(propagate_, a++, 2 * std::numbers::pi / config_.length_y());
  propagate_.setArg(a++, cl_int(fields));
  runtime_.queue().enqueueNDRangeKernel(propagate_, cl::NullRange, cl::NDRange(nx / 2 + 1, ny));  // eq 64-65
  fft_.plan({nx, ny, size_t(fields), fft::Transform::C2R, precision()})
      .enqueue(runtime_.queue(), fft::Direction::Inverse, spectrum_.buffer(), work_.buffer());  // eq 66-67
  finish(in, fields, has_obstruction);  // eq 68-69, §3.7 steps 5-7
  Frame frame = read_frame(in.outputs);  // blocking reads: the host vectors of the inputs are free after this
  ++step_;
  time_ += in.dt;
  frame.step = step_;
  frame.time = time_;
  return frame;
}

Frame EWaveSession::read_frame(const OutputSelection& o) const {
  Frame f;
  const cl::CommandQueue& q = runtime_.queue();
  auto read = [&](const cl::Buffer& buffer, size_t offset, size_t count, std::vector<float>& into) {
    into.resize(count);
    q.enqueueReadBuffer(buffer, CL_FALSE, offset * sizeof(float), count * sizeof(float), into.data());
  };
  auto read_state = [&](size_t offset, std::vector<float>& into) {
    if (!config_.double_precision) return read(state_.buffer(), offset, cells_, into);
    std::vector<double> values(cells_);
    q.enqueueReadBuffer(state_.buffer(), CL_TRUE, offset * sizeof(double), cells_ * sizeof(double), values.data());
    into.assign(values.begin(), values.end());
  };
  if (o.height) read_state(0, f.height);
  if (o.phi) read_state(cells_, f.phi);
  if (o.displacement) {
    read(out_.buffer(), 0, cells_, f.displacement_x);
    read(out_.buffer(), cells_, cells_, f.displacement_y);
  }
  if (o.normals) read(out_.buffer(), 2 * cells_, 3 * cells_, f.normals);
  q.finish();
  return f;
}

std::string EWaveSession::state() const {
  StateHeader h{};
  std::memcpy(h.magic, kMagic, sizeof(kMagic));
  h.nx = config_.nx, h.ny = config_.ny, h.dx = config_.dx, h.dy = config_.dy;
  h.dispersion = int64_t(config_.dispersion);
  h.gravity = config_.gravity, h.depth = config_.depth, h.capillary_length = config_.capillary_length;
  h.trim = config_.trim, h.trim_width = config_.trim_width, h.trim_alpha = config_.trim_alpha;
  h.friction_time = config_.friction_time, h.source_scale = config_.source_scale;
  h.mask_phi = config_.mask_phi, h.displacement_scale = config_.displacement_scale;
  h.double_precision = config_.double_precision;
  h.step = step_, h.time = time_;
  std::string bytes(sizeof(h) + kStateFields * cells_ * real_size_, '\0');
  std::memcpy(bytes.data(), &h, sizeof(h));
  auto lock = runtime_.exclusive();
  runtime_.queue().enqueueReadBuffer(state_.buffer(), CL_TRUE, 0, kStateFields * cells_ * real_size_,
                                     bytes.data() + sizeof(h));
  return bytes;
}

namespace {

StateHeader header_of(const std::string& bytes) {
  StateHeader h{};
  if (bytes.size() < sizeof(h)) fail(Code::InvalidArgument, "state has " + std::to_string(bytes.size()) + " bytes, too few for an eWave state");
  std::memcpy(&h, bytes.data(), sizeof(h));
  if (std::memcmp(h.magic, kMagic, sizeof(kMagic)) != 0) fail(Code::InvalidArgument, "state is not an eWave state (bad magic)");
  if (h.nx < 1 || h.ny < 1 || h.nx > (int64_t(1) << 20) || h.ny > (int64_t(1) << 20))
    fail(Code::InvalidArgument, "state.grid is invalid");
  size_t want = sizeof(h) + kStateFields * size_t(h.nx) * size_t(h.ny) * (h.double_precision ? 8 : 4);
  if (bytes.size() != want)
    fail(Code::InvalidArgument, "state has " + std::to_string(bytes.size()) + " bytes, want " + std::to_string(want));
  return h;
}

}  // namespace

EWaveConfig EWaveSession::config_from_state(const std::string& bytes) {
  StateHeader h = header_of(bytes);
  EWaveConfig c;
  c.nx = h.nx, c.ny = h.ny, c.dx = h.dx, c.dy = h.dy;
  c.dispersion = DispersionKind(h.dispersion);
  c.gravity = h.gravity, c.depth = h.depth, c.capillary_length = h.capillary_length;
  c.trim = h.trim != 0, c.trim_width = h.trim_width, c.trim_alpha = h.trim_alpha;
  c.friction_time = h.friction_time, c.source_scale = h.source_scale;
  c.mask_phi = h.mask_phi != 0, c.displacement_scale = h.displacement_scale;
  c.double_precision = h.double_precision != 0;
  validate(c);
  return c;
}

void EWaveSession::restore(const std::string& bytes) {
  StateHeader h = header_of(bytes);
  if (h.nx != config_.nx || h.ny != config_.ny || (h.double_precision != 0) != config_.double_precision)
    fail(Code::InvalidArgument, "state.grid = " + std::to_string(h.nx) + " x " + std::to_string(h.ny) +
                                    (h.double_precision ? " (double)" : " (float)") + " does not match the session's " +
                                    std::to_string(config_.nx) + " x " + std::to_string(config_.ny));
  const char* fields = bytes.data() + sizeof(h);
  for (size_t c = 0; c < kStateFields * cells_; ++c) {
    double v;
    if (config_.double_precision) {
      std::memcpy(&v, fields + c * 8, 8);
    } else {
      float f;
      std::memcpy(&f, fields + c * 4, 4);
      v = f;
    }
    if (!std::isfinite(v)) fail(Code::InvalidArgument, "state field value " + std::to_string(c) + " is not finite");
  }
  EWaveConfig restored = config_from_state(bytes);
  restored.ambient_ocean = config_.ambient_ocean;  // not in the state bytes: the session keeps its own
  config_ = std::move(restored);
  coefficients_.clear();  // the dispersion may differ
  auto lock = runtime_.exclusive();
  upload_trim();
  runtime_.queue().enqueueWriteBuffer(state_.buffer(), CL_TRUE, 0, kStateFields * cells_ * real_size_, fields);
  step_ = h.step;
  time_ = h.time;
}

}  // namespace squall::ewave
