#include "clouds/clouds_request.h"

#include "clouds/build_memory.h"
#include "clouds/obj_mesh.h"
#include "common/error.h"
#include "common/validate.h"
#include "common/field_codec.h"

namespace squall::clouds::rpc {
namespace v1 = squall::v1;

namespace {

Vec3d vec(const v1::Vec3& v) { return {v.x(), v.y(), v.z()}; }
void put(const Vec3d& v, v1::Vec3* out) {
  out->set_x(v[0]);
  out->set_y(v[1]);
  out->set_z(v[2]);
}

NoiseParams noise(const v1::NoiseSpec& n) {
  NoiseParams p;
  p.frequency = n.has_frequency() ? n.frequency() : 0.1;
  p.octaves = n.has_octaves() ? n.octaves() : 4;
  p.roughness = n.has_roughness() ? n.roughness() : 0.5;
  p.frequency_jump = n.has_frequency_jump() ? n.frequency_jump() : 2.2;
  p.offset = vec(n.offset());
  return p;
}

TriangleMesh mesh(const v1::MeshSpec& m, const std::string& field) {
  if (!m.obj().empty()) {
    if (m.vertices_size() || m.triangles_size())
      fail(Code::InvalidArgument, field + " has both obj and vertices/triangles; send one of them");
    return parse_obj(m.obj(), field + ".obj");
  }
  if (m.vertices_size() % 3 != 0)
    fail(Code::InvalidArgument,
         field + ".vertices has " + std::to_string(m.vertices_size()) + " numbers; it needs x, y, z per vertex");
  TriangleMesh out;
  out.vertices.reserve(size_t(m.vertices_size() / 3));
  for (int i = 0; i < m.vertices_size(); i += 3)
    out.vertices.push_back({m.vertices(i), m.vertices(i + 1), m.vertices(i + 2)});
  out.triangles.assign(m.triangles().begin(), m.triangles().end());
  return out;
}

}  // namespace

CloudModel model(const v1::CloudModel& m, const std::string& f) {
  CloudModel out;
  out.voxel_size = m.voxel_size();
  out.skin = m.has_skin() ? m.skin() : 2 * m.voxel_size();
  for (const auto& s : m.spheres()) out.spheres.push_back({vec(s.center()), s.radius()});
  for (const auto& e : m.ellipsoids()) out.ellipsoids.push_back({vec(e.center()), vec(e.radii())});
  for (int i = 0; i < m.meshes_size(); ++i) out.meshes.push_back(mesh(m.meshes(i), validate::at(f + ".meshes", i)));
  const auto& p = m.pyroclastic();
  out.pyroclastic.layers = p.layers();
  out.pyroclastic.amplitude = p.amplitude();
  out.pyroclastic.gamma = p.has_gamma() ? p.gamma() : 1.0;
  out.pyroclastic.noise = noise(p.noise());
  for (const auto& q : m.particles()) {
    Particle particle;
    particle.center = vec(q.center());
    particle.radius = q.radius();
    particle.amplitude = q.has_amplitude() ? q.amplitude() : 1.0;
    particle.bias = q.has_bias() ? q.bias() : 0.5;
    particle.fade = q.has_fade() ? q.fade() : 1.0;
    particle.noise = noise(q.noise());
    out.particles.push_back(particle);
  }
  const auto& a = m.advection();
  out.advection.speed = a.speed();
  out.advection.time = a.time();
  out.advection.substeps = a.has_substeps() ? a.substeps() : 1;
  validate::known(f + ".advection.scheme", a.scheme(), v1::AdvectionScheme_ARRAYSIZE, "AdvectionScheme");
  out.advection.scheme = a.scheme() == v1::ADVECTION_SCHEME_SEMI_LAGRANGIAN ? AdvectionScheme::SemiLagrangian
                                                                            : AdvectionScheme::ModifiedMacCormack;
  out.advection.noise = noise(a.noise());
  const auto& t = m.temperature();
  out.temperature.enabled = t.enabled();
  out.temperature.surface = t.has_surface() ? t.surface() : 288.15;
  out.temperature.base_altitude = t.base_altitude();
  out.temperature.lapse_rate = t.has_lapse_rate() ? t.lapse_rate() : 0.0065;
  out.temperature.fluctuation = t.fluctuation();
  out.temperature.noise = noise(t.noise());
  if (m.has_max_active_voxels()) {
    if (m.max_active_voxels() == 0) fail(Code::InvalidArgument, f + ".max_active_voxels = 0 must be >= 1");
    out.max_active_voxels = m.max_active_voxels();
  } else {
    out.max_active_voxels = ~0ull;  // the engine's cap applies
  }
  return out;
}

uint64_t mesh_read_bytes(const v1::CloudModel& m) {
  uint64_t bytes = 0;
  for (const v1::MeshSpec& mesh : m.meshes()) {
    const ObjCounts counts = mesh.obj().empty() ? ObjCounts{(uint64_t(mesh.vertices_size()) + 2) / 3,
                                                            (uint64_t(mesh.triangles_size()) + 2) / 3}
                                                : count_obj(mesh.obj());
    bytes += clouds::mesh_read_bytes(counts.vertices, counts.triangles);
  }
  return bytes;
}

RenderSettings settings(const v1::RenderSettings& s, const std::string& f) {
  // Unset, the camera would stand at the point it looks at: say what is missing instead.
  if (!s.has_camera()) fail(Code::InvalidArgument, f + ".camera is unset: a render needs its eye, look_at and size");
  RenderSettings out;
  const auto& c = s.camera();
  out.camera.eye = vec(c.eye());
  out.camera.look_at = vec(c.look_at());
  out.camera.up = vec(c.up());
  out.camera.vertical_fov_deg = c.has_vertical_fov_deg() ? c.vertical_fov_deg() : 40.0;
  out.camera.width = c.width();
  out.camera.height = c.height();
  out.step = s.step();
  out.substeps = s.has_substeps() ? s.substeps() : 1;
  out.trilinear = s.trilinear();
  out.seed = s.seed();
  out.min_transmittance = s.has_min_transmittance() ? s.min_transmittance() : 1e-4;
  out.shadow_step = s.shadow_step();
  out.shadow_trilinear = s.shadow_trilinear();
  const auto& ph = s.phase();
  switch (ph.kind()) {
    case v1::PHASE_KIND_UNIFORM: out.phase.kind = PhaseKind::Uniform; break;
    case v1::PHASE_KIND_DOUBLE_HENYEY_GREENSTEIN: out.phase.kind = PhaseKind::DoubleHenyeyGreenstein; break;
    case v1::PHASE_KIND_FOURNIER_FORAND: out.phase.kind = PhaseKind::FournierForand; break;
    case v1::PHASE_KIND_UNSPECIFIED:
    case v1::PHASE_KIND_HENYEY_GREENSTEIN: out.phase.kind = PhaseKind::HenyeyGreenstein; break;
    default: fail(Code::InvalidArgument, f + ".phase.kind = " + std::to_string(ph.kind()) + " is not a PhaseKind");
  }
  if (ph.has_g1()) out.phase.g1 = ph.g1();
  if (ph.has_g2()) out.phase.g2 = ph.g2();
  if (ph.has_weight()) out.phase.weight = ph.weight();
  if (ph.has_ff_n()) out.phase.ff_n = ph.ff_n();
  if (ph.has_ff_mu()) out.phase.ff_mu = ph.ff_mu();
  if (s.wavelengths_size()) out.wavelengths.assign(s.wavelengths().begin(), s.wavelengths().end());
  if (s.extinction_size())
    out.extinction.assign(s.extinction().begin(), s.extinction().end());
  else
    out.extinction.assign(out.wavelengths.size(), 0.1);
  if (s.albedo_size())
    out.albedo.assign(s.albedo().begin(), s.albedo().end());
  else
    out.albedo.assign(out.wavelengths.size(), 0.9);
  for (int i = 0; i < s.lights_size(); ++i) {
    const auto& l = s.lights(i);
    validate::known(validate::at(f + ".lights", i) + ".kind", l.kind(), v1::LightKind_ARRAYSIZE, "LightKind");
    Light light;
    light.kind = l.kind() == v1::LIGHT_KIND_POINT ? LightKind::Point : LightKind::Directional;
    light.position = vec(l.position());
    light.direction = vec(l.direction());
    light.intensity.assign(l.intensity().begin(), l.intensity().end());
    out.lights.push_back(light);
  }
  switch (s.shadow()) {
    case v1::SHADOW_MODE_NONE: out.shadow = ShadowMode::None; break;
    case v1::SHADOW_MODE_DIRECT: out.shadow = ShadowMode::Direct; break;
    case v1::SHADOW_MODE_UNSPECIFIED:
    case v1::SHADOW_MODE_DEEP_SHADOW_MAP: out.shadow = ShadowMode::DeepShadowMap; break;
    default: fail(Code::InvalidArgument, f + ".shadow = " + std::to_string(s.shadow()) + " is not a ShadowMode");
  }
  if (s.shadow_map_size_size()) {
    if (s.shadow_map_size_size() != 3)
      fail(Code::InvalidArgument, f + ".shadow_map_size has " + std::to_string(s.shadow_map_size_size()) +
                                      " entries; it needs 3 (x, y, z) or none");
    for (int a = 0; a < 3; ++a) out.shadow_map_size[a] = s.shadow_map_size(a);
  }
  return out;
}

Evolution evolution(const v1::EvolutionSpec& e) {
  Evolution out;
  out.drift = vec(e.drift());
  out.noise_drift = vec(e.noise_drift());
  out.amplitude_rate = e.amplitude_rate();
  out.advection_rate = e.advection_rate();
  out.velocity_drift = vec(e.velocity_drift());
  return out;
}

void fill_summary(const StoredVolume& v, v1::VolumeSummary* out) {
  out->set_volume_id(v.id);
  put(v.device.world_min, out->mutable_bounds_min());
  put(v.device.world_max, out->mutable_bounds_max());
  out->set_voxel_size(v.volume.density->voxelSize()[0]);
  const auto& s = v.volume.stats;
  out->set_active_voxels(s.active_voxels);
  out->set_bytes(s.bytes);
  out->set_dense_bytes(s.dense_bytes);
  out->set_fill_ratio(s.fill_ratio());
  out->set_device_bytes(v.device.device_bytes);
  out->set_has_temperature(v.device.has_temperature);
}

void fill_image(const Image& image, v1::CloudImage* out) {
  out->set_width(uint32_t(image.width));
  out->set_height(uint32_t(image.height));
  for (const auto& c : image.channels) out->add_channels(c);
  out->clear_data();
  squall::field::append_bytes(image.data.data(), image.data.size(), v1::DTYPE_FLOAT32, out->mutable_data());
}

uint64_t image_bytes(const RenderSettings& s) {
  return uint64_t(s.camera.width) * uint64_t(s.camera.height) * (2 * s.wavelengths.size() + 1) * sizeof(float);
}

}  // namespace squall::clouds::rpc
