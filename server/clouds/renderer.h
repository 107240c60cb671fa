// The cloud ray marcher on the device (kernels/clouds/render.cl): settings, validation, the deep shadow
// map pass and the render pass over NanoVDB grids uploaded as is.
#pragma once

#include <array>
#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "clouds/nanovdb_volume.h"
#include "clouds/occupancy.h"
#include "clouds/render_params.h"
#include "clouds/volume.h"
#include "common/cancel.h"
#include "common/limits.h"
#include "runtime/kernel.h"
#include "runtime/runtime.h"
#include "runtime/slices.h"

SQUALL_KERNEL_STRUCT(CloudRenderParams)

namespace squall::clouds {

enum class PhaseKind { Uniform = 0, HenyeyGreenstein = 1, DoubleHenyeyGreenstein = 2, FournierForand = 3 };
enum class LightKind { Point = 0, Directional = 1 };
enum class ShadowMode { None = 0, Direct = 1, DeepShadowMap = 2 };

struct Camera {
  Vec3d eye{0, -30, 0};             // m; components of every point and direction within +-1e7
  Vec3d look_at{0, 0, 0};           // m, != eye
  Vec3d up{0, 0, 1};                // not parallel to the view direction
  double vertical_fov_deg = 40;     // (0, 170)
  int64_t width = 64, height = 64;  // pixels, 1..8192 (held as sent, named so in errors)
};

struct Light {
  LightKind kind = LightKind::Directional;
  Vec3d position{0, 0, 100};      // point light, m
  Vec3d direction{0, 0, 1};       // directional: toward the light (normalized here)
  // Per wavelength: point W sr^-1 m^-1, directional W m^-2 m^-1; [0, 1e20]. A point light's irradiance at
  // distance d is intensity / max(d, r)^2, r half the volume's voxel (render.cl's sq_to_light).
  std::vector<double> intensity;
};

struct Phase {
  PhaseKind kind = PhaseKind::HenyeyGreenstein;
  double g1 = 0.8, g2 = -0.3, weight = 0.9;  // g in [-0.9999, 0.9999], weight in [0, 1]
  double ff_n = 1.05, ff_mu = 4.0;           // FF: n in [1.0001, 2], Junge slope mu in [3.5, 5]
};

struct RenderSettings {
  Camera camera;
  double step = 0.5;       // Delta s, m, > 0
  int64_t substeps = 1;    // N_s, 1..8
  bool trilinear = false;  // density interpolation (false: nearest voxel)
  uint32_t seed = 1;
  double min_transmittance = 1e-4;  // early termination of primary and shadow marches, [0, 1)
  double shadow_step = 0;           // m, >= 0: the step toward the lights; 0: 3 steps (vdb_render's 3 voxels)
  bool shadow_trilinear = false;    // trilinear density on the marches toward the lights (false: nearest voxel)
  Phase phase;
  std::vector<double> wavelengths{550e-9};  // m, [1e-8, 1e-3]; 1..8 channels
  std::vector<double> extinction{1.0};      // kappa per unit density, 1/m, [0, 1e6]; one per wavelength
  std::vector<double> albedo{0.9};          // [0, 1]; one per wavelength
  std::vector<Light> lights;                // 0..4
  ShadowMode shadow = ShadowMode::DeepShadowMap;
  std::array<int64_t, 3> shadow_map_size{64, 64, 64};  // DSM nodes per axis, 2..512
};

// Float image, channel-major planes: radiance per wavelength (W m^-2 sr^-1 m^-1), transmittance per
// wavelength, depth (m; -1 where the first wavelength's transmittance stays >= 0.5).
struct Image {
  int width = 0, height = 0;
  std::vector<std::string> channels;
  std::vector<float> data;
  float at(int channel, int x, int y) const { return data[(size_t(channel) * height + y) * width + x]; }
};

// The last deep shadow map made for a volume, kept for its next render with the same settings but the
// camera's: the map holds the column density toward each light at nodes over the volume's box, which does
// not depend on the camera, so the renders of a camera moving about a stored volume, or of several cameras
// on one, read the map of the first. Held in the daemon's memory budget while kept.
struct KeptShadowMap {
  std::mutex mutex;
  CloudRenderParams made_with{};  // the parameters of the render that made it, the camera's cleared
  cl::Buffer map;                 // none before the first
  // Its bytes in the memory budget, shared with the renders reading it (so that they stay counted until
  // the last reader is done, though the map is replaced or reclaimed meanwhile), and in the kept maps' own.
  std::shared_ptr<Slot> memory;
  Slot share;
  uint64_t made = 0;              // maps made for the volume, kept or not
  std::atomic<uint64_t> used{0};  // when a render last kept or read it, in its renderer's count
  bool listed = false;            // in its renderer's list of kept maps (reclaim())
};

// A map of at most this many bytes is kept: 16 MiB, a 128^3 map of two lights. A larger one leaves the
// volume's kept map as it was.
inline constexpr size_t kMaxKeptShadowMapBytes = size_t(16) << 20;
// The maps kept for all volumes together hold at most this many bytes (by default 64 MiB): no more of the
// memory budget than that is kept from calls. The volumes that keep maps keep them, first come, until they
// replace them or go; a map that would find no room in this share or in the memory budget is made for its
// render alone, and the volume's kept map stays.
inline constexpr size_t kMaxKeptShadowMapsBytes = size_t(64) << 20;

// A volume on the device: the NanoVDB buffers of its grids, byte for byte.
struct DeviceVolume {
  cl::Buffer density, temperature;
  cl::Buffer interior;  // interior_tiles() of the density
  bool has_temperature = false;
  Vec3d world_min{0, 0, 0}, world_max{0, 0, 0};  // the active voxels' cells, m; both 0 when none is
  // World boxes (min x, y, z, max x, y, z; m) of the density's active leaves and tiles grown by a voxel:
  // where the deep shadow map is needed (its nodes farther than one map cell from all are skipped).
  std::vector<std::array<double, 6>> occupied;
  CoarseOccupancy coarse;  // `occupied` on a coarse grid over the box: what a ray's march will cost
  uint64_t device_bytes = 0;
  double voxel_size = 1;  // m: a leaf node's side is 8 voxels
  // A stored volume's; none for a volume rendered once (a model in the request, an evolution's frame).
  std::shared_ptr<KeptShadowMap> kept_shadow_map;
};

// A volume's grids as NanoVDB buffers on the host, before they are uploaded: their size, the device
// memory the upload takes, is known here.
struct NanoGrids {
  NanoHandle density, temperature;  // temperature empty for a volume without one
  std::vector<uint32_t> interior;   // interior_tiles() of the density
  uint64_t bytes() const { return density.size() + temperature.size() + interior.size() * sizeof(uint32_t); }
};
NanoGrids to_nanovdb(const CloudVolume& volume);

// The grids on the device, with the boxes a render's empty-space skipping reads.
DeviceVolume upload_volume(Runtime& runtime, const CloudVolume& volume, const NanoGrids& grids);
inline DeviceVolume upload_volume(Runtime& runtime, const CloudVolume& volume) {
  return upload_volume(runtime, volume, to_nanovdb(volume));
}

// Density samples a render of `volume` would take, an upper bound computed before it runs: every primary
// ray crosses the volume's whole box diagonal in steps of s.step with s.substeps samples each, a step cut
// short at every tree node it leaves (march_steps); with direct shadows every sample marches such a ray
// toward each light; a deep shadow map marches one per map node and light. Early termination and
// empty-space skipping only make the real count smaller. By part: per pixel (primary march and direct
// shadows), per deep shadow map node, and in all.
struct SampleEstimate {
  double per_pixel = 0, per_map_node = 0, map_nodes = 0, total = 0;
};
SampleEstimate estimate_samples(const DeviceVolume& volume, const RenderSettings& s);

// A pixel's march runs to its end once started: this bound on its density samples bounds how long one
// slice (a tile of 64 pixels) can hold the device, and so how soon a cancelled render lets go of it.
inline constexpr double kMaxSamplesPerPixel = 1e7;

// Throws squall::Error(InvalidArgument) naming the field (prefix + ".camera.width", ...).
void validate(const RenderSettings& settings, const std::string& prefix = "render");

// The kernels march in float: a step below about 2^-24 of the distance it is taken at rounds back to
// where it started, and the march would never end. A march counts its distance from where it enters the
// volume's box (or from the eye, inside it), so steps are refused below kMinStepOfDistance of the box's
// diagonal (8 float ulps, a margin over that), the primary step and the shadow step alike. Throws
// squall::Error(InvalidArgument) naming prefix + ".step" or prefix + ".shadow_step" and the least step.
inline constexpr double kMinStepOfDistance = 0x1p-20;
void check_march_resolution(const DeviceVolume& volume, const RenderSettings& s, const std::string& prefix);

// Bytes a render's deep shadow map takes while the render runs, 0 for a render with none: a float per
// map node and light, and the mask of needed nodes (a byte per node) on the host and on the device.
uint64_t shadow_map_bytes(const RenderSettings& s);

// How a render deals its work items (pixels, deep shadow map entries) to the device. A work-group of 8x8
// pixels (64 entries) suits a GPU. A CPU device runs a work-group as one thread's loop, and PoCL's pthread
// device deals each thread a fixed run of work-groups (on two threads 64, or half of what is left of a small
// launch): a run that held a cloud's costly tiles kept one core busy while the other had none. There a
// work-item a compute unit takes runs of 8 items from a counter the work-items share (the map's entries
// too: its needed ones gather where the cloud is). Both compile the same code for an item and gave the same
// images, bit for bit, where measured (Render.BothWorkSchedulesRenderTheSameImage, on the tests' device).
enum class WorkSchedule {
  Auto,           // SharedCounter on a CPU device, WorkGroups elsewhere
  WorkGroups,     // a work-item an item, in work-groups of 64
  SharedCounter,  // a work-item a compute unit, runs of 8 items from a shared counter
};

class CloudRenderer : public MemoryReclaimer {
 public:
  // Creates the render.cl kernels (and checks their signatures): the runtime has built "clouds/". The
  // shadow maps kept for volumes hold their bytes in `gate`'s memory budget (none: not counted) as cached
  // memory, which a call that needs the room takes back, and at most `max_kept_maps_bytes` together.
  explicit CloudRenderer(Runtime& runtime, LimitGate* gate = nullptr,
                         size_t max_kept_maps_bytes = kMaxKeptShadowMapsBytes);
  ~CloudRenderer() override;
  CloudRenderer(const CloudRenderer&) = delete;
  CloudRenderer& operator=(const CloudRenderer&) = delete;
  // Renders in slices of 8x8 tiles (the shadow map in slices of nodes) sized by their estimated cost,
  // checking `cancel` between them: a cancelled render frees the device within a slice (Error(Cancelled)).
  // A deep shadow map is made, or taken from the volume's KeptShadowMap, and kept for its next render when
  // at most kMaxKeptShadowMapBytes and within the kept maps' share (else the next render makes its own). A
  // map made holds shadow_map_bytes() in `gate`'s memory budget while the render runs (RESOURCE_EXHAUSTED
  // where there is no room), unless `map_memory`, the caller's, holds that much (a stream's, for all its
  // frames); a kept one holds its own bytes from then on, as cached memory: counted once.
  Image render(const DeviceVolume& volume, const RenderSettings& settings, const std::string& field = "render",
               const Cancellation& cancel = {}, const Slot* map_memory = nullptr);
  // Drops kept maps, least recently used first, until `bytes` are given back: their volumes' next renders
  // make them again. A map a render is reading now is left kept (its bytes go back only after that render).
  uint64_t reclaim(uint64_t bytes) override;
  // The way renders deal their work from now on (Auto at construction): a benchmark or a test compares them.
  void set_work_schedule(WorkSchedule schedule) { schedule_ = schedule; }

