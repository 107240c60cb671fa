#include "clouds/build_memory.h"

#include <algorithm>
#include <cmath>
#include <unordered_set>

#include "common/seeded_hash.h"

namespace squall::clouds {
namespace {

constexpr double kLeafVoxels = 8;

// Voxels of `body` grown by `g` (m), rounded out to whole leaves (each within 8 sqrt(3) voxels of the grown
// body): its grown bounding box rounded out to leaves, or for a convex body, if fewer, Steiner's formula
// V + A r + M r^2 + (4 pi / 3) r^3, its mean-curvature integral M being 2 pi times its mean width, at most
// its diameter (R. Schneider, "Convex Bodies: The Brunn-Minkowski Theory", ch. 4).
double grown_voxels(const MeshPiece& body, double g, double dx) {
  const double leaf = kLeafVoxels * dx;
  double box = 1;
  for (int a = 0; a < 3; ++a) box *= (std::ceil((body.hi[a] - body.lo[a] + 2 * g) / leaf) + 1) * leaf;
  double voxels = box;
  if (body.convex) {
    const double r = g + std::sqrt(3.0) * leaf;
    const double diameter = std::hypot(body.hi[0] - body.lo[0], body.hi[1] - body.lo[1], body.hi[2] - body.lo[2]);
    voxels = std::min(box, body.volume + body.area * r + 2 * M_PI * diameter * r * r + 4 * M_PI / 3 * r * r * r);
  }
  return voxels / (dx * dx * dx);
}

// An ellipsoid's body; its area is at most 4 pi times the largest product of two semi-axes (a sphere's).
MeshPiece ellipsoid(const Vec3d& center, const Vec3d& radii) {
  const Vec3d& r = radii;
  MeshPiece body{4 * M_PI / 3 * r[0] * r[1] * r[2], 4 * M_PI * std::max({r[0] * r[1], r[1] * r[2], r[2] * r[0]})};
  for (int a = 0; a < 3; ++a) body.lo[a] = center[a] - r[a], body.hi[a] = center[a] + r[a];
  body.convex = true;
  return body;
}

// The internal nodes the shapes' grown boxes reach, each counted once: OpenVDB's lower ones span 128^3
// voxels, its upper ones 4096^3. A box over more than kMaxListed nodes counts them all, shared or not.
class NodeCount {
 public:
  void cover(const MeshPiece& body, double g, double dx) {
    lower_ += count(body, g, dx * 128, lower_nodes_);
    upper_ += count(body, g, dx * 4096, upper_nodes_);
  }
  double lower() const { return lower_; }
  double upper() const { return upper_; }

 private:
  static constexpr double kMaxListed = 1 << 16;
  // Node coordinates stay within 2^21 voxels of the origin (the model's reach): 20 bits an axis.
  static double count(const MeshPiece& body, double g, double span, std::unordered_set<uint64_t, SeededHash>& seen) {
    int64_t lo[3], hi[3];
    double nodes = 1;
    for (int a = 0; a < 3; ++a) {
      lo[a] = int64_t(std::floor((body.lo[a] - g) / span));
      hi[a] = int64_t(std::floor((body.hi[a] + g) / span));
      nodes *= double(hi[a] - lo[a] + 1);
    }
    if (nodes > kMaxListed) return nodes;
    double added = 0;
    for (int64_t i = lo[0]; i <= hi[0]; ++i)
      for (int64_t j = lo[1]; j <= hi[1]; ++j)
        for (int64_t k = lo[2]; k <= hi[2]; ++k)
          added += seen.insert(uint64_t(i + (1 << 19)) << 40 | uint64_t(j + (1 << 19)) << 20 | uint64_t(k + (1 << 19)))
                       .second;
    return added;
  }
  std::unordered_set<uint64_t, SeededHash> lower_nodes_, upper_nodes_;  // coordinates of the client's bodies
  double lower_ = 0, upper_ = 0;
};

}  // namespace

uint64_t build_bytes(const CloudModel& m) {
  std::vector<MeshPiece> pieces;
  for (const TriangleMesh& mesh : m.meshes)
    for (const MeshPiece& piece : mesh_pieces(mesh)) pieces.push_back(piece);
  return build_bytes(m, pieces);
}

uint64_t build_bytes(const CloudModel& m, const std::vector<MeshPiece>& pieces) {
  // The level set's band reaches 2 voxels past the growth (base_level_set's half width).
  const double g = shape_growth(m) + 2 * m.voxel_size;
  double voxels = 0;
  NodeCount nodes;
  auto add = [&](const MeshPiece& body) {
    voxels += grown_voxels(body, g, m.voxel_size);
    nodes.cover(body, g, m.voxel_size);
  };
  for (const Sphere& s : m.spheres) add(ellipsoid(s.center, {s.radius, s.radius, s.radius}));
  for (const Ellipsoid& e : m.ellipsoids) add(ellipsoid(e.center, e.radii));
  for (const Particle& p : m.particles) add(ellipsoid(p.center, {p.radius, p.radius, p.radius}));
  for (const MeshPiece& piece : pieces) add(piece);
  double triangles = 0, vertices = 0;
  for (const TriangleMesh& mesh : m.meshes) {
    triangles += double(mesh.triangles.size() / 3);
    vertices += double(mesh.vertices.size());
  }
  const double per_voxel = kBytesPerBandVoxel + (m.temperature.enabled ? kTemperatureBytesPerVoxel : 0);
  const double bytes = per_voxel * voxels +
                       kGridsAtPeak * (kLowerNodeBytes * nodes.lower() + kUpperNodeBytes * nodes.upper()) +
                       kBytesPerTriangle * triangles + kBytesPerVertex * vertices + kBytesPerBuild;
  return bytes < 0x1p64 ? uint64_t(bytes) : UINT64_MAX;  // a band of 1e6 voxels about a grain passes 2^64
}

uint64_t mesh_read_bytes(uint64_t vertices, uint64_t triangles) {
  return uint64_t(kReadBytesPerVertex * double(vertices) + kReadBytesPerTriangle * double(triangles));
}

}  // namespace squall::clouds
