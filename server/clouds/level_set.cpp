// Base shapes to a level set (l > 0 inside), pyroclastic displacement (eqs 105-112), density (eq 103)
// and particle stamping (eqs 113-114), numbered as in J. Tessendorf, "Gilligan: A Prototype Framework for
// Simulating and Rendering Maritime Environments" (2017), sec. 6.2. One of the few translation units that
// include OpenVDB's tools.
#include <openvdb/tools/Composite.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/Prune.h>
#include <openvdb/tree/LeafManager.h>
#include <openvdb/util/NullInterrupter.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "clouds/volume.h"

namespace squall::clouds {
namespace {

using openvdb::FloatGrid;
using openvdb::Vec3s;

std::vector<Vec3s> to_points(const std::vector<Vec3d>& v) {
  std::vector<Vec3s> out;
  out.reserve(v.size());
  for (const auto& p : v) out.emplace_back(float(p[0]), float(p[1]), float(p[2]));
  return out;
}

// OpenVDB's interrupter over a call's Cancellation: its mesh and sphere conversions ask it between their
// stages and blocks of work, and return early once it says so (the caller then checks the Cancellation).
class Interrupter : public openvdb::util::NullInterrupter {
 public:
  explicit Interrupter(const Cancellation& cancel) : cancel_(cancel) {}
  bool wasInterrupted(int = -1) override { return cancel_.requested(); }

 private:
  const Cancellation& cancel_;
};

// OpenVDB's createLevelSetSphere leaves a sphere of fewer voxels in radius empty (below the Nyquist limit).
constexpr double kMinVdbSphereVoxels = 1.5;

// The bits of `v` (< 2^21) spread to every third bit.
uint64_t spread_bits(uint64_t v) {
  uint64_t out = 0;
  for (int b = 0; b < 21; ++b) out |= (v >> b & 1) << (3 * b);
  return out;
}

// Triangles in the Z order of their centroids' leaves (G. M. Morton, "A Computer Oriented Geodetic Data Base
// and a New Technique in File Sequencing", IBM, 1966). OpenVDB's mesh conversion hands its threads runs of
// the list and keeps a grid per thread: runs of nearby triangles keep each thread's grid from spanning the
// whole band, whatever order the client listed them in.
void sort_by_region(std::vector<openvdb::Vec3I>& triangles, const std::vector<Vec3s>& points,
                    const openvdb::math::Transform& xform) {
  std::vector<std::pair<uint64_t, openvdb::Vec3I>> keyed;
  keyed.reserve(triangles.size());
  for (const auto& t : triangles) {
    const openvdb::Vec3d centroid = (openvdb::Vec3d(points[t[0]]) + points[t[1]] + points[t[2]]) / 3;
    const openvdb::Vec3d leaf = xform.worldToIndex(centroid) / 8;  // within 2^18 leaves of the origin
    uint64_t code = 0;
    for (int a = 0; a < 3; ++a) code |= spread_bits(uint64_t(std::clamp(leaf[a] + 0x1p20, 0.0, 0x1p21 - 1))) << a;
    keyed.emplace_back(code, t);
  }
  std::sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (size_t i = 0; i < triangles.size(); ++i) triangles[i] = keyed[i].second;
}

// OpenVDB's convention (negative inside) with a symmetric band of `half_width` voxels.
FloatGrid::Ptr mesh_sdf(const openvdb::math::Transform& xform, const std::vector<Vec3s>& points,
                        const std::vector<openvdb::Vec3I>& triangles, float half_width, Interrupter& interrupter) {
  std::vector<openvdb::Vec4I> quads;
  return openvdb::tools::meshToSignedDistanceField<FloatGrid>(interrupter, xform, points, triangles, quads, half_width,
                                                              half_width);
}

FloatGrid::Ptr ellipsoid_sdf(const Ellipsoid& e, const openvdb::math::Transform& xform, float half_width,
                             Interrupter& interrupter) {
  const int rings = 48, segments = 96;  // chord error < 0.06% of the largest radius
  // Rings about the longest axis (z, then x, y taken cyclically: the winding kept), in the order listed: the
  // mesh conversion's threads, each given a run of triangles, then each take a slice of it, not all of it.
  const auto& r = e.radii;
  const int p = r[0] > r[1] && r[0] > r[2] ? 0 : r[1] > r[2] ? 1 : 2, q = (p + 1) % 3, s = (p + 2) % 3;
  std::vector<Vec3s> points;
  std::vector<openvdb::Vec3I> triangles;
  for (int i = 0; i <= rings; ++i) {
    double theta = M_PI * i / rings;
    for (int j = 0; j < segments; ++j) {
      double phi = 2 * M_PI * j / segments;
      Vec3s x;
      x[q] = float(e.center[q] + r[q] * std::sin(theta) * std::cos(phi));
      x[s] = float(e.center[s] + r[s] * std::sin(theta) * std::sin(phi));
      x[p] = float(e.center[p] + r[p] * std::cos(theta));
      points.push_back(x);
    }
  }
  auto index = [&](int i, int j) { return unsigned(i * segments + (j % segments)); };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      triangles.emplace_back(index(i, j), index(i + 1, j), index(i + 1, j + 1));
      triangles.emplace_back(index(i, j), index(i + 1, j + 1), index(i, j + 1));
    }
  return mesh_sdf(xform, points, triangles, half_width, interrupter);
}

void negate(FloatGrid& grid) {
  float background = grid.background();
  for (auto it = grid.tree().beginValueAll(); it; ++it) it.setValue(-*it);
  grid.tree().root().setBackground(-background, false);
  grid.setGridClass(openvdb::GRID_UNKNOWN);
}

openvdb::Vec3d world(const openvdb::math::Transform& xform, const openvdb::Coord& ijk) {
  return xform.indexToWorld(ijk);
}

// Eqs 113-114 for one particle over the voxels of `box` (max blend).
void stamp_box(FloatGrid::Accessor& acc, const openvdb::math::Transform& xform, const Particle& p, double skin,
               const openvdb::CoordBBox& box) {
  const openvdb::Vec3d c(p.center[0], p.center[1], p.center[2]);
  for (auto ijk = box.begin(); ijk; ++ijk) {
    openvdb::Vec3d x = world(xform, *ijk);
    double l = p.radius - (x - c).length();
    if (l <= 0) continue;
    double rho_base = std::clamp(l / skin, 0.0, 1.0);  // eq 103
    double N = p.amplitude * (p.bias + fractal_noise(p.noise, {x[0], x[1], x[2]}));
    double v = std::max(0.0, N * std::pow(rho_base, p.fade));  // eq 113
    if (v > acc.getValue(*ijk)) acc.setValue(*ijk, float(v));  // eq 114 (max blend)
  }
}

}  // namespace