 private:
  struct ShadowMap;
  // Sets `map` to what a render of `p` reads: the volume's kept map, else one made now on `lease`'s queue
  // (left running), else (no deep shadow map) one float the render does not read.
  void make_shadow_map(ShadowMap& map, const DeviceVolume& volume, const RenderSettings& settings,
                       const CloudRenderParams& p, QueueLease& lease, const Cancellation& cancel,
                       const std::string& field, const Slot* map_memory);
  // Launches that share their work: whether the schedule (Auto resolved) is SharedCounter, their
  // work-items (one a compute unit), and a counter at 0 for one (filled on the lease's queue).
  bool shares_work() const;
  cl::NDRange sharing_items() const;
  BufferLease shared_counter();
  // Enqueue tiles first .. first + count - 1 of the image, and entries first .. first + count - 1 of a deep
  // shadow map (those past its end do nothing), as the schedule says.
  void launch_tiles(const DeviceVolume& volume, const cl::Buffer& map, const CloudRenderParams& p,
                    const cl::Buffer& out, const TileGrid& tiles, size_t first, size_t count);
  void launch_map_entries(const DeviceVolume& volume, const CloudRenderParams& p, const cl::Buffer& needed,
                          const cl::Buffer& map, size_t first, size_t count);
  bool may_keep(const KeptShadowMap& kept, size_t bytes) const;  // under kept.mutex
  // Keeps a map made for a render, once the render has waited for its queue.
  void keep(const DeviceVolume& volume, ShadowMap& map);
  std::vector<std::shared_ptr<KeptShadowMap>> kept_maps();  // the maps kept now, least recently used first

