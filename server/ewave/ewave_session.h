// One eWave simulation: h and phi on the device, stepped in the order of J. Tessendorf, "Gilligan: A
// Prototype Framework for Simulating and Rendering Maritime Environments" (2017), sec. 3.7, with cached FFT
// plans and propagator tables. Not thread-safe by itself: EWaveEngine serializes calls per session.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/surface_current.h"
#include "ewave/coefficient_cache.h"
#include "ewave/ewave_config.h"
#include "ewave/ewave_state_format.h"
#include "ewave/shapes.h"
#include "ewave/step_kernels.h"
#include "fft/fft.h"
#include "ocean/ocean_engine.h"
#include "runtime/runtime.h"

namespace squall::ewave {

// The cells [i0, i1) x [j0, j1) of a grid.
struct CellBox {
  long i0 = 0, j0 = 0, i1 = 0, j1 = 0;
  bool empty() const { return i1 <= i0 || j1 <= j0; }
  double cells() const { return empty() ? 0 : double(i1 - i0) * double(j1 - j0); }
};

class EWaveSession {
 public:
  // Validates the config (Error InvalidArgument naming the field) and uploads the initial fields.
  // `ocean` evaluates the config's and the steps' ocean specs (initial_ocean, ambient_ocean); without it
  // such specs give Error(FailedPrecondition). It must outlive the session and share the runtime.
  // `gate` holds the daemon's limits (--max-grid-cells) that the ocean specs' layers are checked against;
  // null: the default limits. `coefficients` holds the propagator tables the session shares with others;
  // null: a cache of the session's own. Both must outlive the session. `call`: what the creating call lends
  // the initial ocean's evaluation.
  EWaveSession(Runtime& runtime, fft::Fft& fft, const EWaveConfig& config, ocean::OceanEngine* ocean = nullptr,
               const LimitGate* gate = nullptr, CoefficientCache* coefficients = nullptr, const OceanCall& call = {});

  const EWaveConfig& config() const { return config_; }
  // A number no other session of this process has had: it tells a session from one made later under its id.
  uint64_t serial() const { return serial_; }
  // Error(Aborted) unless `serial` is 0 or this session's: the id names a session made after the caller's
  // read of it (closed and made again under the same id, or resumed from its checkpoint: a session moved
  // away and back), whose config the caller may not have seen.
  void require_serial(uint64_t serial) const;
  uint64_t step_index() const { return step_; }
  double time() const { return time_; }

  // One step of inputs.dt (validated first; the session is unchanged when they are rejected). A step that
  // fails once it has begun to change the fields leaves the session broken: this and state() then answer
  // FAILED_PRECONDITION until restore().
  // A guard whose retry_key is the last step's returns that step's frame again and steps nothing; one whose
  // after_step is not the step count gives Error(Aborted) naming "after_step", as does one whose session
  // serial is not this session's (require_serial).
  Frame step(const StepInputs& inputs, const StepGuard& guard = {}, const OceanCall& call = {});
  // The retry_key the last step was made with (empty: none), kept in checkpoints so that a retry finds it
  // on the replica the session moves to.
  const std::string& retry_key() const { return retry_key_; }
  void set_retry_key(std::string key) { retry_key_ = std::move(key); }
  // The surface current u = grad phi at the session time on the cells (nodes at ((i + 0.5) dx, (j + 0.5)
  // dy)), by central differences, periodic like the FFT propagation.
  SurfaceCurrent surface_current() const;

  // The whole session (config without initial fields, step, time, h, phi) as bytes. A session made with
  // config_from_state() of those bytes, then restore() of them, continues bit-identically.
  std::string state() const;
  // The bytes' step, time, h, phi and config, into a session of the same grid, which keeps the ambient
  // ocean it was made with (an ocean engine evaluates it).
  void restore(const std::string& bytes);
  // Bytes of the device buffers the session holds now: its state, spectra, work and output planes, trim
  // profiles, and the maps its steps have uploaded (the shapes' small arrays aside). session_bytes() of
  // its config budgets for them all.
  uint64_t device_bytes() const;
  // A config from state bytes (for a new session), with their ambient ocean validated against `gate`;
  // throws InvalidArgument when the bytes are not a state (naming "state.ambient_ocean..." for its spec).
  static EWaveConfig config_from_state(const std::string& bytes, const LimitGate& gate);
  // What a valid config needs of where it runs: fp64 for double precision, and grid and ocean layer lengths
  // that the FFT backend transforms (clFFT's are products of 2, 3, 5, 7, 11 and 13). INVALID_ARGUMENT naming
  // the field under `path` ("config", "state"). The oceans are not checked without `ocean`.
  static void check_runs_on(const Runtime& runtime, const fft::Fft& fft, const ocean::OceanEngine* ocean,
                            const EWaveConfig& config, const std::string& path);
  // The same for a step's inputs: its ambient ocean's layers (named "inputs.ambient_ocean...").
  static void check_runs_on(const ocean::OceanEngine* ocean, const StepInputs& inputs);