FloatGrid::Ptr base_level_set(const CloudModel& model, double exterior, double interior, const Cancellation& cancel,
                              const std::string& what) {
  auto xform = openvdb::math::Transform::createLinearTransform(model.voxel_size);
  float half_width = float(std::max(exterior, interior) / model.voxel_size + 2);
  FloatGrid::Ptr sdf;
  Interrupter interrupter(cancel);
  auto add = [&](FloatGrid::Ptr g) {
    cancel.check(what);  // a conversion cut short, or before the next shape: a union of many takes long
    if (!sdf) {
      sdf = g;
    } else {
      openvdb::tools::csgUnion(*sdf, *g);
    }
  };
  for (const auto& s : model.spheres) {
    // OpenVDB's sphere would be empty (its test, in float: float(r) / float(dx) < 1.5f): as a mesh.
    if (!(float(s.radius) / float(model.voxel_size) >= float(kMinVdbSphereVoxels))) {
      add(ellipsoid_sdf({s.center, {s.radius, s.radius, s.radius}}, *xform, half_width, interrupter));
      continue;
    }
    add(openvdb::tools::createLevelSetSphere<FloatGrid, openvdb::util::NullInterrupter>(
        float(s.radius), Vec3s(float(s.center[0]), float(s.center[1]), float(s.center[2])), float(model.voxel_size),
        half_width, &interrupter));
  }
  for (const auto& e : model.ellipsoids) add(ellipsoid_sdf(e, *xform, half_width, interrupter));
  for (const auto& m : model.meshes) {
    std::vector<openvdb::Vec3I> triangles;
    for (size_t t = 0; t < m.triangles.size(); t += 3)
      triangles.emplace_back(m.triangles[t], m.triangles[t + 1], m.triangles[t + 2]);
    const std::vector<Vec3s> points = to_points(m.vertices);
    sort_by_region(triangles, points, *xform);
    add(mesh_sdf(*xform, points, triangles, half_width, interrupter));
  }
  if (!sdf) return nullptr;
  cancel.check(what);  // the last shape's union done
  negate(*sdf);        // Gilligan's convention (sec. 6.2.2): l > 0 inside
  sdf->setName("level_set");
  return sdf;
}

