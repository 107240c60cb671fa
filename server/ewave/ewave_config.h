// eWave session configuration and per-step inputs and outputs, with their validation (J. Tessendorf,
// "Gilligan: A Prototype Framework for Simulating and Rendering Maritime Environments" (2017), sec. 3, and
// its App. B, J. Tessendorf, "eWave: Using an Exponential Solver on the iWave Problem" (2014); equation
// numbers are Gilligan's). Units SI; the grid frame puts cell (i, j) at ((i + 0.5) dx, (j + 0.5) dy), x fastest.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/cancel.h"
#include "ocean/ocean_params.h"

namespace squall {
class LimitGate;
class Slot;
}  // namespace squall

namespace squall::ewave {

enum class DispersionKind { Deep = 0, Shallow = 1, Capillary = 2, Combined = 3 };  // = SQUALL_DISPERSION_*

struct EWaveConfig {
  int64_t nx = 0, ny = 0;  // cells, 2 .. 2^30 each (and within --max-grid-cells)
  double dx = 0, dy = 0;   // m, > 0
  DispersionKind dispersion = DispersionKind::Deep;
  double gravity = 9.81;              // m/s^2, > 0
  double depth = 0;                   // m, > 0 for shallow and combined dispersion
  double capillary_length = 0;        // m, >= 0 (capillary and combined)
  bool trim = true;                   // the power-law taper of eq 82 at the four edges
  double trim_width = 0;              // m, L of eq 82; 0 = 8% of the shorter side; at most half the shorter side
  double trim_alpha = 0.05;           // exponent alpha of eq 82, in (0, 10]
  double friction_time = 0;           // s, tau of eq 72-73; 0 = no friction
  double source_scale = 0;            // m/s, S0 of eq 75 (obstruction as a height source)
  bool mask_phi = false;              // also multiply phi by O (Gilligan eq 74 masks h only)
  bool double_precision = false;      // h, phi and the FFTs in double (needs fp64): the float FFTs of the backends
                                      // lose ~1e-7 of the energy per step (see tests/ewave), double ~1e-15
  double displacement_scale = 1;      // lambda: D = lambda FFT^-1(i k/k h~) (the ocean's sign) and in eq 94
  std::vector<float> initial_height;  // m, nx*ny values or empty (zero)
  std::vector<float> initial_phi;     // m^2/s, nx*ny values or empty (zero)
  double start_time = 0;              // s, finite: the session's simulation time before its first step
  // Ocean specs (ocean_params.h), evaluated by the ocean engine on the session grid: output grid nx x ny
  // covering nx dx x ny dy, ocean sample (i, j) (at x = i dx, y = j dy of the ocean's frame) -> cell (i, j),
  // i.e. the ocean's origin sits at the centre of cell (0, 0). The spec's own output grid must be 0 or
  // equal to that. Messages name "config.ambient_ocean.layers[0].wind_speed" etc.
  // initial_ocean: h and phi at start_time from the ocean surface, phi~ = -i (G/w)[h0 e^{-iwt} -
  // conj(h0(-k)) e^{iwt}], G = g (1 + (k l)^2) (the linear potential that eWave's propagator continues
  // exactly when the layer's dispersion, gravity and capillary length are the session's and its drift is 0).
  // Exclusive with initial_height / initial_phi.
  std::optional<ocean::TileSpec> initial_ocean;
  // ambient_ocean: h_A of eq 77 for every step that brings no ambient of its own, evaluated at the session
  // time at the start of the step (when eq 77 is applied). Not part of GetState's bytes; the engine's
  // checkpoints (EWaveEngine::checkpoint, --state-dir) carry it.
  std::optional<ocean::TileSpec> ambient_ocean;

