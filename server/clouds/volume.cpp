// build_cloud and the whole-grid operations: advection (eqs 115-117), temperature (sec. 6.3), max-density
// combination (sec. 6.2.5), statistics and .vdb output; numbers from J. Tessendorf, "Gilligan: A Prototype
// Framework for Simulating and Rendering Maritime Environments" (2017).
#include "clouds/volume.h"

#include <openvdb/io/Stream.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/Morphology.h>
#include <openvdb/tools/Prune.h>
#include <openvdb/tree/LeafManager.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <sstream>

#include "clouds/advection.h"
#include "common/error.h"
#include "common/fnv1a.h"
#include "common/validate.h"

namespace squall::clouds {

using openvdb::FloatGrid;

void initialize_openvdb() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

namespace {

// Keeps only voxels and tiles with a positive value active, drops empty leaves, merges uniform ones.
void tidy_density(FloatGrid& grid) {
  for (auto it = grid.tree().beginValueAll(); it; ++it) it.setActiveState(*it > 0);
  openvdb::tools::pruneInactive(grid.tree());
  openvdb::tools::prune(grid.tree());
}

void check_budget(const FloatGrid& density, const CloudModel& model, const std::string& field, const char* stage) {
  uint64_t active = density.tree().activeVoxelCount();
  if (active > model.max_active_voxels)
    fail(Code::ResourceExhausted, field + ": " + std::to_string(active) + " active voxels after " + stage + " exceed " +
                                      field + ".max_active_voxels = " + std::to_string(model.max_active_voxels));
}

}  // namespace

FloatGrid::Ptr advect_density(const FloatGrid& density, const Advection& advection, const Cancellation& cancel) {
  return advect_density(density, noise_velocity(advection), std::sqrt(3.0) * advection.speed, advection.time,
                        advection.substeps, advection.scheme, cancel);
}

FloatGrid::Ptr advect_density(const FloatGrid& density, const VelocityField& u, double max_speed, double time,
                              int substeps, AdvectionScheme scheme, const Cancellation& cancel) {
  const double dx = density.transform().voxelSize()[0];
  FloatGrid::Ptr out = density.deepCopy();
  out->tree().voxelizeActiveTiles();
  int dilation = int(std::ceil(advection_reach(max_speed, time) / dx)) + 1;
  openvdb::tools::dilateActiveValues(out->tree(), dilation, openvdb::tools::NN_FACE_EDGE_VERTEX,
                                     openvdb::tools::EXPAND_TILES);
  openvdb::tree::LeafManager<openvdb::FloatTree> leaves(out->tree());
  std::atomic<bool> cancelled{false};
  leaves.foreach ([&](openvdb::FloatTree::LeafNodeType& leaf, size_t) {
    if (cancelled || cancel.requested()) {  // a leaf (512 voxels) is the slice
      cancelled = true;
      return;
    }
    auto in = density.getConstAccessor();
    openvdb::tools::GridSampler<FloatGrid::ConstAccessor, openvdb::tools::BoxSampler> sampler(in, density.transform());
    for (auto it = leaf.beginValueOn(); it; ++it) {
      openvdb::Vec3d x = density.transform().indexToWorld(it.getCoord());
      Vec3d X = characteristic_map(u, {x[0], x[1], x[2]}, time, substeps, scheme);
      it.setValue(sampler.wsSample(openvdb::Vec3d(X[0], X[1], X[2])));  // eq 116: rho(X(x))
    }
  });
  if (cancelled) Cancellation::stopped("advection");
  tidy_density(*out);
  return out;
}

FloatGrid::Ptr temperature_field(const FloatGrid& density, const Temperature& t, const std::string& field,
                                 const Cancellation& cancel) {
  FloatGrid::Ptr out = FloatGrid::create(0.0f);
  out->setTransform(density.transform().copy());
  out->tree().topologyUnion(density.tree());
  out->tree().voxelizeActiveTiles();
  out->setName("temperature");
  openvdb::tree::LeafManager<openvdb::FloatTree> leaves(out->tree());
  std::vector<double> lowest(leaves.leafCount(), INFINITY), highest(leaves.leafCount(), -INFINITY);
  std::atomic<bool> cancelled{false};
  leaves.foreach ([&](openvdb::FloatTree::LeafNodeType& leaf, size_t n) {
    if (cancelled || cancel.requested()) {  // a leaf is the slice: up to 512 fractal noises
      cancelled = true;
      return;
    }
    for (auto it = leaf.beginValueOn(); it; ++it) {
      openvdb::Vec3d x = out->transform().indexToWorld(it.getCoord());
      double T = t.surface - t.lapse_rate * (x[2] - t.base_altitude);  // hydrostatic lapse (§6.3)
      if (t.fluctuation > 0) T += t.fluctuation * fractal_noise(t.noise, {x[0], x[1], x[2]});
      lowest[n] = std::min(lowest[n], T), highest[n] = std::max(highest[n], T);
      it.setValue(float(std::clamp(T, 0.0, kMaxTemperature)));  // as it is wherever the field is kept
    }
  });
  if (cancelled) Cancellation::stopped(field + ": the temperature");
  if (lowest.empty()) return out;  // no voxel (voxelized, every active value is in a leaf)
  const double T_min = *std::min_element(lowest.begin(), lowest.end());
  const double T_max = *std::max_element(highest.begin(), highest.end());
  if (T_min > 0 && T_max <= kMaxTemperature) return out;
  fail(Code::InvalidArgument, field + ".temperature makes temperatures from " + validate::number(T_min) + " K to " +
                                  validate::number(T_max) + " K over the volume; they must lie in (0, " +
                                  validate::number(kMaxTemperature) +
                                  "] K: mind surface, base_altitude, lapse_rate and fluctuation");
}

CloudVolume combine_max(const CloudVolume& a, const CloudVolume& b) {
  CloudVolume out;
  out.density = a.density->deepCopy();
  if (a.temperature) out.temperature = a.temperature->deepCopy();
  auto rho = out.density->getAccessor();
  auto rho_a = a.density->getConstAccessor();
  std::unique_ptr<FloatGrid::Accessor> temp;
  if (out.temperature) temp = std::make_unique<FloatGrid::Accessor>(out.temperature->getAccessor());
  auto temp_b = b.temperature ? std::make_unique<FloatGrid::ConstAccessor>(b.temperature->getConstAccessor()) : nullptr;
  FloatGrid::Ptr b_voxels = b.density->deepCopy();
  b_voxels->tree().voxelizeActiveTiles();
  for (auto it = b_voxels->cbeginValueOn(); it; ++it) {
    const openvdb::Coord ijk = it.getCoord();
    if (*it <= rho_a.getValue(ijk)) continue;
    rho.setValue(ijk, *it);
    if (temp && temp_b) temp->setValue(ijk, temp_b->getValue(ijk));
  }
  openvdb::tools::prune(out.density->tree());
  out.stats = volume_stats(*out.density);
  return out;
}

VolumeStats volume_stats(const FloatGrid& density) {
  VolumeStats s;
  s.active_voxels = density.tree().activeVoxelCount();
  s.leaf_nodes = density.tree().leafCount();
  s.bytes = density.tree().memUsage();
  s.bounds = density.evalActiveVoxelBoundingBox();
  s.dense_voxels = s.active_voxels ? s.bounds.volume() : 0;
  // saturated: a box 1.7e6 voxels a side (spheres at +-8.5e5 m in 1 m voxels) has 4.9e18 voxels
  s.dense_bytes = s.dense_voxels > UINT64_MAX / 4 ? UINT64_MAX : 4 * s.dense_voxels;
  return s;
}

namespace {

// OpenVDB's stream header (io::Archive::writeHeader): the magic number (8 bytes), the file version and the
// library's major and minor versions (4 each), whether grid offsets follow (1), then a random UUID as 36
// characters, "xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx".
constexpr size_t kUuidAt = 21, kUuidLength = 36;

bool is_uuid_text(std::string_view text) {
  if (text.size() != kUuidLength) return false;
  for (size_t k = 0; k < kUuidLength; ++k)
    if (k == 8 || k == 13 || k == 18 || k == 23 ? text[k] != '-' : !std::isxdigit(static_cast<unsigned char>(text[k])))
      return false;
  return true;
}

// Replaces the stream's random UUID by one made of its grids' bytes (their FNV-1a fingerprint, and that
// fingerprint's own with the byte count), so that the same volume is always the same bytes; a header laid
// out otherwise is left as it is.
void derive_uuid(std::string& vdb) {
  if (vdb.size() < kUuidAt + kUuidLength || !is_uuid_text(std::string_view(vdb).substr(kUuidAt, kUuidLength))) return;
  const char* rest = vdb.data() + kUuidAt + kUuidLength;
  const size_t count = vdb.size() - kUuidAt - kUuidLength;
  const uint64_t first = fnv1a(kFnv1aOffsetBasis, rest, count), tail[2] = {first, uint64_t(count)};
  const uint64_t halves[2] = {first, fnv1a(kFnv1aOffsetBasis, tail, sizeof tail)};
  char hex[33];
  std::snprintf(hex, sizeof hex, "%016llx%016llx", (unsigned long long)halves[0], (unsigned long long)halves[1]);
  const std::string digits(hex);
  const std::string uuid = digits.substr(0, 8) + "-" + digits.substr(8, 4) + "-" + digits.substr(12, 4) + "-" +
                           digits.substr(16, 4) + "-" + digits.substr(20, 12);
  vdb.replace(kUuidAt, kUuidLength, uuid);
}

// Density is finite and >= 0 in every voxel and tile, active or not, and in the background: the marches read
// them all (a leaf's inactive voxels through trilinear samples), and tell a leaf from a tile by a tile's
// value being >= 0.
void check_density_values(const FloatGrid& density, const std::string& field) {
  auto check = [&](float value, auto where) {
    if (!(value >= 0 && std::isfinite(value)))
      fail(Code::InvalidArgument, field + ": its density grid holds " + validate::number(value) + " at " + where() +
                                      ": density must be finite and >= 0");
  };
  check(density.background(), [] { return std::string("the background"); });
  for (auto it = density.cbeginValueAll(); it; ++it)
    check(*it, [&] { return (it.isVoxelValue() ? "voxel " : "the tile at ") + validate::xyz(it.getCoord()); });
}

}  // namespace

std::string write_vdb(const CloudVolume& volume) {
  initialize_openvdb();
  openvdb::GridCPtrVec grids{volume.density};
  if (volume.temperature) grids.push_back(volume.temperature);
  std::ostringstream bytes(std::ios::binary);
  openvdb::io::Stream(bytes).write(grids);
  std::string vdb = bytes.str();
  derive_uuid(vdb);
  return vdb;
}

CloudVolume read_vdb(const std::string& bytes, const std::string& field) {
  initialize_openvdb();
  std::istringstream in(bytes, std::ios::binary);
  openvdb::GridPtrVecPtr grids;
  try {
    // Read at once: a delayed load would first copy the bytes to a temporary file, left behind when the
    // stream is not a .vdb one.
    grids = openvdb::io::Stream(in, /*delayLoad=*/false).getGrids();
  } catch (const openvdb::Exception& e) {
    fail(Code::InvalidArgument, field + " is not a .vdb stream: " + e.what());
  }
  CloudVolume volume;
  for (const auto& grid : *grids) {
    auto floats = openvdb::gridPtrCast<FloatGrid>(grid);
    if (floats && floats->getName() == "density") volume.density = floats;
    if (floats && floats->getName() == "temperature") volume.temperature = floats;
  }
  if (!volume.density) fail(Code::InvalidArgument, field + " holds no float grid named \"density\"");
  check_density_values(*volume.density, field);
  volume.stats = volume_stats(*volume.density);
  return volume;
}

CloudVolume build_cloud(const CloudModel& model, const std::string& field, const Cancellation& cancel) {
  initialize_openvdb();
  validate(model, field);
  const double dx = model.voxel_size;
  FloatGrid::Ptr density;
  const double exterior = pyroclastic_bound(model.pyroclastic) + 3 * dx, interior = model.skin + 3 * dx;
  if (auto ls = base_level_set(model, exterior, interior, cancel, field + ": the base shapes")) {
    if (model.pyroclastic.layers > 0)
      ls = pyroclastic_displace(*ls, model.pyroclastic, cancel, field + ": the pyroclastic displacement");
    density = density_from_level_set(*ls, model.skin);
  } else {
    density = FloatGrid::create(0.0f);
    density->setTransform(openvdb::math::Transform::createLinearTransform(dx));
    density->setName("density");
    density->setGridClass(openvdb::GRID_FOG_VOLUME);
  }
  check_budget(*density, model, field, "the base shapes");
  stamp_particles(*density, model.particles, model.skin, cancel, field + ": the particles");
  check_budget(*density, model, field, "stamping");
  if (model.advection.speed > 0 && model.advection.time > 0) {
    density = advect_density(*density, model.advection, cancel);
    check_budget(*density, model, field, "advection");
  }
  CloudVolume volume;
  volume.density = density;
  cancel.check(field + ": the build");
  if (model.temperature.enabled) volume.temperature = temperature_field(*density, model.temperature, field, cancel);
  volume.stats = volume_stats(*density);
  return volume;
}

}  // namespace squall::clouds