  Runtime& runtime_;
  LimitGate* gate_;
  // Its memory budget: the kept maps' bytes, all volumes together. A KeptShadowMap gives its share back to
  // it, so the volumes that keep maps must not outlive the renderer.
  LimitGate kept_maps_;
  std::mutex kept_mutex_;                           // guards kept_; no map's mutex is taken under it
  std::vector<std::weak_ptr<KeptShadowMap>> kept_;  // the volumes' maps that keep() has kept
  std::atomic<uint64_t> uses_{0};                   // KeptShadowMap::used
  // density, interior, p, needed, dsm
  Kernel<cl::Buffer, cl::Buffer, CloudRenderParams, cl::Buffer, cl::Buffer> shadow_map_;
  // density, interior, p, needed, dsm, first entry, entries, next entry
  Kernel<cl::Buffer, cl::Buffer, CloudRenderParams, cl::Buffer, cl::Buffer, cl_uint, cl_uint, cl::Buffer>
      shadow_map_shared_;
  // density, interior, temperature, dsm, p, out
  Kernel<cl::Buffer, cl::Buffer, cl::Buffer, cl::Buffer, CloudRenderParams, cl::Buffer> render_;
  // density, interior, temperature, dsm, p, out, first tile, tiles, tiles a row, next pixel: on CPU devices
  Kernel<cl::Buffer, cl::Buffer, cl::Buffer, cl::Buffer, CloudRenderParams, cl::Buffer, cl_uint, cl_uint, cl_uint,
         cl::Buffer>
      render_shared_;
  std::atomic<WorkSchedule> schedule_{WorkSchedule::Auto};
};

}  // namespace squall::clouds