  size_t cells() const { return size_t(nx) * size_t(ny); }
  double length_x() const { return double(nx) * dx; }
  double length_y() const { return double(ny) * dy; }
  double effective_trim_width() const;  // trim_width, or its default
};

// The grid's extents, 2 .. 2^30 points an axis (an FFT needs 2), named "<path>.nx"; with a gate, also
// within --max-grid-cells (RESOURCE_EXHAUSTED).
void validate_grid(int64_t nx, int64_t ny, const LimitGate* gate, const std::string& path);

// Throws Error(InvalidArgument) naming the field under `path`, e.g. "config.dx = nan must be finite and
// > 0". With a gate, the grid is also checked against --max-grid-cells (RESOURCE_EXHAUSTED).
void validate(const EWaveConfig& config, const LimitGate* gate = nullptr, const std::string& path = "config");

// An ocean spec with its output grid set to the session grid of `config` (see EWaveConfig::ambient_ocean).
ocean::TileSpec ocean_on_grid(const ocean::TileSpec& spec, const EWaveConfig& config);
// Validates an ocean spec for the session grid; messages are prefixed with `field` + ".".
void validate_ocean(const std::string& field, const ocean::TileSpec& spec, const EWaveConfig& config,
                    const LimitGate* gate = nullptr);

enum class ShapeKind { Circle, Ellipse, Box, Polygon };

// An obstruction shape placed for one step (grid frame, metres).
struct Shape {
  ShapeKind kind = ShapeKind::Circle;
  double x = 0, y = 0;                          // centre (circle, ellipse, box)
  double a = 0, b = 0;                          // circle: a = radius; ellipse: semi-axes; box: half-lengths; > 0
  double heading = 0;                           // rad, direction of the a axis from +x
  std::vector<std::array<double, 2>> vertices;  // polygon: >= 3 vertices, metres
};

struct OutputSelection {
  bool height = true;         // h after the step (m)
  bool displacement = false;  // D_x, D_y (m), eq 47 with the ocean's sign
  bool normals = false;       // unit normals (eq 90/94), interleaved x, y, z
  bool phi = false;           // velocity potential (m^2/s)
};

struct StepInputs {
  double dt = 0;                      // s, finite and > 0
  std::vector<float> obstruction;     // O in [0, 1], nx*ny or empty (1 everywhere)
  std::vector<Shape> shapes;          // rasterized into O (multiplied) with fractional edge coverage
  std::vector<float> ambient_height;  // h_A (m), nx*ny or empty
  // h_A from an ocean spec (see EWaveConfig::ambient_ocean), at the session time at the start of this
  // step; exclusive with ambient_height. A step with neither uses the config's ambient_ocean, if any.
  std::optional<ocean::TileSpec> ambient_ocean;
  std::vector<float> source_height;  // S_h (m/s), nx*ny or empty
  std::vector<float> source_phi;     // S_phi (m^2/s^2), nx*ny or empty
  double drift_x = 0, drift_y = 0;   // uniform drift current U_D (m/s), used when no drift field is given
  std::vector<float> drift_field_x;  // U_D,x per cell (m/s), nx*ny or empty (both or neither)
  std::vector<float> drift_field_y;
  OutputSelection outputs;
};

// What makes a step safe to send again (EWaveStepRequest.retry_key and after_step).
struct StepGuard {
  std::string retry_key;               // the caller's key for this step, at most kMaxRetryKeyBytes; empty: none
  std::optional<uint64_t> after_step;  // the step count the session must be at; none: no check
  // The serial of the session the caller read the config of (EWaveEngine::view), to validate the step's
  // inputs and size its frame; 0: no check.
  uint64_t session_serial = 0;
};
constexpr size_t kMaxRetryKeyBytes = 64;

// What a call lends the ocean its step (an ambient ocean) or a session's creation (its initial ocean)
// evaluates: its cancellation, looked at while the ocean's spectra are built (Error(Cancelled) then, the
// session as it was, or not made), and its reservation of those spectra, from which a spectrum kept takes
// its bytes (OceanEngine::tile's spectra_memory); none: the budget is asked.
struct OceanCall {
  Cancellation cancel;
  Slot* spectra_memory = nullptr;
};

// The longest step, s: kMaxDt, or with the trim on the period of the grid's shortest wave when shorter
// (shortest_wave_period in propagator.h: longer trimmed steps grow without bound).
constexpr double kMaxDt = 1e4;
double max_dt(const EWaveConfig& config);

// Throws Error(InvalidArgument) naming the field (e.g. "inputs.obstruction has 10 values, want 4096"); an
// ambient ocean's layers are checked against `gate`'s --max-grid-cells (RESOURCE_EXHAUSTED), or the
// default limits without one.
void validate(const StepInputs& inputs, const EWaveConfig& config, const LimitGate* gate = nullptr);

struct Frame {
  uint64_t step = 0;  // steps done so far (1 after the first step)
  double time = 0;    // s, simulation time after this step
  std::vector<float> height, displacement_x, displacement_y, normals, phi;  // as selected; empty otherwise
};

// A session's time and config.start_time: within +-kMaxTime s (a SimTime's range).
constexpr double kMaxTime = 1e9;
constexpr size_t kMaxShapes = 1024;
constexpr size_t kMaxShapeVertices = 65536;
// Point-in-shape tests one step's rasterization may make (ewave_rasterize runs to its end once started): about
// 0.8 s on two CPU cores. A coastline of many vertices over a large grid belongs in inputs.obstruction.
constexpr double kMaxRasterizeTests = 4e9;

}  // namespace squall::ewave
