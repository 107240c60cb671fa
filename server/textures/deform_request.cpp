#include "textures/deform_request.h"

#include <algorithm>

#include "common/error.h"
#include "common/field_codec.h"
#include "common/validate.h"
#include "textures/textures_request.h"

namespace squall::textures::rpc {
namespace {

namespace v1 = squall::v1;
using validate::at;

DeformControlKind control_kind(int kind, const std::string& path) {
  switch (validate::known(path, kind, 6, "DeformControlKind")) {
    case v1::DEFORM_CONTROL_MAP: return DeformControlKind::Map;
    case v1::DEFORM_CONTROL_ISOTROPIC: return DeformControlKind::Isotropic;
    case v1::DEFORM_CONTROL_ANISOTROPIC: return DeformControlKind::Anisotropic;
    case v1::DEFORM_CONTROL_BRUSH: return DeformControlKind::Brush;
    default: return DeformControlKind::Constant;
  }
}

Tensor2 tensor(const v1::Tensor2& t) { return {t.xx(), t.xy(), t.yx(), t.yy()}; }

std::vector<BrushStroke> strokes(const google::protobuf::RepeatedPtrField<v1::BrushStroke>& in) {
  std::vector<BrushStroke> out;
  for (const v1::BrushStroke& s : in) out.push_back({s.center().x(), s.center().y(), s.radius(), s.strength()});
  return out;
}

std::vector<uint8_t> chart(const v1::DeformTextureRequest& r, const DeformSpec& s, const std::string& path) {
  std::vector<uint8_t> inside;
  if (!r.has_chart()) return inside;
  const std::vector<float> values = image_plane(r.chart(), path + ".chart", uint32_t(s.width), uint32_t(s.height));
  validate::each(path + ".chart", values.data(), values.size());  // finite; nonzero = inside
  for (float v : values) inside.push_back(v != 0);
  return inside;
}

}  // namespace

DeformSpec deform_spec(const v1::DeformTextureRequest& r, LimitGate& gate, Slot& decoded, const std::string& path) {
  DeformSpec s;
  TextureSpec image = image_texture(r.texture(), gate, decoded, path + ".texture");
  s.width = image.width;
  s.height = image.height;
  s.channels = image.channels;
  s.pixels = std::move(image.pixels);
  if (!r.has_rigidity())
    fail(Code::InvalidArgument, path + ".rigidity is unset: give R, the texture's size, values in [-1, 1]");
  s.rigidity = image_plane(r.rigidity(), path + ".rigidity", uint32_t(s.width), uint32_t(s.height));
  s.chart = chart(r, s, path);
  DeformControl& c = s.control;
  c.kind = control_kind(r.control(), path + ".control");
  c.kappa = r.has_kappa() ? r.kappa() : 1.0;
  c.d_mu = r.d_mu();
  if (r.has_d_mu_map())
    c.d_mu_map = image_plane(r.d_mu_map(), path + ".d_mu_map", uint32_t(s.width), uint32_t(s.height));
  else if (c.kind == DeformControlKind::Map)
    fail(Code::InvalidArgument, path + ".d_mu_map is unset: DEFORM_CONTROL_MAP needs it");
  if (r.has_deformation_start()) c.deformation_start = tensor(r.deformation_start());
  if (r.has_deformation_end()) c.deformation_end = tensor(r.deformation_end());
  c.strokes = strokes(r.strokes());
  c.paper_dt_factor = r.paper_dt_factor();
  s.frames = r.frames();
  s.dt = r.has_dt() ? r.dt() : 1.0 / 30;
  s.substeps = r.has_substeps() ? r.substeps() : 10;
  s.stack_levels = r.stack_levels();
  s.tolerance = r.has_tolerance() ? r.tolerance() : 1e-6;
  s.max_iterations = r.has_max_iterations() ? r.max_iterations() : 4000;
  return s;
}

DeformPlanes deform_planes(const v1::DeformTextureRequest& r, const std::string& path) {
  DeformPlanes p;
  field::dtype(r.dtype(), path + ".dtype");
  if (r.planes_size() == 0) return p;
  p.color = false;
  for (int i = 0; i < r.planes_size(); ++i) {
    switch (validate::known(at(path + ".planes", size_t(i)), r.planes(i), 6, "DeformPlane")) {
      case v1::DEFORM_PLANE_WARP: p.warp = true; break;
      case v1::DEFORM_PLANE_REFERENCE: p.reference = true; break;
      case v1::DEFORM_PLANE_LEVEL: p.level = true; break;
      case v1::DEFORM_PLANE_FLOW: p.flow = true; break;
      default: p.color = true; break;
    }
  }
  return p;
}

DeformSpec deform_start(const v1::DeformControl& control, LimitGate& gate, Slot& decoded, const std::string& path) {
  if (!control.has_start())
    fail(Code::InvalidArgument, path + ".start is unset: the first message starts the deformation");
  if (control.start().frames() != 0)
    validate::reject(path + ".start.frames", control.start().frames(), "0 (each message asks for its frames)");
  if (control.start().has_deformation_end())
    fail(Code::InvalidArgument, path + ".start.deformation_end is set: an interactive deformation holds " +
                                    "deformation_start until a message's deformation steers it");
  DeformSpec s = deform_spec(control.start(), gate, decoded, path + ".start");
  s.frames = 1;  // per message (deform_control_frames); the tensor holds its start until steered
  s.control.deformation_end = s.control.deformation_start;
  return s;
}

uint32_t deform_control_frames(const v1::DeformControl& control, const std::string& path) {
  if (!control.has_frames()) return 1;
  return uint32_t(validate::in(path + ".frames", int64_t(control.frames()), 0, 1024));
}

bool steer(const v1::DeformControl& m, DeformSpec& s, const std::string& path) {
  DeformControl& c = s.control;
  bool changed = false;
  if (m.has_d_mu()) c.d_mu = m.d_mu(), changed = true;
  if (m.has_d_mu_map()) {
    c.d_mu_map = image_plane(m.d_mu_map(), path + ".d_mu_map", uint32_t(s.width), uint32_t(s.height));
    changed = true;
  }
  if (m.has_deformation()) {
    c.deformation_start = c.deformation_end = tensor(m.deformation());
    changed = true;
  }
  if (m.strokes_size() > 0 || m.clear_strokes()) c.strokes = strokes(m.strokes()), changed = true;
  return changed;
}

uint64_t frame_bytes(const DeformSpec& s, const DeformPlanes& p, v1::DType dtype) {
  const uint64_t planes = (p.color ? uint64_t(s.channels) : 0) + 2 * p.warp + p.reference + p.level + 2 * p.flow;
  return planes * uint64_t(s.width) * uint64_t(s.height) * field::bytes_per_value(dtype);
}

void fill_frame(const DeformFrame& f, const FlowSolve& flow, const DeformPlanes& p, int channels, v1::DType dtype,
                v1::DeformFrame* out) {
  out->set_index(uint32_t(f.index));
  out->set_time(f.time);
  const size_t n = size_t(f.width) * f.height;
  int k = 0;
  auto add = [&](const std::string& name, const char* unit) {
    v1::Field* field = out->add_planes();
    field::encode({name, unit, uint32_t(f.width), uint32_t(f.height), 0, field::dtype(dtype)},
                  f.planes.data() + size_t(k++) * n, n, field);
    field->mutable_spacing()->set_x(1);
    field->mutable_spacing()->set_y(1);
    field->mutable_origin()->set_x(0.5);
    field->mutable_origin()->set_y(0.5);
  };
  if (p.color)
    for (int c = 0; c < channels; ++c) add("color_" + std::to_string(c), "1");
  if (p.warp) add("warp_x", "texel"), add("warp_y", "texel");
  if (p.reference) add("reference_time", "1");
  if (p.level) add("level", "1");
  if (p.flow) add("flow_x", "texel"), add("flow_y", "texel");
  out->set_solver_iterations(uint32_t(flow.iterations));
  out->set_solver_residual(flow.residual);
  out->set_max_warp(f.max_warp);
  out->set_max_residual(f.max_residual);
  out->set_min_reference(f.min_reference);
  out->set_max_reference(f.max_reference);
}

}  // namespace squall::textures::rpc
