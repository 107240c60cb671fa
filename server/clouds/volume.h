// A built cloud: sparse OpenVDB grids (density, optional temperature) and its summary. Building runs on
// the host (OpenVDB, TBB); rendering converts the grids to NanoVDB (nanovdb_volume.h). Equation and
// section numbers are those of J. Tessendorf, "Gilligan: A Prototype Framework for Simulating and
// Rendering Maritime Environments" (2017); App E is its App. E, J. Tessendorf, "Advection Solver Performance
// with Long Time Steps, and Strategies for Fast and Accurate Numerical Implementation" (2015).
#pragma once

#include <openvdb/openvdb.h>

#include <functional>
#include <string>
#include <vector>

#include "clouds/model.h"
#include "common/cancel.h"

namespace squall::clouds {

struct VolumeStats {
  uint64_t active_voxels = 0;  // of the density grid, active tiles counted by their voxels
  uint64_t leaf_nodes = 0;
  uint64_t bytes = 0;         // memory of the density tree (OpenVDB memUsage)
  openvdb::CoordBBox bounds;  // index bounding box of the active voxels
  uint64_t dense_voxels = 0;  // voxels of a dense grid over `bounds`
  uint64_t dense_bytes = 0;   // 4 bytes per dense voxel (eq 102)
  double fill_ratio() const { return dense_bytes ? double(bytes) / double(dense_bytes) : 0; }
};

struct CloudVolume {
  openvdb::FloatGrid::Ptr density;      // named "density", dimensionless in [0, amplitude], background 0
  openvdb::FloatGrid::Ptr temperature;  // named "temperature", K; null unless the model asks for it
  VolumeStats stats;
};

// Registers OpenVDB's types (idempotent, thread-safe). Called by every entry point below.
void initialize_openvdb();

// Validates and builds the model (throws squall::Error naming the field; ResourceExhausted when the
// active voxels exceed model.max_active_voxels). `cancel` is checked before each shape, between leaves of
// the displacement and the advection, and before each slab of a particle: Error(Cancelled) then.
CloudVolume build_cloud(const CloudModel& model, const std::string& field = "model", const Cancellation& cancel = {});

// The base level set (l > 0 inside, the convention of sec. 6.2.2) of the union of the model's spheres,
// ellipsoids and meshes, valid within at least `exterior` m outside and `interior` m inside the surface;
// beyond its band it holds -w outside and +w inside (w = the band's half width, >= both). Null when the
// model has no such shapes. `cancel` is asked before each shape (Error(Cancelled) naming `what`).
openvdb::FloatGrid::Ptr base_level_set(const CloudModel& model, double exterior, double interior,
                                       const Cancellation& cancel = {}, const std::string& what = "the base shapes");
// Eqs 105-112 applied to a level set (l > 0 inside); returns the displaced level set. `cancel` is asked
// between leaves.
openvdb::FloatGrid::Ptr pyroclastic_displace(const openvdb::FloatGrid& level_set, const Pyroclastic& pyro,
                                             const Cancellation& cancel = {},
                                             const std::string& what = "the pyroclastic displacement");
// Eq 103: rho = clamp(l / skin, 0, 1), active where rho > 0 (interior tiles stay tiles).
openvdb::FloatGrid::Ptr density_from_level_set(const openvdb::FloatGrid& level_set, double skin);
// Eqs 113-114: the particles stamped into `density` (max blend). `cancel` is asked before each slab of a
// particle's box (one voxel thick along x).
void stamp_particles(openvdb::FloatGrid& density, const std::vector<Particle>& particles, double skin,
                     const Cancellation& cancel = {}, const std::string& what = "the particles");
// Eqs 115-117 / App E: density(x) <- density(X(x)) with trilinear sampling, over the active set dilated by
// the largest displacement.
openvdb::FloatGrid::Ptr advect_density(const openvdb::FloatGrid& density, const Advection& advection,
                                       const Cancellation& cancel = {});
// The same with any steady velocity field whose speed is at most max_speed (m/s).
openvdb::FloatGrid::Ptr advect_density(const openvdb::FloatGrid& density, const std::function<Vec3d(const Vec3d&)>& u,
                                       double max_speed, double time, int substeps, AdvectionScheme scheme,
                                       const Cancellation& cancel = {});
// §6.3 on the active voxels of density; INVALID_ARGUMENT naming `field`.temperature where it leaves
// (0, kMaxTemperature] K (a lapse over a tall volume, or a fluctuation larger than the surface temperature).
openvdb::FloatGrid::Ptr temperature_field(const openvdb::FloatGrid& density, const Temperature& temperature,
                                          const std::string& field = "model", const Cancellation& cancel = {});
// Clouds of a library combined by maximum density (§6.2.5); the temperature follows the denser cloud.
CloudVolume combine_max(const CloudVolume& a, const CloudVolume& b);

VolumeStats volume_stats(const openvdb::FloatGrid& density);
// The grids as a .vdb file's bytes (what OpenVDB's tools read); the same volume, the same bytes (the
// header's UUID is made of the grids' bytes).
std::string write_vdb(const CloudVolume& volume);
// The grids of write_vdb's bytes back, with their stats; INVALID_ARGUMENT naming `field` when the bytes
// are no .vdb stream or hold no float grid named "density".
CloudVolume read_vdb(const std::string& bytes, const std::string& field);

}  // namespace squall::clouds
