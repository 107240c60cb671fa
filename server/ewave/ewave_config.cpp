#include "ewave/ewave_config.h"

#include <algorithm>
#include <cmath>

#include "common/error.h"
#include "common/limits.h"
#include "common/validate.h"
#include "ewave/propagator.h"
#include "ocean/spectrum_setup.h"

namespace squall::ewave {
namespace {

using validate::finite;
using validate::non_negative;
using validate::positive;

// Bounds that keep every intermediate of a step finite in single precision (float32 overflows at 3.4e38):
// field values (m, m/s, m^2/s), speeds (m/s), lengths (m), times (s).
const validate::Interval kMapValues = validate::closed(-1e6, 1e6);
const validate::Interval kLengths = validate::closed(1e-6, 1e6);
constexpr double kMaxSpeed = 1e3, kMaxScale = 1e6;

// A per-cell map: empty, or exactly `cells` finite values (within `range`).
void check_map(const std::string& field, const std::vector<float>& map, size_t cells,
               const validate::Interval& range = kMapValues) {
  if (map.empty()) return;
  validate::count(field, map.size(), cells, "nx * ny");
  validate::each(field, map.data(), map.size(), range);
}

void check_shape(const std::string& field, const Shape& s) {
  if (s.kind == ShapeKind::Polygon) {
    if (s.vertices.size() < 3)
      fail(Code::InvalidArgument, field + ".vertices has " + std::to_string(s.vertices.size()) + ", want >= 3");
    for (size_t v = 0; v < s.vertices.size(); ++v) {
      finite(validate::at(field + ".vertices", v) + ".x", s.vertices[v][0]);
      finite(validate::at(field + ".vertices", v) + ".y", s.vertices[v][1]);
    }
    return;
  }
  finite(field + ".x", s.x);
  finite(field + ".y", s.y);
  positive(field + ".a", s.a);
  if (s.kind != ShapeKind::Circle) positive(field + ".b", s.b);
  finite(field + ".heading", s.heading);
}

}  // namespace

double EWaveConfig::effective_trim_width() const {
  return trim_width > 0 ? trim_width : 0.08 * std::min(length_x(), length_y());
}

void validate_grid(int64_t nx, int64_t ny, const LimitGate* gate, const std::string& path) {
  validate::in(path + ".nx", nx, 2, int64_t(1) << 30);  // an FFT needs 2 points per axis
  validate::in(path + ".ny", ny, 2, int64_t(1) << 30);
  if (gate) gate->check_grid(path, nx, ny);
}

void validate(const EWaveConfig& c, const LimitGate* gate, const std::string& path) {
  validate_grid(c.nx, c.ny, gate, path);
  validate::in(path + ".dx", c.dx, kLengths);
  validate::in(path + ".dy", c.dy, kLengths);
  validate::known(path + ".dispersion", int(c.dispersion), 4, "dispersion model (deep, shallow, capillary, combined)");
  positive(path + ".gravity", c.gravity, 1e3);
  if (c.dispersion == DispersionKind::Shallow || c.dispersion == DispersionKind::Combined)
    positive(path + ".depth", c.depth, 1e5);
  else
    non_negative(path + ".depth", c.depth, 1e5);
  non_negative(path + ".capillary_length", c.capillary_length, 1);
  non_negative(path + ".trim_width", c.trim_width);
  double half = 0.5 * std::min(c.length_x(), c.length_y());
  if (c.effective_trim_width() > half)
    validate::reject(path + ".trim_width", c.effective_trim_width(),
                     "<= half the shorter side (" + validate::number(half) + " m)");
  positive(path + ".trim_alpha", c.trim_alpha, 10);
  non_negative(path + ".friction_time", c.friction_time, kMaxTime);
  validate::in(path + ".source_scale", c.source_scale, validate::closed(-kMaxScale, kMaxScale));
  validate::in(path + ".displacement_scale", c.displacement_scale, validate::closed(-kMaxScale, kMaxScale));
  check_map(path + ".initial_height", c.initial_height, c.cells());
  check_map(path + ".initial_phi", c.initial_phi, c.cells());
  validate::in(path + ".start_time.seconds", c.start_time, validate::closed(-kMaxTime, kMaxTime));
  if (c.initial_ocean) {
    if (!c.initial_height.empty() || !c.initial_phi.empty())
      fail(Code::InvalidArgument,
           path + ".initial_ocean excludes " + path + ".initial_height and " + path + ".initial_phi");
    validate_ocean(path + ".initial_ocean", *c.initial_ocean, c, gate);
  }
  if (c.ambient_ocean) validate_ocean(path + ".ambient_ocean", *c.ambient_ocean, c, gate);
}

ocean::TileSpec ocean_on_grid(const ocean::TileSpec& spec, const EWaveConfig& c) {
  ocean::TileSpec on = spec;
  on.nx = c.nx, on.ny = c.ny, on.lx = c.length_x(), on.ly = c.length_y();
  return on;
}

void validate_ocean(const std::string& field, const ocean::TileSpec& spec, const EWaveConfig& c,
                    const LimitGate* gate) {
  auto differs = [](double a, double b) { return a != 0 && std::abs(a - b) > 1e-9 * std::abs(b); };
  if (differs(double(spec.nx), double(c.nx)) || differs(double(spec.ny), double(c.ny)))
    fail(Code::InvalidArgument, field + ".output = " + std::to_string(spec.nx) + " x " + std::to_string(spec.ny) +
                                    " must be unset or the session grid " + std::to_string(c.nx) + " x " +
                                    std::to_string(c.ny));
  if (differs(spec.lx, c.length_x()) || differs(spec.ly, c.length_y()))
    fail(Code::InvalidArgument, field + ".output extent = " + validate::number(spec.lx) + " x " +
                                    validate::number(spec.ly) + " m must be unset or the session's nx dx x ny dy = " +
                                    validate::number(c.length_x()) + " x " + validate::number(c.length_y()) + " m");
  LimitGate fallback{Limits{}};
  ocean::validate_tile(ocean_on_grid(spec, c), gate ? *gate : fallback, field);
}

// A drift field's departure point, u dt / dx cells back, is taken in float on the device: at most 2^22 cells,
// where float holds it to a quarter of a cell (at 1e10 cells it sampled cells 1024 apart). A uniform drift
// is reduced modulo the grid in double instead, and may move any distance.
void check_drift_reach(const std::string& field, const std::vector<float>& drift, double dt_over_d) {
  double cells = 0;
  for (float u : drift) cells = std::max(cells, std::abs(double(u)) * dt_over_d);
  if (cells > 0x1p22)
    fail(Code::InvalidArgument, field + " moves a cell up to " + validate::number(cells) +
                                    " cells in a step (speed x inputs.dt / spacing), past 2^22 = 4194304, which "
                                    "float32 places to a quarter cell: take shorter steps, or a uniform drift");
}

// fmin: a period past kMaxDt (weak gravity) or infinite (a depth of 1e-300 in shallow water) is kMaxDt. The
// trim and mask_phi both multiply phi in real space, which a longer step turns into growing waves.
double max_dt(const EWaveConfig& c) {
  return c.trim || c.mask_phi ? std::fmin(shortest_wave_period(c), kMaxDt) : kMaxDt;
}

void validate(const StepInputs& in, const EWaveConfig& c, const LimitGate* gate) {
  positive("inputs.dt", in.dt, kMaxDt);
  const double longest = max_dt(c);
  if (in.dt > longest)
    fail(Code::InvalidArgument, "inputs.dt = " + validate::number_apart(in.dt, longest) +
                                    " s is longer than the period of the grid's shortest wave, " +
                                    validate::number(longest) +
                                    " s: with config.trim or config.mask_phi on, longer steps grow without bound; "
                                    "take shorter steps or turn them off");
  size_t cells = c.cells();
  check_map("inputs.obstruction", in.obstruction, cells, validate::closed(0, 1));
  check_map("inputs.ambient_height", in.ambient_height, cells);
  if (in.ambient_ocean) {
    if (!in.ambient_height.empty())
      fail(Code::InvalidArgument, "inputs.ambient_ocean and inputs.ambient_height are exclusive: give one");
    validate_ocean("inputs.ambient_ocean", *in.ambient_ocean, c, gate);
  }
  check_map("inputs.source_height", in.source_height, cells);
  check_map("inputs.source_phi", in.source_phi, cells);
  validate::in("inputs.drift_x", in.drift_x, validate::closed(-kMaxSpeed, kMaxSpeed));
  validate::in("inputs.drift_y", in.drift_y, validate::closed(-kMaxSpeed, kMaxSpeed));
  const validate::Interval speeds = validate::closed(-kMaxSpeed, kMaxSpeed);
  check_map("inputs.drift_field_x", in.drift_field_x, cells, speeds);
  check_map("inputs.drift_field_y", in.drift_field_y, cells, speeds);
  if (in.drift_field_x.empty() != in.drift_field_y.empty())
    fail(Code::InvalidArgument, "inputs.drift_field_x and inputs.drift_field_y must be given together");
  check_drift_reach("inputs.drift_field_x", in.drift_field_x, in.dt / c.dx);
  check_drift_reach("inputs.drift_field_y", in.drift_field_y, in.dt / c.dy);
  if (in.shapes.size() > kMaxShapes)
    fail(Code::InvalidArgument,
         "inputs.shapes has " + std::to_string(in.shapes.size()) + " shapes, at most " + std::to_string(kMaxShapes));
  size_t vertices = 0;
  for (size_t s = 0; s < in.shapes.size(); ++s) {
    check_shape(validate::at("inputs.shapes", s), in.shapes[s]);
    vertices += in.shapes[s].vertices.size();
  }
  if (vertices > kMaxShapeVertices)
    fail(Code::InvalidArgument, "inputs.shapes has " + std::to_string(vertices) + " polygon vertices, at most " +
                                    std::to_string(kMaxShapeVertices));
}

}  // namespace squall::ewave