 private:
  void upload_initial_fields(const OceanCall& call);  // config_'s h, phi or initial_ocean into state_ (under the lock)
  // `values` into the state from plane h (0) or phi (1) on, as many as there are (none: left as it is).
  void write_state(size_t plane, const std::vector<float>& values);
  void upload_trim();                              // the trim profiles of config_ (eq 82)
  void initial_from_ocean(const OceanCall& call);  // h, phi of config_.initial_ocean at time_ (under the lock)
  // h_A of a step: its field, else its or the config's ocean spec at time_ (the ocean engine writes it into
  // ambient_ on the device, no host round trip); null when the step has no ambient (or no obstruction, where
  // h_A (1 - O) = 0 and the ocean is not evaluated).
  const cl::Buffer* ambient(const StepInputs& inputs, bool has_obstruction, const OceanCall& call);
  ocean::OceanEngine& ocean_engine(const std::string& field) const;
  const cl::Buffer& upload(BufferLease& lease, const std::vector<float>& values);
  // The step pipeline (ewave_step.cpp), in the order of step().
  void upload_maps(const StepInputs& inputs);  // uploads those of the obstruction, ambient, source and drift maps given
  bool build_obstruction(const StepInputs& inputs);
  // The step's shapes in the device's layout, into shape_staging_ and vertex_staging_, before its first
  // command (the last step's uploads from them have run: its read-back waited for its queue).
  void stage_shapes(const StepInputs& in);
  // RESOURCE_EXHAUSTED naming inputs.shapes when rasterizing the staged shapes would pass kMaxRasterizeTests.
  void check_rasterize_work(const StepInputs& in) const;
  // O *= the uncovered fraction of the staged shapes around them; reset: O = that fraction there, and 1
  // again in the cells the last reset covered (shape_map_cells_).
  void rasterize(bool reset);
  // The first command of a step that changes the fields; ambient_height: ambient()'s.
  void prepare(const StepInputs& inputs, bool has_obstruction, const cl::Buffer* ambient_height);
  void propagate(const cl::Buffer& coefficients, int fields);  // the table of the step's dt
  void finish(const StepInputs& inputs, int fields, bool has_obstruction);
  Frame read_frame(const OutputSelection& outputs) const;
  // The frame of the last step read again (a retry of it): Error(FailedPrecondition) when it asks for the
  // displacement or normals and out_ no longer holds that step's.
  Frame replay(const OutputSelection& outputs) const;
  void check_same_grid(const StateHeader& header) const;  // restore(): InvalidArgument unless it is ours
  void check_whole() const;                               // FailedPrecondition once broken_
  fft::Precision precision() const { return config_.double_precision ? fft::Precision::F64 : fft::Precision::F32; }

  Runtime& runtime_;
  fft::Fft& fft_;
  ocean::OceanEngine* ocean_;
  const LimitGate* gate_;
  EWaveConfig config_;
  const uint64_t serial_;
  size_t cells_, half_;  // nx ny real cells; (nx/2+1) ny spectrum modes
  size_t real_size_;     // bytes of one state value: 4 (float) or 8 (double)
  uint64_t step_ = 0;
  double time_ = 0;
  std::optional<uint64_t> outputs_step_;  // the step whose displacement and normals out_ holds
  std::string retry_key_;                 // the last step's StepGuard::retry_key
  // Why a step failed after it began to change the fields (a device error, no memory for the frame); empty
  // while they are whole. The fields are then neither the step's nor the one before: the session answers
  // FAILED_PRECONDITION (check_whole()) until restore() gives it whole fields again.
  std::string broken_;
  AnyStepKernels kernels_;  // of the state's precision
  RasterizeKernel rasterize_;
  BufferLease state_, spectrum_, work_, out_, trim_x_, trim_y_;
  // Passed for every optional map a step does not give (its has_* flag 0): zeros, one float a cell, each
  // page written once. The kernels' masked loads name every cell's address of it; on a CPU device a
  // masked-out lane on a page not mapped or not yet touched costs a microcode assist per load.
  BufferLease absent_map_;
  BufferLease obstruction_, ambient_, source_h_, source_phi_, drift_x_, drift_y_, shapes_, vertices_;
  // obstruction_ holds a map of shapes alone: 1 outside shape_map_cells_ (the last shapes' cells), so the
  // next one rewrites those and its own cells, not the grid.
  bool shape_map_ = false;
  CellBox shape_map_cells_;
  std::vector<EWaveShape> shape_staging_;  // the host side of the shapes' and vertices' uploads (stage_shapes())
  std::vector<float> vertex_staging_;
  std::unique_ptr<CoefficientCache> own_coefficients_;  // when the session was given none
  CoefficientCache* coefficients_;
};

}  // namespace squall::ewave
