#include "clouds/build_memory.h"

#include <algorithm>
#include <cmath>

namespace squall::clouds {
namespace {

constexpr double kLeafVoxels = 8;

// Voxels of `body` grown by `g` (m), rounded out to whole leaves: Steiner's formula for its volume grown by
// one leaf more, V + A r + M r^2 + (4 pi / 3) r^3 (exact for a convex body, whose mean-curvature integral M is
// 2 pi times its mean width, at most its diameter), and at most its grown bounding box rounded out to leaves.
double grown_voxels(const MeshPiece& body, double g, double dx) {
  const double leaf = kLeafVoxels * dx, r = g + leaf;
  const double diameter = std::hypot(body.hi[0] - body.lo[0], body.hi[1] - body.lo[1], body.hi[2] - body.lo[2]);
  const double steiner = body.volume + body.area * r + 2 * M_PI * diameter * r * r + 4 * M_PI / 3 * r * r * r;
  double box = 1;
  for (int a = 0; a < 3; ++a) box *= (std::ceil((body.hi[a] - body.lo[a] + 2 * g) / leaf) + 1) * leaf;
  return std::min(steiner, box) / (dx * dx * dx);
}

// An ellipsoid's body; its area is at most 4 pi times the largest product of two semi-axes (a sphere's).
MeshPiece ellipsoid(const Vec3d& center, const Vec3d& radii) {
  const Vec3d& r = radii;
  MeshPiece body{4 * M_PI / 3 * r[0] * r[1] * r[2], 4 * M_PI * std::max({r[0] * r[1], r[1] * r[2], r[2] * r[0]})};
  for (int a = 0; a < 3; ++a) body.lo[a] = center[a] - r[a], body.hi[a] = center[a] + r[a];
  return body;
}

}  // namespace

uint64_t build_bytes(const CloudModel& m) {
  // The level set's band reaches 2 voxels past the growth (base_level_set's half width).
  const double g = shape_growth(m) + 2 * m.voxel_size, dx = m.voxel_size;
  double voxels = 0, shapes = 0;
  auto add = [&](const MeshPiece& body) {
    voxels += grown_voxels(body, g, dx);
    shapes += 1;
  };
  for (const Sphere& s : m.spheres) add(ellipsoid(s.center, {s.radius, s.radius, s.radius}));
  for (const Ellipsoid& e : m.ellipsoids) add(ellipsoid(e.center, e.radii));
  for (const Particle& p : m.particles) add(ellipsoid(p.center, {p.radius, p.radius, p.radius}));
  for (const TriangleMesh& mesh : m.meshes)
    for (const MeshPiece& piece : mesh_pieces(mesh)) add(piece);
  return uint64_t(kBytesPerBandVoxel * voxels + kBytesPerShape * shapes + kBytesPerBuild);
}

}  // namespace squall::clouds
