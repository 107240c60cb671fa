// TextureEngine::validate: every field of an AdvectSpec, under the caller's path.
#include <algorithm>
#include <cmath>
#include <optional>

#include "common/error.h"
#include "common/validate.h"
#include "textures/lagrangian.h"
#include "textures/push_pull.h"
#include "textures/texture_engine.h"

namespace squall::textures {
namespace {

using namespace squall::validate;

constexpr int kMaxVelocityFrames = 4096;
// beta's floor: the margin, in units of d, by which a grid's border clears the kernel about its centre.
constexpr double kMinGridMargin = 0.05;
constexpr double kMinDtPerTime = 0x1p-44;  // 2^-44: 256 of double's steps at any time
constexpr double kMaxSubstepTurn = 2;      // rad: RK4's stability limit on rotations is 2 sqrt(2)

std::string param(const std::string& path, int k) { return at(path + ".params", size_t(k)); }

// Every analytic parameter within +-kMaxVelocityParam, and the one the field divides by at least
// kMinVelocityDivisor.
void analytic(const VelocitySpec& v, const std::string& path) {
  for (int k = 0; k < SQUALL_VELOCITY_PARAMS; ++k)
    in(param(path, k), v.params[k], closed(-kMaxVelocityParam, kMaxVelocityParam));
  int divisor = -1;  // the parameter a kind divides by (fields.h)
  if (v.kind == SQUALL_VELOCITY_SINK || v.kind == SQUALL_VELOCITY_VORTEX || v.kind == SQUALL_VELOCITY_CYLINDER)
    divisor = 3;                                            // eps of |x - c| + eps, core radius, cylinder radius
  if (v.kind == SQUALL_VELOCITY_TAYLOR_GREEN) divisor = 1;  // period
  if (v.kind == SQUALL_VELOCITY_CHANNEL) divisor = 2;       // half width
  if (divisor >= 0) in(param(path, divisor), v.params[divisor], closed(kMinVelocityDivisor, kMaxVelocityParam));
}

// The largest modulus of the eigenvalues of [[a, b], [c, d]], a velocity gradient: a rotation's rate, a
// strain's; 0 for a shear (it carries a texel along, at the rate it grows its distance from its neighbours).
double spectral_radius(double a, double b, double c, double d) {
  const double half_trace = (a + d) / 2, det = a * d - b * c, disc = half_trace * half_trace - det;
  return disc >= 0 ? std::abs(half_trace) + std::sqrt(disc) : std::sqrt(det);  // a complex pair: |lambda|^2 = det
}

// The largest spectral radius of a velocity grid's gradient over its cells and frames, 1/s, from each cell's
// edges' mean differences (across the seam too, where the grid is periodic), of the frames as the kernels
// sample them. Every cell with a fluid node counts: the fluid around that node (the mask's nearest node
// decides) takes the cell's bilinear velocity, solid nodes' included. Cells of four solid nodes carry none
// (a Runge-Kutta stage of a substep that crosses more than half a cell may still sample one).
double grid_gradient_rate(const VelocitySpec& v) {
  auto fluid = [&](size_t n) { return v.mask.empty() || v.mask[n]; };
  const bool wrap = v.extrapolation == Extrapolation::Wrap;
  auto node = [&](int i, int j) { return size_t(j % v.ny) * size_t(v.nx) + size_t(i % v.nx); };
  double rate = 0;
  for (const VelocityFrame& given : v.frames) {
    std::optional<VelocityFrame> filled;  // a copy only where push-pull fills the solid nodes
    if (fills_solid_nodes(v)) filled = sampled_frame(v, given);
    const VelocityFrame& f = filled ? *filled : given;
    for (int j = 0; j < (wrap ? v.ny : v.ny - 1); ++j)
      for (int i = 0; i < (wrap ? v.nx : v.nx - 1); ++i) {
        const size_t n00 = node(i, j), n10 = node(i + 1, j), n01 = node(i, j + 1), n11 = node(i + 1, j + 1);
        if (!fluid(n00) && !fluid(n10) && !fluid(n01) && !fluid(n11)) continue;
        auto along_x = [&](const std::vector<float>& w) {
          return (double(w[n10]) - w[n00] + double(w[n11]) - w[n01]) / (2 * v.hx);
        };
        auto along_y = [&](const std::vector<float>& w) {
          return (double(w[n01]) - w[n00] + double(w[n11]) - w[n10]) / (2 * v.hy);
        };
        rate = std::max(rate, spectral_radius(along_x(f.u), along_y(f.u), along_x(f.v), along_y(f.v)));
      }
  }
  return rate;
}

// The largest rate of a field's velocity gradient, 1/s (fields.h): the turn rate of a rotation,
// the shear of a shear, what the centre or the walls of the others reach; a grid's eigenvalues in its cells.
double gradient_rate(const VelocitySpec& v) {
  const auto& p = v.params;
  switch (v.kind) {
    case SQUALL_VELOCITY_ROTATION:
    case SQUALL_VELOCITY_SHEAR: return std::abs(p[0]);
    case SQUALL_VELOCITY_SINK: return std::abs(p[0]) / p[3];                        // at the centre
    case SQUALL_VELOCITY_VORTEX: return std::abs(p[0]) / (2 * M_PI * p[3] * p[3]);  // solid within the core
    case SQUALL_VELOCITY_TAYLOR_GREEN: return std::abs(p[0]) * 2 * M_PI / p[1];
    case SQUALL_VELOCITY_CHANNEL: return 2 * std::abs(p[0]) / p[2];   // at the walls
    case SQUALL_VELOCITY_CYLINDER: return 2 * std::abs(p[0]) / p[3];  // at the cylinder
    case SQUALL_VELOCITY_GRID: return grid_gradient_rate(v);
    default: return 0;
  }
}

// Each substep is one classical Runge-Kutta step, whose stability region reaches 2 sqrt(2) along the
// imaginary axis (E. Hairer, G. Wanner, "Solving Ordinary Differential Equations II", sec. IV.2): a field
// that turns a texel by more per substep grows its error every step (a rotation of 1e5 rad/s at 1/30 s
// carried the Lagrangian grids to infinity, then NaN). kMaxSubstepTurn keeps a margin below that.
void substeps_resolve(const AdvectSpec& spec, const std::string& path) {
  const double turn = gradient_rate(spec.velocity) * spec.dt / spec.substeps;
  if (turn > kMaxSubstepTurn)
    fail(Code::InvalidArgument,
         path + ".substeps = " + std::to_string(spec.substeps) + ": the velocity field turns by " + number(turn) +
             " rad per substep (its largest gradient times dt / substeps), more than " + number(kMaxSubstepTurn) +
             " that the integration keeps stable; raise substeps (at most " + std::to_string(kMaxTextureSubsteps) +
             ") or lower dt");
}

// A step over [t, t + span] reads a grid's frames from the last at or before t to the first at or after
// t + span, SQUALL_VELOCITY_WINDOW at most: so no SQUALL_VELOCITY_WINDOW - 1 consecutive frames with a
// frame before and one after them may lie within less than one span (dt for Lagrangian grids, which carry
// their vertices over a frame at once, dt / substeps for the Eulerian methods). Before the first frame and
// after the last the field is held: a run that starts or ends the list needs no frame beyond it.
void frames_within_a_step(const AdvectSpec& spec, const std::string& path) {
  const double span = spec.method == Method::LagrangianGrids ? spec.dt : spec.dt / double(spec.substeps);
  const auto& frames = spec.velocity.frames;
  const size_t apart = SQUALL_VELOCITY_WINDOW - 2;
  for (size_t i = 1; i + apart + 1 < frames.size(); ++i)
    if (frames[i + apart].time - frames[i].time < span)
      reject(at(path + ".frames", i + apart) + ".time", frames[i + apart].time,
             "at least " + number(span) + " s after frames[" + std::to_string(i) +
                 "].time = " + number(frames[i].time) + ": a step (" + number(span) + " s) interpolates between " +
                 std::to_string(SQUALL_VELOCITY_WINDOW) + " frames at most; give fewer frames or a shorter step");
}

// A grid's node (0, 0) within +-kMaxCoordinate and its spacings in [kMinVelocityDivisor, kMaxCoordinate]:
// in float32 on the device, neither 0 nor infinite.
void grid_placement(double origin_x, double origin_y, double hx, double hy, const std::string& path) {
  in(path + ".origin.x", origin_x, closed(-kMaxCoordinate, kMaxCoordinate));
  in(path + ".origin.y", origin_y, closed(-kMaxCoordinate, kMaxCoordinate));
  in(path + ".spacing.x", hx, closed(kMinVelocityDivisor, kMaxCoordinate));
  in(path + ".spacing.y", hy, closed(kMinVelocityDivisor, kMaxCoordinate));
}

void velocity_grid(const VelocitySpec& v, const LimitGate& gate, const std::string& path) {
  in(path + ".nx", int64_t(v.nx), 2, kMaxGridSide);
  in(path + ".ny", int64_t(v.ny), 2, kMaxGridSide);
  in(path + ".frames size", int64_t(v.frames.size()), 1, kMaxVelocityFrames);
  gate.check_grid(path, v.nx, v.ny);  // the frames' bytes are bounded by the request's size
  grid_placement(v.origin_x, v.origin_y, v.hx, v.hy, path);
  const size_t nodes = size_t(v.nx) * v.ny;
  const Interval speed = closed(-kMaxVelocityParam, kMaxVelocityParam);
  for (size_t f = 0; f < v.frames.size(); ++f) {
    const std::string frame = at(path + ".frames", f);
    in(frame + ".time", v.frames[f].time, closed(-kMaxFrameTime, kMaxFrameTime));
    if (f > 0 && v.frames[f].time <= v.frames[f - 1].time)
      reject(frame + ".time", v.frames[f].time, "greater than the previous frame's time");
    count(frame + ".u", v.frames[f].u.size(), nodes, "nx * ny");
    count(frame + ".v", v.frames[f].v.size(), nodes, "nx * ny");
    each(frame + ".u", v.frames[f].u.data(), nodes, speed);
    each(frame + ".v", v.frames[f].v.data(), nodes, speed);
  }
  if (!v.mask.empty()) count(path + ".mask", v.mask.size(), nodes, "nx * ny");
}

// The LUT's scalar field: absent (no values, nx = ny = 0), or nx x ny values within +-kMaxTextureValue on a
// spaced grid.
void scalar_grid(const ScalarGridSpec& g, const LimitGate& gate, const std::string& path) {
  if (g.values.empty() && g.nx == 0 && g.ny == 0) return;  // s = 0
  in(path + ".nx", int64_t(g.nx), 2, kMaxGridSide);
  in(path + ".ny", int64_t(g.ny), 2, kMaxGridSide);
  gate.check_grid(path, g.nx, g.ny);
  grid_placement(g.origin_x, g.origin_y, g.hx, g.hy, path);
  const size_t nodes = size_t(g.nx) * g.ny;
  count(path + ".values", g.values.size(), nodes, "nx * ny");
  each(path + ".values", g.values.data(), nodes, closed(-kMaxTextureValue, kMaxTextureValue));  // lerps stay finite
}

// The LUT final function (LTA11 sec. 3.2): C channels, N in 2..4096 finite entries, lut_max > lut_min,
// a band shaping g among SUM_BANDS, TURBULENCE, RIDGED.
void lookup(const FinalLookupSpec& l, const LimitGate& gate, const std::string& path) {
  const int64_t channels = in(path + ".channels", l.channels, 1, SQUALL_LUT_MAX_CHANNELS);
  const size_t size = l.table.size();
  if (size % size_t(channels) != 0)
    reject(path + ".table size", double(size), "a multiple of channels = " + std::to_string(channels));
  in(path + ".table size / channels", int64_t(size / size_t(channels)), 2, SQUALL_LUT_MAX_ENTRIES);
  const Interval values = closed(-kMaxTextureValue, kMaxTextureValue);
  each(path + ".table", l.table.data(), size, values);
  in(path + ".lut_min", l.lut_min, values);
  in(path + ".lut_max", l.lut_max, open_closed(l.lut_min, kMaxTextureValue));
  if (!(float(l.lut_max) > float(l.lut_min)))
    reject(path + ".lut_max", l.lut_max, "apart from lut_min = " + number(l.lut_min) + " in float32");
  if (l.band_shape != SQUALL_FINAL_SUM_BANDS && l.band_shape != SQUALL_FINAL_TURBULENCE &&
      l.band_shape != SQUALL_FINAL_RIDGED)
    reject(path + ".band_shape", double(l.band_shape), "sum of bands, turbulence or ridged");
  scalar_grid(l.field, gate, path + ".field");
}

void texture(const TextureSpec& t, const LimitGate& gate, const std::string& path) {
  known(path + ".kind", t.kind, 2, "texture kind");
  if (t.kind == SQUALL_TEXTURE_IMAGE) {
    // A request's image is checked as it is read; a spec built in process is checked here.
    gate.check_grid(at(path + ".image.channels", 0), t.width, t.height);
    in(path + ".image.channels", int64_t(t.channels), 1, SQUALL_TEXTURE_MAX_CHANNELS);
    const size_t n = size_t(t.width) * t.height * t.channels;
    count(path + ".image.pixels", t.pixels.size(), n, "width * height * channels");
    each(path + ".image.pixels", t.pixels.data(), n, closed(-kMaxTextureValue, kMaxTextureValue));
  } else {
    in(path + ".noise.bands", t.bands, 1, SQUALL_TEXTURE_MAX_CHANNELS);
    in(path + ".noise.base_cells", int64_t(t.base_cells), 1, 64);
    if (t.base_cells != std::floor(t.base_cells)) reject(path + ".noise.base_cells", t.base_cells, "an integer");
    in(path + ".noise.spin", t.spin, closed(-kMaxSpin, kMaxSpin));
  }
  positive(path + ".scale", t.scale, 1e6);
  known(path + ".final_function", t.final_function, SQUALL_FINAL_FUNCTIONS, "final function");
  in(path + ".final_scale", t.final_scale, closed(-kMaxFinalScale, kMaxFinalScale));
  if (t.final_function == SQUALL_FINAL_LUT) lookup(t.lut, gate, path + ".lut");
}

// The device places pixels and nodes in float32: along each axis, `steps` of them over [lo, hi] must each span
// many of float32's steps at the region's coordinates (a 1 du region of pixels at x = 1e6 came out flat;
// Eulerian nodes that close lost their strain and vorticity, whose differences x +- h then read x twice).
void resolved(const std::string& path, const char* what, const char* axis, double lo, double hi, double steps) {
  const double farthest = std::max(std::abs(lo), std::abs(hi)), step = (hi - lo) / steps;
  if (step < farthest * kMinPixelPerCoordinate)
    fail(Code::InvalidArgument, path + ": " + what + " of " + number(step) + " du along " + axis +
                                    " at coordinates up to " + number(farthest) +
                                    " du are finer than float32 places them there (at least " +
                                    number(farthest * kMinPixelPerCoordinate) +
                                    " du): move the region nearer the origin or use fewer " + what);
}

void output(const OutputSpec& o, const LimitGate& gate, const std::string& path) {
  gate.check_grid(path + ".width", path + ".height", o.width, o.height);
  in(path + ".region.x0", o.x0, closed(-kMaxCoordinate, kMaxCoordinate));
  in(path + ".region.y0", o.y0, closed(-kMaxCoordinate, kMaxCoordinate));
  in(path + ".region.x1", o.x1, open_closed(o.x0, kMaxCoordinate));
  in(path + ".region.y1", o.y1, open_closed(o.y0, kMaxCoordinate));
  resolved(path, "pixels", "x", o.x0, o.x1, o.width);
  resolved(path, "pixels", "y", o.y0, o.y1, o.height);
}

void lagrangian(const LagrangianParams& p, const OutputSpec& o, const std::string& path) {
  positive(path + ".d", p.d, 1e6);
  double area = (o.x1 - o.x0 + 2 * p.d) * (o.y1 - o.y0 + 2 * p.d);
  if (area / (p.d * p.d) > kMaxParticles)
    fail(Code::ResourceExhausted, path + ".d = " + number(p.d) + " would need about " + number(area / (p.d * p.d)) +
                                      " particles over the output region; at most " + number(kMaxParticles));
  in(path + ".alpha", p.alpha, open(0, 1));
  // With no margin a grid's border lies at d from its centre, and rounding alone would fail its coverage.
  in(path + ".beta", p.beta, closed(kMinGridMargin, 4));
  in(path + ".grid_res", p.grid_res, 3, 16);
  // A grid's vertices, (2 + beta) d / (grid_res - 1) apart (Yu et al. 2011, sec. 3.3.1), are placed in float32
  // as the pixels are: closer, they coincide and every grid is killed as folded on its first frame.
  const double spacing = (2 + p.beta) * p.d / (p.grid_res - 1);
  resolved(path + ".d", "grid vertices", "x", o.x0 - p.d, o.x1 + p.d, (o.x1 - o.x0 + 2 * p.d) / spacing);
  resolved(path + ".d", "grid vertices", "y", o.y0 - p.d, o.y1 + p.d, (o.y1 - o.y0 + 2 * p.d) / spacing);
  in(path + ".delta_max", p.delta_max, open_closed(1, 100));
  positive(path + ".fade_tau", p.fade_tau, 1e6);
  // The reconstruction's tile lists are indexed by cl_int.
  if (const uint64_t entries = lagrangian_tile_bound(p, o); entries > uint64_t(INT32_MAX))
    fail(Code::ResourceExhausted, path + ".d = " + number(p.d) + " over an output of " + std::to_string(o.width) +
                                      " x " + std::to_string(o.height) + " pixels would bin grids into up to " +
                                      std::to_string(entries) + " tile entries; at most 2^31 - 1");
}

void eulerian(const EulerianParams& p, Method method, const OutputSpec& o, const LimitGate& gate,
              const std::string& path) {
  in(path + ".grid_nx", p.grid_nx, 2, 4096);
  in(path + ".grid_ny", p.grid_ny, 2, 4096);
  gate.check_grid(path + ".grid_nx", path + ".grid_ny", p.grid_nx, p.grid_ny);
  resolved(path + ".grid_nx", "nodes", "x", o.x0, o.x1, double(p.grid_nx - 1));
  resolved(path + ".grid_ny", "nodes", "y", o.y0, o.y1, double(p.grid_ny - 1));
  if (method == Method::Naive) return;  // never regenerated: no latency
  in(path + ".latencies size", int64_t(p.latencies.size()), 1,
     method == Method::EulerianMultilayer ? SQUALL_EULERIAN_MAX_LAYERS : 1);
  for (size_t i = 0; i < p.latencies.size(); ++i) {
    in(at(path + ".latencies", i), p.latencies[i], closed(kMinLatency, 1e6));
    if (i > 0 && p.latencies[i] <= p.latencies[i - 1])
      reject(at(path + ".latencies", i), p.latencies[i], "greater than the previous layer's latency");
  }
  if (method != Method::EulerianMultilayer) return;
  in(path + ".phases", p.phases, 2, SQUALL_EULERIAN_MAX_PHASES);
  if (p.weight == PhaseWeight::Triangle && p.phases != 2)
    reject(path + ".phases", p.phases, "2 with triangle phase weights (they sum to 1 for two phases only)");
  positive(path + ".d_star", p.d_star, 1e6);
}

// The vorticity cascade (ADV03 sec. 4) of a multi-layer request: it turns noise bands, so c_w > 0 needs one.
void cascade(const VorticityCascade& c, const TextureSpec& t, const std::string& path) {
  non_negative(path + ".c_w", c.c_w, 1e6);
  positive(path + ".tau", c.tau, 1e6);
  positive(path + ".tau_ratio", c.tau_ratio, 100);
  if (c.c_w > 0 && t.kind != SQUALL_TEXTURE_NOISE)
    reject(path + ".c_w", c.c_w, "0 with an image texture (the cascade turns noise bands)");
}

}  // namespace

void TextureEngine::validate(const AdvectSpec& spec, const std::string& path, const std::string& velocity_path) const {
  validate_advect(spec, gate_, path, velocity_path);
  const uint64_t largest = runtime_.device_info().max_allocation_bytes;
  const uint64_t bytes = std::max(eulerian_slot_bytes(spec), eulerian_cascade_bytes(spec));
  if (bytes > largest)
    fail(Code::ResourceExhausted, path + ".eulerian.grid_nx x grid_ny = " + std::to_string(spec.eulerian.grid_nx) +
                                      " x " + std::to_string(spec.eulerian.grid_ny) + " needs a device buffer of " +
                                      std::to_string(bytes) + " bytes, past the device's largest allocation of " +
                                      std::to_string(largest) + ": ask for a coarser grid, or fewer latencies, " +
                                      "phases or cascade bands");
}

void validate_clock(const AdvectSpec& spec, const std::string& path, double now) {
  in(path + ".t0", spec.t0, closed(-kMaxTextureTime, kMaxTextureTime));
  positive(path + ".dt", spec.dt, kMaxTextureDt);
  in(path + ".frames", int64_t(spec.frames), 1, kMaxTextureFrames);
  in(path + ".substeps", int64_t(spec.substeps), 1, kMaxTextureSubsteps);
  // Frame times t0 + n dt are doubles: a dt within a few of double's steps at the stream's times makes
  // frames (and a followed current's two readings) that double cannot tell apart.
  const double farthest = std::max({std::abs(spec.t0), std::abs(now), std::abs(now + spec.frames * spec.dt)});
  if (spec.dt < farthest * kMinDtPerTime)
    fail(Code::InvalidArgument, path + ".dt = " + number(spec.dt) + " s at times up to " + number(farthest) +
                                    " s: double cannot tell frames that close apart there (at least " +
                                    number(farthest * kMinDtPerTime) + " s); use a larger dt or a t0 nearer 0");
}

void validate_followed_current(const VelocitySpec& velocity, const std::string& path) {
  const size_t nodes = size_t(velocity.nx) * velocity.ny;
  for (const VelocityFrame& frame : velocity.frames)
    for (const std::vector<float>* speeds : {&frame.u, &frame.v})
      for (size_t n = 0; n < nodes; ++n)
        if (!(std::abs((*speeds)[n]) <= kMaxVelocityParam))
          fail(Code::FailedPrecondition, path + ": its current at node (" + std::to_string(n % velocity.nx) + ", " +
                                             std::to_string(n / velocity.nx) + ") at t = " + number(frame.time) +
                                             " has " + (speeds == &frame.u ? "u" : "v") + " = " + number((*speeds)[n]) +
                                             " du/s, past the +-" + number(kMaxVelocityParam) +
                                             " du/s that advection takes");
}

void validate_made_velocity(const VelocitySpec& velocity, const LimitGate& gate, const std::string& source) {
  velocity_grid(velocity, gate, source + "'s grid");
}

void validate_followed_turn(const AdvectSpec& spec, const std::string& path) {
  if (const double turn = gradient_rate(spec.velocity) * spec.dt / spec.substeps; turn > kMaxSubstepTurn)
    fail(Code::FailedPrecondition, path + ": its current now turns the flow by " + number(turn) +
                                       " rad per substep (its largest gradient times dt / substeps), more than the " +
                                       number(kMaxSubstepTurn) + " that the integration keeps stable");
}

void validate_advect(const AdvectSpec& spec, const LimitGate& gate, const std::string& path,
                     const std::string& velocity_path) {
  known(path + ".method", int(spec.method), kMethods, "method");
  const std::string velocity = velocity_path.empty() ? path + ".velocity" : velocity_path;
  known(velocity + ".kind", spec.velocity.kind, SQUALL_VELOCITY_KINDS, "velocity kind");
  if (spec.velocity.kind == SQUALL_VELOCITY_GRID)
    velocity_grid(spec.velocity, gate, velocity + ".grid");
  else
    analytic(spec.velocity, velocity);
  texture(spec.texture, gate, path + ".texture");
  output(spec.output, gate, path + ".output");
  validate_clock(spec, path);
  substeps_resolve(spec, path);
  if (spec.velocity.kind == SQUALL_VELOCITY_GRID) frames_within_a_step(spec, velocity + ".grid");
  if (spec.method == Method::LagrangianGrids)
    lagrangian(spec.lagrangian, spec.output, path + ".lagrangian");
  else
    eulerian(spec.eulerian, spec.method, spec.output, gate, path + ".eulerian");
  if (spec.method == Method::EulerianMultilayer)
    cascade(spec.eulerian.cascade, spec.texture, path + ".eulerian.cascade");
}

}  // namespace squall::textures
