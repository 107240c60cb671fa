// EWaveSession::step: one eWave step in the order of J. Tessendorf, "Gilligan: A Prototype Framework for
// Simulating and Rendering Maritime Environments" (2017), sec. 3.7 (equation numbers are Gilligan's):
// obstruction map, ewave_prepare, R2C, ewave_propagate, C2R, ewave_finish, read-back.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <type_traits>
#include <variant>

#include "common/error.h"
#include "common/validate.h"
#include "ewave/ewave_session.h"
#include "ewave/propagator.h"
#include "runtime/host_transfer.h"

namespace squall::ewave {
namespace {

bool wants_outputs(const OutputSelection& o) { return o.displacement || o.normals; }

// The cells that can meet the shapes' bounding box, with a cell of margin and clamped to the grid.
// ewave_rasterize leaves every other cell alone (its first test), so rasterizing only these gives the
// same map.
CellBox shape_cells(const std::vector<EWaveShape>& shapes, const EWaveConfig& c) {
  double xmin = INFINITY, ymin = INFINITY, xmax = -INFINITY, ymax = -INFINITY;
  for (const auto& s : shapes) {
    xmin = std::min<double>(xmin, s.xmin), xmax = std::max<double>(xmax, s.xmax);
    ymin = std::min<double>(ymin, s.ymin), ymax = std::max<double>(ymax, s.ymax);
  }
  if (!(xmin <= xmax && ymin <= ymax)) return {};
  auto clamp_cell = [](double v, long n) { return long(std::clamp(v, 0.0, double(n))); };
  return {clamp_cell(std::floor(xmin / c.dx) - 1, c.nx), clamp_cell(std::floor(ymin / c.dy) - 1, c.ny),
          clamp_cell(std::floor(xmax / c.dx) + 2, c.nx), clamp_cell(std::floor(ymax / c.dy) + 2, c.ny)};
}

// The smallest box holding both.
CellBox cover(const CellBox& a, const CellBox& b) {
  if (a.empty()) return b;
  if (b.empty()) return a;
  return {std::min(a.i0, b.i0), std::min(a.j0, b.j0), std::max(a.i1, b.i1), std::max(a.j1, b.j1)};
}

// ewave_rasterize's tests, an upper bound: each cell of its region (the shapes' box and the `previous` one it
// resets) tests every shape's box; each point of a cell near a shape (in some shape's box) tests every shape's
// box again, and a polygon whose box holds it edge by edge.
double rasterize_tests(const std::vector<EWaveShape>& shapes, const EWaveConfig& c, const CellBox& previous) {
  const double n = double(shapes.size()), points = SQUALL_EWAVE_SUBSAMPLES * SQUALL_EWAVE_SUBSAMPLES;
  const CellBox region = cover(shape_cells(shapes, c), previous);
  double near = 0, edges = 0;
  for (const EWaveShape& s : shapes) {
    const double cells = shape_cells({s}, c).cells();
    near += cells;
    edges += cells * points * s.vertex_count;
  }
  return region.cells() * n + std::min(near, region.cells()) * points * n + edges;
}

// The cells a uniform drift moves the fields in one step (eq 68-69: departure x - U dt), reduced in double
// to within half the grid of 0: the fields are periodic, and a float (or the kernel's int) holds no more.
double cells_moved(double drift, double dt, double spacing, int64_t n) {
  return std::remainder(drift * dt / spacing, double(n));
}

// The state's type of the step kernels `k` (a StepKernels<Real>).
template <typename K>
using RealOf = typename std::decay_t<K>::RealType;

}  // namespace

Frame EWaveSession::step(const StepInputs& in, const StepGuard& guard, const OceanCall& call) {
  require_serial(guard.session_serial);
  check_whole();
  if (!guard.retry_key.empty() && guard.retry_key == retry_key_) return replay(in.outputs);
  if (guard.after_step && *guard.after_step != step_)
    fail(Code::Aborted, "after_step = " + std::to_string(*guard.after_step) + ", but the session has made " +
                            std::to_string(step_) + " steps" +
                            (*guard.after_step < step_ ? " (another caller stepped it)"
                                                       : " (after_step is past them: steps lost when it resumed from "
                                                         "a checkpoint, or another session's count)"));
  validate(in, config_, gate_);
  check_runs_on(ocean_, in);
  stage_shapes(in);
  check_rasterize_work(in);
  if (time_ + in.dt > kMaxTime)  // the state's time stays one that GetState's bytes and checkpoints can hold
    fail(Code::InvalidArgument, "inputs.dt = " + validate::number(in.dt) + " takes the session's time " +
                                    validate::number(time_) + " s past " + validate::number(kMaxTime) + " s");
  const int fields = wants_outputs(in.outputs) ? kOutputFields : kStateFields;
  const size_t nx = size_t(config_.nx), ny = size_t(config_.ny);
  const cl::Buffer coefficients = coefficients_->get(runtime_, config_, in.dt);  // on a miss with no queue held
  auto lock = runtime_.exclusive({"ewave.step", nx * ny * size_t(fields)});
  // The transforms' plans for this queue before the first command rewrites the state: a plan that cannot
  // be made (memory) leaves the session as it was.
  fft::Plan& forward =
      fft_.prepare({nx, ny, kStateFields, fft::Transform::R2C, precision()}, fft::Direction::Forward, false);
  fft::Plan& inverse =
      fft_.prepare({nx, ny, size_t(fields), fft::Transform::C2R, precision()}, fft::Direction::Inverse, false);
  upload_maps(in);
  const bool has_obstruction = build_obstruction(in);
  const cl::Buffer* ambient_height = ambient(in, has_obstruction, call);  // may refuse or stop: the fields are whole
  Frame frame;
  try {
    prepare(in, has_obstruction, ambient_height);  // §3.7 steps 1-3 and the sources of step 4
    forward.enqueue(runtime_.queue(), fft::Direction::Forward, state_.buffer(), spectrum_.buffer());  // eq 62-63
    propagate(coefficients, fields);                                                                  // eq 64-65
    inverse.enqueue(runtime_.queue(), fft::Direction::Inverse, spectrum_.buffer(), work_.buffer());   // eq 66-67
    finish(in, fields, has_obstruction);  // eq 68-69, §3.7 steps 5-7
    frame = read_frame(in.outputs);       // waits for the queue: the host vectors of the inputs are free after it
    forward.check_ran();
    inverse.check_ran();
  } catch (const std::exception& e) {
    broken_ = "step " + std::to_string(step_ + 1) + " failed partway: " + e.what();
    throw;
  }
  ++step_;
  time_ += in.dt;
  if (fields == kOutputFields) outputs_step_ = step_;
  retry_key_ = guard.retry_key;
  frame.step = step_;
  frame.time = time_;
  return frame;
}

void EWaveSession::stage_shapes(const StepInputs& in) {
  vertex_staging_.clear();
  shape_staging_ = device_shapes(in.shapes, &vertex_staging_);
  if (vertex_staging_.empty()) vertex_staging_.assign(2, 0.0f);  // a buffer of no bytes cannot be made
}

// A step whose shapes would hold the device too long is refused before anything of it is done.
void EWaveSession::check_rasterize_work(const StepInputs& in) const {
  if (in.shapes.empty()) return;
  const bool resets = in.obstruction.empty() && shape_map_;  // build_obstruction()'s rasterize(true)
  const double tests = rasterize_tests(shape_staging_, config_, resets ? shape_map_cells_ : CellBox{});
  if (tests > kMaxRasterizeTests)
    fail(Code::ResourceExhausted,
         "inputs.shapes make an estimated " + validate::number(tests) +
             " point-in-shape tests (the cells of their boxes x " +
             std::to_string(SQUALL_EWAVE_SUBSAMPLES * SQUALL_EWAVE_SUBSAMPLES) +
             " points x the shapes and polygon vertices), more than the " + validate::number(kMaxRasterizeTests) +
             " one step may make: send fewer polygon vertices, or the obstruction as inputs.obstruction");
}

// The step's maps, before its first command: on a CPU device they are copied into their buffers' host
// storage with no command, and the queue they finish first is empty (write_buffer()).
void EWaveSession::upload_maps(const StepInputs& in) {
  if (!in.obstruction.empty()) {
    shape_map_ = false;  // before the map is overwritten: a later upload that throws leaves no stale shape map
    upload(obstruction_, in.obstruction);
  }
  if (!in.ambient_height.empty()) upload(ambient_, in.ambient_height);
  if (!in.source_height.empty()) upload(source_h_, in.source_height);
  if (!in.source_phi.empty()) upload(source_phi_, in.source_phi);
  if (!in.drift_field_x.empty()) upload(drift_x_, in.drift_field_x), upload(drift_y_, in.drift_field_y);
}

// O = (the obstruction field, or 1) times the uncovered fraction of the shapes. False when neither is given.
// A map of shapes alone is filled with 1 once; later steps rewrite only the cells around the last shapes
// and the new ones.
bool EWaveSession::build_obstruction(const StepInputs& in) {
  if (in.obstruction.empty() && in.shapes.empty()) return false;
  if (!in.obstruction.empty()) {  // upload_maps() has uploaded it
    if (!in.shapes.empty()) rasterize(false);
    return true;
  }
  if (obstruction_.bytes() != cells_ * sizeof(float)) {
    obstruction_ = runtime_.buffers().acquire(cells_ * sizeof(float));
    shape_map_ = false;
  }
  if (!shape_map_) {
    runtime_.queue().enqueueFillBuffer(obstruction_.buffer(), cl_float(1.0f), 0, cells_ * sizeof(float));
    shape_map_cells_ = {};
  }
  rasterize(true);
  shape_map_ = true;
  return true;
}

void EWaveSession::rasterize(bool reset) {
  // The staging is kept in members until the next step: a write command (on a GPU) is not waited for; the
  // read-back is.
  const std::vector<EWaveShape>& device = shape_staging_;
  size_t shape_bytes = device.size() * sizeof(EWaveShape);
  if (shapes_.bytes() != shape_bytes) shapes_ = runtime_.buffers().acquire(shape_bytes);
  write_buffer(runtime_, shapes_.buffer(), shape_bytes, device.data());
  upload(vertices_, vertex_staging_);
  const CellBox cells = shape_cells(device, config_);
  const CellBox box = reset ? cover(cells, shape_map_cells_) : cells;
  if (!box.empty())
    rasterize_.launch_region(cl::NDRange(box.i0, box.j0), cl::NDRange(box.i1 - box.i0, box.j1 - box.j0), cl::NullRange,
                             obstruction_.buffer(), shapes_.buffer(), cl_int(device.size()), vertices_.buffer(),
                             cl_int(config_.nx), cl_int(config_.ny), cl_float(config_.dx), cl_float(config_.dy),
                             cl_int(reset ? 1 : 0));
  if (reset) shape_map_cells_ = cells;
}

void EWaveSession::prepare(const StepInputs& in, bool has_obstruction, const cl::Buffer* ambient_height) {
  const cl::Buffer& none = absent_map_.buffer();
  auto optional = [&](const BufferLease& lease, const std::vector<float>& values) -> const cl::Buffer& {
    return values.empty() ? none : lease.buffer();  // upload_maps() has uploaded it
  };
  double decay = 1, gain = in.dt;   // eq 60-61
  if (config_.friction_time > 0) {  // eq 72-73
    decay = std::exp(-in.dt / config_.friction_time);
    gain = -config_.friction_time * std::expm1(-in.dt / config_.friction_time);
  }
  const cl::Buffer& obstruction = has_obstruction ? obstruction_.buffer() : none;
  const cl::Buffer& source_h = optional(source_h_, in.source_height);
  const cl::Buffer& source_phi = optional(source_phi_, in.source_phi);
  std::visit(
      [&](auto& k) {
        using Real = RealOf<decltype(k)>;
        k.prepare.launch_rows(config_.nx, config_.ny, state_.buffer(), cl_int(config_.nx), cl_int(config_.ny),
                              obstruction, cl_int(has_obstruction), ambient_height ? *ambient_height : none,
                              cl_int(ambient_height != nullptr), trim_x_.buffer(), trim_y_.buffer(),
                              cl_int(config_.trim), source_h, cl_int(!in.source_height.empty()), source_phi,
                              cl_int(!in.source_phi.empty()), Real(config_.source_scale), Real(decay), Real(gain));
      },
      kernels_);
}

void EWaveSession::propagate(const cl::Buffer& coefficients, int fields) {
  std::visit(
      [&](auto& k) {
        using Real = RealOf<decltype(k)>;
        k.propagate.launch_rows(size_t(config_.nx) / 2 + 1, config_.ny, spectrum_.buffer(), coefficients,
                                cl_int(config_.nx), cl_int(config_.ny), Real(2 * std::numbers::pi / config_.length_x()),
                                Real(2 * std::numbers::pi / config_.length_y()), cl_int(fields));
      },
      kernels_);
}

void EWaveSession::finish(const StepInputs& in, int fields, bool has_obstruction) {
  const cl::Buffer& none = absent_map_.buffer();
  bool field_drift = !in.drift_field_x.empty();
  bool uniform_drift = !field_drift && (in.drift_x != 0 || in.drift_y != 0);
  const cl_int drift_mode = field_drift ? 2 : uniform_drift ? 1 : 0;
  const cl::Buffer& drift_x = field_drift ? drift_x_.buffer() : none;  // upload_maps() has uploaded both
  const cl::Buffer& drift_y = field_drift ? drift_y_.buffer() : none;
  const cl::Buffer& obstruction = has_obstruction ? obstruction_.buffer() : none;
  std::visit(
      [&](auto& k) {
        using Real = RealOf<decltype(k)>;
        auto& kernel = drift_mode == 0 ? k.finish : k.finish_advect;
        kernel.launch_rows(
            config_.nx, config_.ny, work_.buffer(), cl_int(fields), state_.buffer(), out_.buffer(), cl_int(config_.nx),
            cl_int(config_.ny), drift_mode, Real(cells_moved(in.drift_x, in.dt, config_.dx, config_.nx)),
            Real(cells_moved(in.drift_y, in.dt, config_.dy, config_.ny)), drift_x, drift_y, Real(in.dt / config_.dx),
            Real(in.dt / config_.dy), obstruction, cl_int(has_obstruction), cl_int(config_.mask_phi), trim_x_.buffer(),
            trim_y_.buffer(), cl_int(config_.trim), Real(config_.displacement_scale));
      },
      kernels_);
}

const cl::Buffer* EWaveSession::ambient(const StepInputs& in, bool has_obstruction, const OceanCall& call) {
  if (!in.ambient_height.empty()) return &ambient_.buffer();  // upload_maps() has uploaded it
  const std::optional<ocean::TileSpec>& spec = in.ambient_ocean ? in.ambient_ocean : config_.ambient_ocean;
  if (!spec || !has_obstruction) return nullptr;  // h_A (1 - O) = 0 without an obstruction: skip the ocean
  const std::string field = in.ambient_ocean ? "inputs.ambient_ocean" : "config.ambient_ocean";
  ocean::OceanEngine& ocean = ocean_engine(field);       // the config's layers checked at creation, the inputs' above
  size_t bytes = kStateFields * cells_ * sizeof(float);  // h_A, then the unused phi_A plane
  if (ambient_.bytes() != bytes) ambient_ = runtime_.buffers().acquire(bytes);
  ocean.surface_on_device(ocean_on_grid(*spec, config_), time_, ambient_.buffer(), call.cancel, call.spectra_memory);
  return &ambient_.buffer();
}

Frame EWaveSession::read_frame(const OutputSelection& o) const {
  Frame f;
  std::vector<double> height, phi;  // a double-precision state, converted after the wait
  ReadBack back(runtime_);          // after what it reads into: on a throw it waits before they go
  auto read = [&](const cl::Buffer& buffer, size_t offset, size_t count, std::vector<float>& into) {
    into.resize(count);
    back.add(buffer, offset * sizeof(float), count * sizeof(float), into.data());
  };
  auto read_state = [&](size_t offset, std::vector<float>& into, std::vector<double>& values) {
    if (!config_.double_precision) return read(state_.buffer(), offset, cells_, into);
    values.resize(cells_);
    back.add(state_.buffer(), offset * sizeof(double), cells_ * sizeof(double), values.data());
  };
  if (o.height) read_state(0, f.height, height);
  if (o.phi) read_state(cells_, f.phi, phi);
  if (o.displacement) {
    read(out_.buffer(), 0, cells_, f.displacement_x);
    read(out_.buffer(), cells_, cells_, f.displacement_y);
  }
  if (o.normals) read(out_.buffer(), 2 * cells_, 3 * cells_, f.normals);
  back.wait();
  if (!height.empty()) f.height.assign(height.begin(), height.end());
  if (!phi.empty()) f.phi.assign(phi.begin(), phi.end());
  return f;
}

Frame EWaveSession::replay(const OutputSelection& outputs) const {
  if (wants_outputs(outputs) && outputs_step_ != step_)
    fail(Code::FailedPrecondition,
         "retry_key is that of step " + std::to_string(step_) +
             ", made already (its reply was lost), whose displacement and normals the session no "
             "longer holds: ask for height and phi alone, or step on with a new key");
  Frame frame;
  {
    auto lock = runtime_.exclusive();
    frame = read_frame(outputs);
  }
  frame.step = step_;
  frame.time = time_;
  return frame;
}

SurfaceCurrent EWaveSession::surface_current() const {
  check_whole();
  Frame potential;
  {
    auto lock = runtime_.exclusive();
    potential = read_frame(OutputSelection{false, false, false, true});
  }
  SurfaceCurrent current;
  current.nx = config_.nx;
  current.ny = config_.ny;
  current.origin_x = 0.5 * config_.dx;
  current.origin_y = 0.5 * config_.dy;
  current.dx = config_.dx;
  current.dy = config_.dy;
  current.time = time_;
  periodic_gradient(potential.phi, current);
  return current;
}

}  // namespace squall::ewave
