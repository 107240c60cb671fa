#include "textures/device_inputs.h"

#include <algorithm>
#include <cmath>

#include "runtime/upload.h"
#include "textures/push_pull.h"

namespace squall::textures {
namespace {

// The frames as (u, v) pairs, x fastest, frame after frame; extrapolated by push-pull if asked.
std::vector<cl_float2> grid_pairs(const VelocitySpec& v) {
  std::vector<cl_float2> pairs;
  if (v.kind != SQUALL_VELOCITY_GRID) return pairs;
  const size_t nodes = size_t(v.nx) * v.ny;
  for (const auto& frame : v.frames) {
    const VelocityFrame f = sampled_frame(v, frame);
    for (size_t n = 0; n < nodes; ++n) pairs.push_back(cl_float2{{f.u[n], f.v[n]}});
  }
  return pairs;
}

// The LUT's table or scalar field when the final function is the LUT, else nothing.
const std::vector<float>& lut_input(const TextureSpec& t, const std::vector<float>& values) {
  static const std::vector<float> none;
  return t.final_function == SQUALL_FINAL_LUT ? values : none;
}

VelocityField field_of(const VelocitySpec& v) {
  VelocityField f{};
  f.kind = v.kind;
  for (int k = 0; k < SQUALL_VELOCITY_PARAMS; ++k) f.p[k] = float(v.params[k]);
  if (v.kind != SQUALL_VELOCITY_GRID) return f;
  f.nx = v.nx;
  f.ny = v.ny;
  f.extrapolation = v.extrapolation == Extrapolation::Zero   ? SQUALL_EXTRAPOLATE_ZERO
                    : v.extrapolation == Extrapolation::Wrap ? SQUALL_EXTRAPOLATE_WRAP
                                                             : SQUALL_EXTRAPOLATE_CLAMP;
  f.origin_x = float(v.origin_x);
  f.origin_y = float(v.origin_y);
  f.hx = float(v.hx);
  f.hy = float(v.hy);
  f.has_mask = v.mask.empty() ? 0 : 1;
  return f;
}

// The LUT final function's description: its table, band shaping and scalar field (fields.h).
void lookup_of(const FinalLookupSpec& l, TextureSource& s) {
  s.lut_channels = int(l.channels);  // validated: 1..SQUALL_LUT_MAX_CHANNELS
  s.lut_entries = int(l.table.size() / size_t(std::max<int64_t>(l.channels, 1)));
  s.lut_min = float(l.lut_min);
  s.lut_max = float(l.lut_max);
  s.lut_band_shape = l.band_shape;
  if (l.field.values.empty()) return;  // s = 0
  s.scalar_nx = l.field.nx;
  s.scalar_ny = l.field.ny;
  s.scalar_origin_x = float(l.field.origin_x);
  s.scalar_origin_y = float(l.field.origin_y);
  s.scalar_hx = float(l.field.hx);
  s.scalar_hy = float(l.field.hy);
}

TextureSource source_of(const TextureSpec& t, const ReferenceStats& stats) {
  TextureSource s{};
  s.kind = t.kind;
  s.channels = int(t.kind == SQUALL_TEXTURE_IMAGE ? t.channels : t.bands);  // validated: 1..SQUALL_TEXTURE_MAX_CHANNELS
  s.width = t.width;
  s.height = t.height;
  s.seed = t.seed;
  s.base_cells = float(t.base_cells);
  for (int c = 0; c < s.channels && c < int(stats.mean.size()); ++c) s.mean[c] = float(stats.mean[c]);
  s.final_function = t.final_function;
  s.final_scale = float(t.final_scale);
  if (t.final_function == SQUALL_FINAL_LUT) lookup_of(t.lut, s);
  return s;
}

}  // namespace

DeviceInputs::DeviceInputs(Runtime& runtime, const AdvectSpec& spec, const ReferenceStats& stats)
    : texture_(source_of(spec.texture, stats)),
      spin_(spec.texture.spin),
      output_(spec.output),
      stats_(stats),
      image_(upload(runtime, spec.texture.kind == SQUALL_TEXTURE_IMAGE ? spec.texture.pixels : std::vector<float>{})),
      scalar_(upload(runtime, lut_input(spec.texture, spec.texture.lut.field.values))),
      lut_(upload(runtime, lut_input(spec.texture, spec.texture.lut.table))) {
  set_velocity(runtime, spec.velocity);
}

void DeviceInputs::set_velocity(Runtime& runtime, const VelocitySpec& velocity) {
  field_ = field_of(velocity);
  times_.clear();
  for (const auto& frame : velocity.frames) times_.push_back(frame.time);
  mask_host_ = velocity.mask;
  grid_ = upload(runtime, grid_pairs(velocity));
  mask_ = upload(runtime, velocity.mask);
}

std::shared_ptr<const DeviceInputs> DeviceInputs::steered(Runtime& runtime, const AdvectSpec& spec, double time) const {
  auto next = std::make_shared<DeviceInputs>(*this);
  next->set_velocity(runtime, spec.velocity);
  next->turned_ = turned(time);  // the bands turn on from where they are, at the new rate
  next->turned_since_ = time;
  next->spin_ = spec.texture.spin;
  next->texture_.final_scale = float(spec.texture.final_scale);
  return next;
}

VelocityField DeviceInputs::velocity(double t0, double span) const {
  VelocityField f = field_;
  if (f.kind != SQUALL_VELOCITY_GRID) return f;
  size_t first = 0;  // the last frame at or before t0, else the first
  while (first + 1 < times_.size() && times_[first + 1] <= t0) ++first;
  size_t last = first;  // the first frame at or after t0 + span, else the last (validation keeps it in a window)
  while (last + 1 < times_.size() && last + 1 < first + SQUALL_VELOCITY_WINDOW && times_[last] < t0 + span) ++last;
  f.frames = int(last - first + 1);
  f.frame_first = int(first * size_t(f.nx) * f.ny);
  for (size_t k = first; k <= last; ++k) f.p[k - first] = float(times_[k] - t0);  // exact in float32 at any t0
  return f;
}

double DeviceInputs::turned(double time) const { return turned_ + spin_ * (time - turned_since_); }

TextureSource DeviceInputs::texture(double time) const {
  TextureSource t = texture_;
  const double band0 = turned(time);
  if (band0 == 0) return t;
  for (int c = 0; c < t.channels; ++c) {  // 2^(2c/3) band 0's, reduced in double (float32: radians off at 1e8 s)
    const double turn = std::fmod(std::exp2(2.0 * c / 3.0) * band0, 2 * M_PI);
    t.turn[c] = float(turn < 0 ? turn + 2 * M_PI : turn);
  }
  return t;
}

OutputGrid DeviceInputs::output(int tile) const {
  OutputGrid g{};
  g.width = output_.width;
  g.height = output_.height;
  g.x0 = float(output_.x0);
  g.y0 = float(output_.y0);
  g.pixel_x = float((output_.x1 - output_.x0) / output_.width);
  g.pixel_y = float((output_.y1 - output_.y0) / output_.height);
  g.tile = tile;
  g.tiles_x = (output_.width + tile - 1) / tile;
  return g;
}

bool DeviceInputs::fluid(double x, double y) const {
  return velocity_fluid_at(&field_, mask_host_.data(), float(x), float(y)) != 0;
}

ReferenceStats image_stats(const TextureSpec& texture) {
  ReferenceStats stats;
  const size_t n = size_t(texture.width) * texture.height;
  for (int c = 0; c < texture.channels; ++c) {
    double sum = 0, sum2 = 0;
    for (size_t k = 0; k < n; ++k) {
      double value = texture.pixels[c * n + k];
      sum += value;
      sum2 += value * value;
    }
    double mean = sum / double(n);
    stats.mean.push_back(mean);
    stats.variance.push_back(std::max(0.0, sum2 / double(n) - mean * mean));
  }
  return stats;
}

}  // namespace squall::textures
