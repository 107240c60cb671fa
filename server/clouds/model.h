// A cloud model: what to build (J. Tessendorf, "Gilligan: A Prototype Framework for Simulating and Rendering
// Maritime Environments" (2017), sec. 6.2, the "Bishop" workflow). Plain data, SI units; validated by
// validate() before anything is built. Level sets follow Gilligan's convention (sec. 6.2.2): l > 0 inside.
// Altitude is +z (the temperature lapse and the renderer's "up" use it).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "clouds/noise.h"

namespace squall::clouds {

struct Sphere {
  Vec3d center{0, 0, 0};  // m, finite
  double radius = 1;      // m, > 0
};

struct Ellipsoid {
  Vec3d center{0, 0, 0};  // m, finite
  Vec3d radii{1, 1, 1};   // semi-axes along x, y, z, m, each > 0
};

struct TriangleMesh {
  std::vector<Vec3d> vertices;      // m, finite, >= 4
  std::vector<uint32_t> triangles;  // 3 vertex indices per triangle, counter-clockwise seen from outside
  bool from_obj = false;            // errors name vertex k as the OBJ text's (k + 1)th, else as vertices[3k..3k+2]
};

// Cumulo pyroclastic displacement (eqs 105-112): layer n adds amplitude * |N_n(X)|^gamma to l, with
// N_n(x) = r^n N_0(x f_jump^n), N_0 = the normalized fractal noise, X = x - l grad l (CPT/PPT).
struct Pyroclastic {
  int64_t layers = 0;    // 0 = off, <= 8 (held as sent, named so in errors)
  double amplitude = 1;  // m, >= 0: the largest displacement of one layer
  double gamma = 1;      // valley sharpness, (0, 16]
  NoiseParams noise;
};

// A particle (eqs 113-114): a sphere stamped with its own noise, v = max(0, N(x) rho_base(x)^fade),
// N = amplitude (bias + FS_norm(x)).
struct Particle {
  Vec3d center{0, 0, 0};  // m
  double radius = 1;      // m, > 0
  double amplitude = 1;   // density scale, >= 0
  double bias = 0.5;      // added to the normalized noise, [-1, 1]
  double fade = 1;        // >= 0
  NoiseParams noise;
};

enum class AdvectionScheme { SemiLagrangian, ModifiedMacCormack };

// Advection of the density by a fractal noise velocity u = speed (FS(x), FS(x+d1), FS(x+d2)) (App D eq 3.9),
// over `time` in `substeps` equal steps of the characteristic map (eqs 115-117, App E eq 13).
struct Advection {
  double speed = 0;      // m/s, >= 0 (0 = off)
  double time = 0;       // s, >= 0
  int64_t substeps = 1;  // 1..256 (held as sent, named so in errors)
  AdvectionScheme scheme = AdvectionScheme::ModifiedMacCormack;
  NoiseParams noise;
};

// The hottest a volume's temperature field may be, K: ten times the surface's cap.
inline constexpr double kMaxTemperature = 1e5;

// Temperature (§6.3): T = surface - lapse_rate (z - base_altitude) + fluctuation FS_norm(x), on the
// density's active voxels.
struct Temperature {
  bool enabled = false;
  double surface = 288.15;     // K at base_altitude, (0, 10000]
  double base_altitude = 0;    // m
  double lapse_rate = 0.0065;  // K/m, [-0.1, 0.1] (standard atmosphere 6.5 K/km)
  double fluctuation = 0;      // K, >= 0
  NoiseParams noise;
};

struct CloudModel {
  double voxel_size = 1;        // m, > 0
  double skin = 1;              // skin thickness Delta x_skin of eq 103, m, > 0
  std::vector<Sphere> spheres;  // the base shapes, unioned (max of l)
  std::vector<Ellipsoid> ellipsoids;
  std::vector<TriangleMesh> meshes;
  Pyroclastic pyroclastic;          // applied to the union of base shapes
  std::vector<Particle> particles;  // stamped, combined by max density
  Advection advection;
  Temperature temperature;
  uint64_t max_active_voxels = 64ull << 20;  // budget; the build fails rather than exceed it
  double max_advection_samples = 1e9;        // budget: estimated active voxels x substeps (x2 for MacCormack)
};

// How far (m) advect_density() grows the active region of a density carried at up to max_speed (m/s) for
// `time` (s): a modified MacCormack step moves a point by at most twice the semi-Lagrangian one. The region
// grows by that many voxels along each axis (a cube about each voxel: up to sqrt(3) times it diagonally).
inline double advection_reach(double max_speed, double time) { return 2 * max_speed * time; }

// Voxel sizes, m: OpenVDB refuses a transform whose determinant, the voxel's volume, is below 3e-15 m^3 (a
// voxel under 1.5e-5 m), and past 1e6 m the float32 march's world coordinates (2^20 voxels either way)
// would pass 1e12 m.
constexpr double kMinVoxelSize = 1e-4, kMaxVoxelSize = 1e6;
// A noise's base frequency, 1/m, and its offset, m: with the shapes within 2^20 voxels of the origin, the
// lattice coordinates (x + offset) f f_jump^i stay finite in double.
constexpr double kMaxNoiseFrequency = 1e9, kMaxNoiseOffset = 1e9;

// A connected piece of a mesh (triangles that share vertices): its enclosed volume |V| (m^3, by the
// divergence theorem from one of its vertices: no cancellation far from the origin), surface area (m^2),
// bounding box (m), and whether it bounds a convex body.
struct MeshPiece {
  double volume = 0, area = 0;
  Vec3d lo{0, 0, 0}, hi{0, 0, 0};
  bool convex = false;
  // An edge of the piece in an odd number of triangles (a border: the piece is open there), as its two
  // vertex indices; -1 when every edge is in an even number.
  int64_t border_from = -1, border_to = -1;
};
// The pieces of a mesh whose triangle indices are in range.
std::vector<MeshPiece> mesh_pieces(const TriangleMesh& mesh);

// Throws squall::Error(InvalidArgument) naming the field (prefix + ".spheres[2].radius") for any
// non-finite or out-of-range value or degenerate mesh, and ResourceExhausted when the estimated active
// voxel count exceeds max_active_voxels or the advection's velocity samples max_advection_samples. Returns
// that estimate: an upper bound of the active voxels of every grid the build makes.
// With `pieces`, the meshes' connected pieces (mesh_pieces) are appended there, for build_bytes.
double validate(const CloudModel& model, const std::string& prefix = "model", std::vector<MeshPiece>* pieces = nullptr);

// How far (m) a build can grow any shape: the skin and the level set's band, the pyroclastic layers'
// displacement and the advection's reach (of a validated model).
double shape_growth(const CloudModel& model);

// Largest displacement the pyroclastic layers can add, m (sum over layers of amplitude (r^n)^gamma).
double pyroclastic_bound(const Pyroclastic& p);

}  // namespace squall::clouds
