#include "ewave/ewave_request.h"

#include <set>

#include "common/error.h"
#include "common/validate.h"
#include "common/field_codec.h"
#include "ocean/ocean_request.h"

namespace squall::ewave::rpc {
namespace {

namespace v1 = squall::v1;

DispersionKind dispersion(v1::DispersionModel model) {
  switch (model) {
    case v1::DISPERSION_MODEL_UNSPECIFIED:
    case v1::DISPERSION_MODEL_DEEP: return DispersionKind::Deep;
    case v1::DISPERSION_MODEL_SHALLOW: return DispersionKind::Shallow;
    case v1::DISPERSION_MODEL_CAPILLARY: return DispersionKind::Capillary;
    case v1::DISPERSION_MODEL_COMBINED: return DispersionKind::Combined;
    default:
      fail(Code::InvalidArgument, "config.dispersion = " + std::to_string(int(model)) +
                                      " must be a DispersionModel (DEEP, SHALLOW, CAPILLARY or COMBINED)");
  }
}

v1::DispersionModel dispersion(DispersionKind kind) {
  switch (kind) {
    case DispersionKind::Deep: return v1::DISPERSION_MODEL_DEEP;
    case DispersionKind::Shallow: return v1::DISPERSION_MODEL_SHALLOW;
    case DispersionKind::Capillary: return v1::DISPERSION_MODEL_CAPILLARY;
    case DispersionKind::Combined: return v1::DISPERSION_MODEL_COMBINED;
  }
  return v1::DISPERSION_MODEL_UNSPECIFIED;
}

// A shape's coordinates and extents, m: within +-1e9 (a shape that large covers any grid), so that the
// rasterizer's squares of them stay finite in float32.
const validate::Interval kShapeCoordinate = validate::closed(-1e9, 1e9);
const validate::Interval kShapeExtent = validate::open_closed(0, 1e9);

// A shape of a step (grid frame, metres), its fields checked under `path` ("inputs.shapes[2]").
Shape shape(const v1::EWaveShape& proto, const std::string& path) {
  Shape s;
  switch (proto.shape_case()) {
    case v1::EWaveShape::kCircle: {
      const auto& c = proto.circle();
      s.kind = ShapeKind::Circle;
      s.x = validate::in(path + ".circle.center_x", c.center_x(), kShapeCoordinate);
      s.y = validate::in(path + ".circle.center_y", c.center_y(), kShapeCoordinate);
      s.a = s.b = validate::in(path + ".circle.radius", c.radius(), kShapeExtent);
      break;
    }
    case v1::EWaveShape::kEllipse: {
      const auto& e = proto.ellipse();
      s.kind = ShapeKind::Ellipse;
      s.x = validate::in(path + ".ellipse.center_x", e.center_x(), kShapeCoordinate);
      s.y = validate::in(path + ".ellipse.center_y", e.center_y(), kShapeCoordinate);
      s.a = validate::in(path + ".ellipse.semi_axis_a", e.semi_axis_a(), kShapeExtent);
      s.b = validate::in(path + ".ellipse.semi_axis_b", e.semi_axis_b(), kShapeExtent);
      s.heading = validate::finite(path + ".ellipse.heading", e.heading());
      break;
    }
    case v1::EWaveShape::kBox: {
      const auto& b = proto.box();
      s.kind = ShapeKind::Box;
      s.x = validate::in(path + ".box.center_x", b.center_x(), kShapeCoordinate);
      s.y = validate::in(path + ".box.center_y", b.center_y(), kShapeCoordinate);
      s.a = validate::in(path + ".box.half_length", b.half_length(), kShapeExtent);
      s.b = validate::in(path + ".box.half_width", b.half_width(), kShapeExtent);
      s.heading = validate::finite(path + ".box.heading", b.heading());
      break;
    }
    case v1::EWaveShape::kPolygon: {
      const auto& p = proto.polygon();
      s.kind = ShapeKind::Polygon;
      if (p.vertices_size() < 3)
        fail(Code::InvalidArgument,
             path + ".polygon.vertices has " + std::to_string(p.vertices_size()) + " vertices, want >= 3");
      for (int v = 0; v < p.vertices_size(); ++v) {
        const std::string at = validate::at(path + ".polygon.vertices", v);
        s.vertices.push_back({validate::in(at + ".x", p.vertices(v).x(), kShapeCoordinate),
                              validate::in(at + ".y", p.vertices(v).y(), kShapeCoordinate)});
      }
      break;
    }
    default: fail(Code::InvalidArgument, path + " has no shape: set one of circle, ellipse, box, polygon");
  }
  return s;
}

std::vector<float> map(bool present, const v1::Field& field, const EWaveConfig& c, const std::string& path) {
  return present ? grid_values(field, c.nx, c.ny, path) : std::vector<float>{};
}

struct OutputInfo {
  const char* name;
  const char* unit;
};

OutputInfo info(v1::EWaveOutput o) {
  switch (o) {
    case v1::EWAVE_OUTPUT_HEIGHT: return {"height", "m"};
    case v1::EWAVE_OUTPUT_DISPLACEMENT_X: return {"displacement_x", "m"};
    case v1::EWAVE_OUTPUT_DISPLACEMENT_Y: return {"displacement_y", "m"};
    case v1::EWAVE_OUTPUT_NORMAL_X: return {"normal_x", "1"};
    case v1::EWAVE_OUTPUT_NORMAL_Y: return {"normal_y", "1"};
    case v1::EWAVE_OUTPUT_NORMAL_Z: return {"normal_z", "1"};
    case v1::EWAVE_OUTPUT_PHI: return {"phi", "m^2/s"};
    default: return {"", ""};
  }
}

// The values of one output: a plane of the engine frame itself, or one component of its normals (which
// come interleaved x, y, z) gathered into `scratch`.
const std::vector<float>& output_values(const Frame& f, v1::EWaveOutput o, std::vector<float>& scratch) {
  auto normal = [&](size_t component) -> const std::vector<float>& {
    scratch.resize(f.normals.size() / 3);
    for (size_t c = 0; c < scratch.size(); ++c) scratch[c] = f.normals[3 * c + component];
    return scratch;
  };
  switch (o) {
    case v1::EWAVE_OUTPUT_HEIGHT: return f.height;
    case v1::EWAVE_OUTPUT_DISPLACEMENT_X: return f.displacement_x;
    case v1::EWAVE_OUTPUT_DISPLACEMENT_Y: return f.displacement_y;
    case v1::EWAVE_OUTPUT_NORMAL_X: return normal(0);
    case v1::EWAVE_OUTPUT_NORMAL_Y: return normal(1);
    case v1::EWAVE_OUTPUT_NORMAL_Z: return normal(2);
    case v1::EWAVE_OUTPUT_PHI: return f.phi;
    default: fail(Code::Internal, "unknown EWaveOutput " + std::to_string(int(o)));
  }
}

}  // namespace

std::vector<float> grid_values(const v1::Field& field, int64_t nx, int64_t ny, const std::string& path) {
  if (int64_t(field.nx()) != nx)
    fail(Code::InvalidArgument,
         path + ".nx = " + std::to_string(field.nx()) + ", want the session's nx = " + std::to_string(nx));
  if (int64_t(field.ny()) != ny)
    fail(Code::InvalidArgument,
         path + ".ny = " + std::to_string(field.ny()) + ", want the session's ny = " + std::to_string(ny));
  if (field.nz() > 1)
    fail(Code::InvalidArgument, path + ".nz = " + std::to_string(field.nz()) + ", want 0 or 1 (a 2D field)");
  return squall::field::decode(field, path);  // dtype and byte count, named "<path>.dtype", "<path>.data"
}

EWaveConfig config(const v1::EWaveConfig& p, const LimitGate& gate) {
  validate_grid(p.nx(), p.ny(), &gate, "config");
  EWaveConfig c;
  c.nx = p.nx(), c.ny = p.ny();
  c.dx = p.dx(), c.dy = p.dy();
  c.dispersion = dispersion(p.dispersion());
  if (p.has_gravity()) c.gravity = p.gravity();
  c.depth = p.depth();
  c.capillary_length = p.capillary_length();
  c.trim = p.has_trim() ? p.trim() : true;
  c.trim_width = p.trim_width();
  if (p.has_trim_alpha()) c.trim_alpha = p.trim_alpha();
  c.friction_time = p.friction_time();
  c.source_scale = p.source_scale();
  c.mask_phi = p.mask_phi();
  c.double_precision = p.double_precision();
  if (p.has_displacement_scale()) c.displacement_scale = p.displacement_scale();
  c.initial_height = map(p.has_initial_height(), p.initial_height(), c, "config.initial_height");
  c.initial_phi = map(p.has_initial_phi(), p.initial_phi(), c, "config.initial_phi");
  if (p.has_start_time()) c.start_time = validate::finite("config.start_time.seconds", p.start_time().seconds());
  if (p.has_initial_ocean()) c.initial_ocean = ocean::rpc::tile_spec(p.initial_ocean(), gate, "config.initial_ocean");
  if (p.has_ambient_ocean()) c.ambient_ocean = ocean::rpc::tile_spec(p.ambient_ocean(), gate, "config.ambient_ocean");
  validate(c, &gate);  // ranges, finite values; messages name "config.<field>"
  return c;
}

void fill_config(const EWaveConfig& c, v1::EWaveConfig* p) {
  p->set_nx(uint32_t(c.nx)), p->set_ny(uint32_t(c.ny));
  p->set_dx(c.dx), p->set_dy(c.dy);
  p->set_dispersion(dispersion(c.dispersion));
  p->set_gravity(c.gravity);
  p->set_depth(c.depth);
  p->set_capillary_length(c.capillary_length);
  p->set_trim(c.trim);
  p->set_trim_width(c.effective_trim_width());
  p->set_trim_alpha(c.trim_alpha);
  p->set_friction_time(c.friction_time);
  p->set_source_scale(c.source_scale);
  p->set_mask_phi(c.mask_phi);
  p->set_double_precision(c.double_precision);
  p->set_displacement_scale(c.displacement_scale);  // start_time omitted, as the initial fields: not in force now
}

std::vector<v1::EWaveOutput> outputs(const v1::EWaveInputs& p) {
  std::vector<v1::EWaveOutput> list;
  std::set<int> seen;
  for (int i = 0; i < p.outputs_size(); ++i) {
    auto o = v1::EWaveOutput(p.outputs(i));
    const std::string at = validate::at("inputs.outputs", i);
    if (!*info(o).name) fail(Code::InvalidArgument, at + " = " + std::to_string(int(o)) + " is not an EWaveOutput");
    if (!seen.insert(o).second) fail(Code::InvalidArgument, at + " = " + v1::EWaveOutput_Name(o) + " is listed twice");
    list.push_back(o);
  }
  if (list.empty()) list.push_back(v1::EWAVE_OUTPUT_HEIGHT);
  return list;
}

StepInputs inputs(const v1::EWaveInputs& p, const EWaveConfig& c, const LimitGate& gate) {
  StepInputs in;
  in.dt = p.dt();
  in.obstruction = map(p.has_obstruction(), p.obstruction(), c, "inputs.obstruction");
  if (size_t(p.shapes_size()) > kMaxShapes)
    fail(Code::InvalidArgument,
         "inputs.shapes has " + std::to_string(p.shapes_size()) + " shapes, at most " + std::to_string(kMaxShapes));
  for (int s = 0; s < p.shapes_size(); ++s) in.shapes.push_back(shape(p.shapes(s), validate::at("inputs.shapes", s)));
  in.ambient_height = map(p.has_ambient_height(), p.ambient_height(), c, "inputs.ambient_height");
  if (p.has_ambient_ocean()) in.ambient_ocean = ocean::rpc::tile_spec(p.ambient_ocean(), gate, "inputs.ambient_ocean");
  in.source_height = map(p.has_source_height(), p.source_height(), c, "inputs.source_height");
  in.source_phi = map(p.has_source_phi(), p.source_phi(), c, "inputs.source_phi");
  in.drift_x = p.drift_x(), in.drift_y = p.drift_y();
  in.drift_field_x = map(p.has_drift_field_x(), p.drift_field_x(), c, "inputs.drift_field_x");
  in.drift_field_y = map(p.has_drift_field_y(), p.drift_field_y(), c, "inputs.drift_field_y");
  OutputSelection& o = in.outputs;
  o = {false, false, false, false};
  for (auto out : outputs(p)) {
    o.height |= out == v1::EWAVE_OUTPUT_HEIGHT;
    o.displacement |= out == v1::EWAVE_OUTPUT_DISPLACEMENT_X || out == v1::EWAVE_OUTPUT_DISPLACEMENT_Y;
    o.normals |=
        out == v1::EWAVE_OUTPUT_NORMAL_X || out == v1::EWAVE_OUTPUT_NORMAL_Y || out == v1::EWAVE_OUTPUT_NORMAL_Z;
    o.phi |= out == v1::EWAVE_OUTPUT_PHI;
  }
  validate(in, c, &gate);  // dt, value ranges, finite values; messages name "inputs.<field>"
  return in;
}

uint64_t frame_bytes(const EWaveConfig& c, size_t outputs, v1::DType d) {
  return outputs * (c.cells() * squall::field::bytes_per_value(d) + 128) + 256;
}

uint64_t frame_host_bytes(const EWaveConfig& c, const OutputSelection& o) {
  const uint64_t state_planes = uint64_t(o.height) + uint64_t(o.phi);
  const uint64_t float_planes = state_planes + 2 * uint64_t(o.displacement) + 4 * uint64_t(o.normals);
  return c.cells() * (float_planes * sizeof(float) + (c.double_precision ? state_planes * sizeof(double) : 0));
}

StepGuard guard(const v1::EWaveStepRequest& request, uint64_t session_serial) {
  if (request.retry_key().size() > kMaxRetryKeyBytes)
    fail(Code::InvalidArgument, "retry_key has " + std::to_string(request.retry_key().size()) + " bytes, at most " +
                                    std::to_string(kMaxRetryKeyBytes));
  StepGuard guard{request.retry_key(), std::nullopt, session_serial};
  if (request.has_after_step()) guard.after_step = request.after_step();
  return guard;
}

void fill_frame(const Frame& f, const EWaveConfig& c, const std::vector<v1::EWaveOutput>& outputs, v1::DType d,
                v1::EWaveFrame* reply) {
  reply->set_step(f.step);
  reply->mutable_time()->set_seconds(f.time);
  std::vector<float> scratch;
  for (auto o : outputs) {
    v1::Field* field = reply->add_fields();
    squall::field::encode({info(o).name, info(o).unit, uint32_t(c.nx), uint32_t(c.ny), 0, d},
                          output_values(f, o, scratch), field);
    field->mutable_spacing()->set_x(c.dx), field->mutable_spacing()->set_y(c.dy);
    field->mutable_origin()->set_x(0.5 * c.dx), field->mutable_origin()->set_y(0.5 * c.dy);
  }
}

}  // namespace squall::ewave::rpc
