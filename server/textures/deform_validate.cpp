// The ranges of a content-aware deformation (G. Guingo et al., "Content-aware texture deformation with
// dynamic control", Computers & Graphics 91, 2020), as the proto's DeformTextureRequest states them.
#include "textures/deform_validate.h"

#include <algorithm>

#include "common/error.h"
#include "common/validate.h"
#include "textures/deform_control.h"

namespace squall::textures {
namespace {

using namespace squall::validate;

constexpr int kMaxSide = 1 << 20;
constexpr int kMaxChannels = 8;
constexpr int kMaxStrokes = 256;
constexpr int kMaxFrames = 100000;
constexpr int kMaxSubsteps = 100;
constexpr int kMaxLevels = 16;
constexpr int kMaxIterations = 100000;
constexpr double kMaxKappa = 1e6, kMaxDmu = 100, kMaxRadius = 1e6, kMaxDt = 1e4, kMaxGradient = 1e6;
// A brush's Gaussian divides by 2 r^2 in float: from 1e-6 texels it is a normal float, and a narrower brush
// reaches no texel centre but the one it sits on.
constexpr double kMinRadius = 1e-6;
constexpr double kMinDeterminant = 1e-12;

// Components within +-kMaxGradient and det at least kMinDeterminant: a deformation gradient whose inverse is
// finite in float32 (1e300 components made an infinite determinant, which passed as > 0, and infinite
// reference coordinates).
void tensor(const Tensor2& g, const std::string& path) {
  const Interval components = closed(-kMaxGradient, kMaxGradient);
  in(path + ".xx", g.xx, components);
  in(path + ".xy", g.xy, components);
  in(path + ".yx", g.yx, components);
  in(path + ".yy", g.yy, components);
  const double det = g.determinant();
  if (!(det >= kMinDeterminant))
    reject(path + " determinant", det, "at least 1e-12 (a deformation gradient whose inverse stays finite)");
}

// Each frame's G on the ramp between two deformation gradients is one too: the straight line between them
// may pass through a singular G (from G to -G, say), which T = G_now G_before^-1 would divide by.
void ramp(const Tensor2& start, const Tensor2& end, int frames, const std::string& path) {
  for (int k = 1; k + 1 < frames; ++k) {
    const double det = deformation_ramp(start, end, frames, k).determinant();
    if (!(det >= kMinDeterminant))
      reject(path + ": the determinant of the ramp's G at frame " + std::to_string(k), det,
             "at least 1e-12 (the line from deformation_start passes a singular gradient)");
  }
}

void stroke(const BrushStroke& s, const std::string& path) {
  finite(path + ".center.x", s.center_x);
  finite(path + ".center.y", s.center_y);
  in(path + ".radius", s.radius, closed(kMinRadius, kMaxRadius));
  in(path + ".strength", s.strength, closed(-kMaxDmu, kMaxDmu));
}

// The texture's size comes from its planes (channels[].nx and .ny, pixels8, a PNG's header), which no
// field of the request holds as such: it is named as the texture's size.
void texture(const DeformSpec& spec, const LimitGate& gate, const std::string& path) {
  if (std::min(spec.width, spec.height) < 4 || std::max(spec.width, spec.height) > kMaxSide)
    fail(Code::InvalidArgument, path + " is " + std::to_string(spec.width) + " x " + std::to_string(spec.height) +
                                    " texels: each side must be in [4, " + std::to_string(kMaxSide) + "]");
  gate.check_grid(path + "'s width", path + "'s height", spec.width, spec.height);
  in(path + ".channels size", int64_t(spec.channels), 1, kMaxChannels);
  const size_t n = size_t(spec.width) * spec.height * spec.channels;
  count(path + ".channels", spec.pixels.size(), n, "width * height * channels");
  each(path + ".channels", spec.pixels.data(), n);
}

}  // namespace

void validate_control(const DeformControl& c, int width, int height, const std::string& prefix,
                      const std::string& tensor_name) {
  known(prefix + "control", int(c.kind), 5, "deform control");
  in(prefix + "kappa", c.kappa, closed(-kMaxKappa, kMaxKappa));
  in(prefix + "d_mu", c.d_mu, closed(-kMaxDmu, kMaxDmu));
  if (c.kind == DeformControlKind::Map || !c.d_mu_map.empty()) {  // one sent is checked, used or not
    const size_t n = size_t(width) * height;
    count(prefix + "d_mu_map", c.d_mu_map.size(), n, "width * height");
    each(prefix + "d_mu_map", c.d_mu_map.data(), n, closed(-kMaxDmu, kMaxDmu));
  }
  tensor(c.deformation_start, prefix + tensor_name);
  in(prefix + "strokes size", int64_t(c.strokes.size()), 0, kMaxStrokes);
  for (size_t k = 0; k < c.strokes.size(); ++k) stroke(c.strokes[k], at(prefix + "strokes", k));
}

void validate_anisotropic_step(const Tensor2& t, const std::string& field, const std::string& frame) {
  const double shear = 0.5 * (t.xy + t.yx);  // the symmetric part [[xx, shear], [shear, yy]]
  if (t.xx > 0 && t.xx * t.yy - shear * shear > 0) return;
  fail(Code::InvalidArgument, field + " turns some direction by 90 degrees or more in one frame (" + frame +
                                  "): eq. 8's log(vb^T T vb) is undefined there (T = G_now G_before^-1 = [[" +
                                  number(t.xx) + ", " + number(t.xy) + "], [" + number(t.yx) + ", " + number(t.yy) +
                                  "]]); spread the turn over more frames");
}

namespace {

// Each frame's T of an ANISOTROPIC control's ramp.
void anisotropic_ramp(const DeformSpec& spec, const std::string& path) {
  if (spec.control.kind != DeformControlKind::Anisotropic) return;
  const DeformControl& c = spec.control;
  for (int k = 1; k < spec.frames; ++k)
    validate_anisotropic_step(
        frame_deformation(deformation_ramp(c.deformation_start, c.deformation_end, spec.frames, k),
                          deformation_ramp(c.deformation_start, c.deformation_end, spec.frames, k - 1)),
        path, "frame " + std::to_string(k));
}

}  // namespace

void validate_deform(const DeformSpec& spec, const LimitGate& gate, const std::string& path) {
  texture(spec, gate, path + ".texture");
  const size_t n = size_t(spec.width) * spec.height;
  count(path + ".rigidity", spec.rigidity.size(), n, "width * height");
  each(path + ".rigidity", spec.rigidity.data(), n, closed(-1, 1));
  if (!spec.chart.empty()) count(path + ".chart", spec.chart.size(), n, "width * height");
  validate_control(spec.control, spec.width, spec.height, path + ".", "deformation_start");
  tensor(spec.control.deformation_end, path + ".deformation_end");
  in(path + ".frames", int64_t(spec.frames), 1, kMaxFrames);
  ramp(spec.control.deformation_start, spec.control.deformation_end, spec.frames, path + ".deformation_end");
  anisotropic_ramp(spec, path + ".deformation_end");
  in(path + ".dt", spec.dt, open_closed(0, kMaxDt));
  in(path + ".substeps", int64_t(spec.substeps), 1, kMaxSubsteps);
  in(path + ".stack_levels", int64_t(spec.stack_levels), 0, kMaxLevels);
  in(path + ".tolerance", spec.tolerance, closed(1e-12, 1e-1));
  in(path + ".max_iterations", int64_t(spec.max_iterations), 1, kMaxIterations);
  const double cells = double(n) * (2 * spec.stack_levels + 1);
  if (cells > double(gate.limits().max_grid_cells))
    fail(Code::ResourceExhausted,
         path + ".stack_levels = " + std::to_string(spec.stack_levels) + ": " +
             std::to_string(2 * spec.stack_levels + 1) +
             " levels of width * height = " + std::to_string(uint64_t(cells)) +
             " cells exceed --max-grid-cells = " + std::to_string(gate.limits().max_grid_cells));
}

}  // namespace squall::textures