FloatGrid::Ptr pyroclastic_displace(const FloatGrid& level_set, const Pyroclastic& pyro, const Cancellation& cancel,
                                    const std::string& what) {
  FloatGrid::Ptr current = level_set.deepCopy();
  const auto& xform = level_set.transform();
  const double dx = xform.voxelSize()[0];
  for (int n = 0; n < pyro.layers; ++n) {
    NoiseParams noise = pyro.noise;  // N_n(x) = r^n N_0(x f_jump^n)  (eqs 108, 110)
    noise.frequency *= std::pow(pyro.noise.frequency_jump, n);
    const double scale = std::pow(pyro.noise.roughness, n);
    FloatGrid::Ptr next = current->deepCopy();
    openvdb::tree::LeafManager<openvdb::FloatTree> leaves(next->tree());
    std::atomic<bool> cancelled{false};
    leaves.foreach ([&](openvdb::FloatTree::LeafNodeType& leaf, size_t) {
      if (cancelled || cancel.requested()) {  // a leaf (512 voxels) is the slice
        cancelled = true;
        return;
      }
      auto in = current->getConstAccessor();
      for (auto it = leaf.beginValueOn(); it; ++it) {
        const openvdb::Coord ijk = it.getCoord();
        const double l = in.getValue(ijk);
        openvdb::Vec3d grad((in.getValue(ijk.offsetBy(1, 0, 0)) - in.getValue(ijk.offsetBy(-1, 0, 0))) / (2 * dx),
                            (in.getValue(ijk.offsetBy(0, 1, 0)) - in.getValue(ijk.offsetBy(0, -1, 0))) / (2 * dx),
                            (in.getValue(ijk.offsetBy(0, 0, 1)) - in.getValue(ijk.offsetBy(0, 0, -1))) / (2 * dx));
        openvdb::Vec3d x = world(xform, ijk);
        openvdb::Vec3d X = x - l * grad;  // X_CPT (eq 105), X_PPT for n > 0 (eqs 107, 111)
        double N = scale * fractal_noise(noise, {X[0], X[1], X[2]});
        it.setValue(float(l + pyro.amplitude * std::pow(std::abs(N), pyro.gamma)));  // eqs 106, 109, 112
      }
    });
    if (cancelled) Cancellation::stopped(what);
    current = next;
  }
  return current;
}

FloatGrid::Ptr density_from_level_set(const FloatGrid& level_set, double skin) {
  FloatGrid::Ptr density = level_set.deepCopy();
  for (auto it = density->tree().beginValueAll(); it; ++it) {
    float rho = std::clamp(float(*it / skin), 0.0f, 1.0f);  // eq 103
    it.setValue(rho);
    it.setActiveState(rho > 0);
  }
  density->tree().root().setBackground(0.0f, false);
  openvdb::tools::pruneInactive(density->tree());
  openvdb::tools::prune(density->tree());
  density->setName("density");
  density->setGridClass(openvdb::GRID_FOG_VOLUME);
  return density;
}

void stamp_particles(FloatGrid& density, const std::vector<Particle>& particles, double skin,
                     const Cancellation& cancel, const std::string& what) {
  const auto& xform = density.transform();
  auto acc = density.getAccessor();
  for (const auto& p : particles) {
    openvdb::Vec3d c(p.center[0], p.center[1], p.center[2]);
    const openvdb::Coord lo = openvdb::Coord::floor(xform.worldToIndex(c - openvdb::Vec3d(p.radius))),
                         hi = openvdb::Coord::ceil(xform.worldToIndex(c + openvdb::Vec3d(p.radius)));
    for (int i = lo.x(); i <= hi.x(); ++i) {
      cancel.check(what);  // a slab of one particle's box: its noise is the costly part of a build
      stamp_box(acc, xform, p, skin, {openvdb::Coord(i, lo.y(), lo.z()), openvdb::Coord(i, hi.y(), hi.z())});
    }
  }
  openvdb::tools::prune(density.tree());
}

}  // namespace squall::clouds
