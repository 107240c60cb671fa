#include "clouds/model.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <unordered_map>

#include "common/disjoint_sets.h"
#include "common/error.h"
#include "common/seeded_hash.h"
#include "common/validate.h"

namespace squall::clouds {
namespace {

using validate::finite;
using validate::positive;

// A noise's frequencies and offset keep its lattice coordinates finite for every shape the model allows.
void check_noise(const std::string& f, const NoiseParams& n) {
  positive(f + ".frequency", n.frequency, kMaxNoiseFrequency);
  validate::in(f + ".octaves", int64_t(n.octaves), 1, 16);
  validate::in(f + ".roughness", n.roughness, validate::closed(1e-6, 1));
  validate::in(f + ".frequency_jump", n.frequency_jump, validate::closed(1, 8));
  validate::in_xyz(f + ".offset", n.offset, validate::closed(-kMaxNoiseOffset, kMaxNoiseOffset));
}

Vec3d sub(const Vec3d& a, const Vec3d& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3d cross(const Vec3d& a, const Vec3d& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double dot(const Vec3d& a, const Vec3d& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// The ray march works in float32 index coordinates, which resolve 1/8 of a voxel up to 2^20 voxels from the
// origin (and OpenVDB's int32 coordinates overflow at 2^31): a shape, grown by `reach` (m), must stay within
// 2^20 voxels of the origin along each axis.
void check_reach(const std::string& path, const Vec3d& center, double reach, double voxel_size) {
  const double limit = std::ldexp(voxel_size, 20);
  for (int a = 0; a < 3; ++a)
    if (!(std::abs(center[a]) + reach <= limit))
      fail(Code::InvalidArgument, path + " = " + validate::xyz(center) + " plus " + validate::number(reach) +
                                      " m of shape must stay within 2^20 voxels (" + validate::number(limit) +
                                      " m) of the origin (float32 on the device): move the model nearer");
}

// What grows every shape, m: the skin and the level set's band, the pyroclastic layers' displacement, the
// advection's reach.
struct Growth {
  double band, displaced, advected;
  double total() const { return band + displaced + advected; }
};

Growth growth_of(const CloudModel& m) {
  // The advection's dilation: advection_reach of the field's top speed sqrt(3) speed, along the diagonals too.
  return {m.skin + 3 * m.voxel_size, pyroclastic_bound(m.pyroclastic),
          std::sqrt(3.0) * advection_reach(std::sqrt(3.0) * m.advection.speed, m.advection.time)};
}

// The growth alone must stay within check_reach's bound; past it, the field behind its largest part is named
// (rather than the first shape's centre).
void check_growth(const std::string& f, const CloudModel& m, const Growth& g) {
  const double limit = std::ldexp(m.voxel_size, 20);
  if (g.total() <= limit) return;
  const double largest = std::max({g.band, g.displaced, g.advected});
  const std::string field = largest == g.band ? f + ".skin = " + validate::number(m.skin)
                            : largest == g.displaced
                                ? f + ".pyroclastic.amplitude = " + validate::number(m.pyroclastic.amplitude)
                                : f + ".advection.speed = " + validate::number(m.advection.speed);
  fail(Code::InvalidArgument, field + " grows every shape by " + validate::number(g.total()) + " m (skin and band " +
                                  validate::number(g.band) + " m, pyroclastic displacement " +
                                  validate::number(g.displaced) + " m, advection " + validate::number(g.advected) +
                                  " m): more than the 2^20 voxels (" + validate::number(limit) +
                                  " m) the device resolves about the origin");
}

// Vertex k of mesh `f` as the request names it: the OBJ text's (k + 1)th vertex, or the flat list's x, y, z at
// vertices[3k], [3k + 1] and [3k + 2].
std::string vertex_path(const std::string& f, const TriangleMesh& m, size_t k) {
  if (m.from_obj) return f + ".obj vertex " + std::to_string(k + 1);
  return f + ".vertices[" + std::to_string(3 * k) + ".." + std::to_string(3 * k + 2) + "]";
}

// Mesh `f`'s pieces, once its counts, its vertices (finite, and within reach when grown by `grow`), its
// triangles' indices and the volume it encloses are checked.
std::vector<MeshPiece> check_mesh(const std::string& f, const TriangleMesh& m, double grow, double voxel_size) {
  if (m.vertices.size() < 4)
    fail(Code::InvalidArgument, f + (m.from_obj ? ".obj" : ".vertices") + " has " + std::to_string(m.vertices.size()) +
                                    " vertices; a closed mesh needs at least 4");
  for (size_t i = 0; i < m.vertices.size(); ++i)
    for (int a = 0; a < 3; ++a)
      if (!std::isfinite(m.vertices[i][a]))
        validate::finite(
            m.from_obj ? vertex_path(f, m, i) + " " + "xyz"[a] : validate::at(f + ".vertices", 3 * i + size_t(a)),
            m.vertices[i][a]);
  for (size_t k = 0; k < m.vertices.size(); ++k) check_reach(vertex_path(f, m, k), m.vertices[k], grow, voxel_size);
  if (m.triangles.size() < 12 || m.triangles.size() % 3 != 0)
    fail(Code::InvalidArgument, m.from_obj ? f + ".obj has " + std::to_string(m.triangles.size() / 3) +
                                                 " triangles (its faces fanned); a " + "closed mesh needs at least 4"
                                           : f + ".triangles has " + std::to_string(m.triangles.size()) +
                                                 " indices; it needs a multiple of 3 and at least 4 triangles");
  for (size_t k = 0; k < m.triangles.size(); ++k)
    if (m.triangles[k] >= m.vertices.size())
      fail(Code::InvalidArgument, f + ".triangles[" + std::to_string(k) + "] = " + std::to_string(m.triangles[k]) +
                                      " is out of range (" + std::to_string(m.vertices.size()) + " vertices)");
  std::vector<MeshPiece> pieces = mesh_pieces(m);
  for (const MeshPiece& piece : pieces)
    if (piece.border_from >= 0)
      fail(Code::InvalidArgument, f + " is not closed: the edge from " + vertex_path(f, m, size_t(piece.border_from)) +
                                      " to " + vertex_path(f, m, size_t(piece.border_to)) +
                                      " borders an odd number of triangles (a closed mesh has every edge in two)");
  double volume = 0, area = 0;  // the pieces' together
  for (const MeshPiece& piece : pieces) volume += piece.volume, area += piece.area;
  double scale = std::sqrt(area);
  if (!(area > 0) || std::abs(volume) <= 1e-9 * scale * scale * scale)
    fail(Code::InvalidArgument, f + " is degenerate: it encloses no volume (area " + validate::number(area) +
                                    " m^2, volume " + validate::number(volume) + " m^3)");
  return pieces;
}

// Voxels' volume (m^3) a mesh's level set and density can take: each piece's inside, a band of `grow` about
// its surface on both sides (the level set's narrow band), the tube of `grow` about its edges (Steiner's
// M grow^2 with M, 2 pi times the mean width, at most 2 pi times its diameter: all of a thin piece's band)
// and a ball of `grow` (all of a small piece's band), at most its bounding box grown by `grow`.
double mesh_volume_estimate(const std::vector<MeshPiece>& pieces, double grow) {
  double volume = 0;
  for (const MeshPiece& piece : pieces) {
    double box = 1;
    for (int a = 0; a < 3; ++a) box *= piece.hi[a] - piece.lo[a] + 2 * grow;
    const double diameter = std::hypot(piece.hi[0] - piece.lo[0], piece.hi[1] - piece.lo[1], piece.hi[2] - piece.lo[2]);
    volume += std::min(
        piece.volume + 2 * grow * piece.area + 2 * M_PI * diameter * grow * grow + 4 * M_PI / 3 * grow * grow * grow,
        box);
  }
  return volume;
}

}  // namespace

double pyroclastic_bound(const Pyroclastic& p) {
  double bound = 0;
  for (int n = 0; n < p.layers; ++n) bound += p.amplitude * std::pow(std::pow(p.noise.roughness, n), p.gamma);
  return bound;
}

double shape_growth(const CloudModel& m) { return growth_of(m).total(); }

namespace {

// The piece of each triangle: union-find over the vertices, joined by the triangles.
std::vector<size_t> piece_of_triangles(const TriangleMesh& m, size_t* pieces) {
  DisjointSets vertices(m.vertices.size());
  for (size_t t = 0; t < m.triangles.size(); t += 3)
    for (size_t k = t + 1; k < t + 3; ++k) vertices.join(m.triangles[k], m.triangles[t]);
  std::vector<size_t> index(m.vertices.size(), SIZE_MAX), piece(m.triangles.size() / 3);
  *pieces = 0;
  for (size_t t = 0; t < piece.size(); ++t) {
    size_t& i = index[vertices.find(m.triangles[3 * t])];
    if (i == SIZE_MAX) i = (*pieces)++;
    piece[t] = i;
  }
  return piece;
}

// Marks each piece convex that is: closed (every edge in two triangles), wound alike (the two run an edge
// in opposite directions), convex at every edge (the far vertex of one triangle not outside the other's
// plane, the outside told by the sign of the piece's volume) and a sphere (Euler characteristic
// V - E + F = 2, so no two convex parts joined at a vertex). A closed connected set that is convex about
// each of its points is convex (H. Tietze, "Uber Konvexheit im kleinen und im grossen", Math. Z. 28, 1928).
void mark_convex(const TriangleMesh& m, const std::vector<size_t>& piece_of, const std::vector<double>& signed_volume,
                 std::vector<MeshPiece>& pieces) {
  struct Edge {
    uint32_t from, opposite;
    size_t triangle;
    int uses;
  };
  std::unordered_map<uint64_t, Edge, SeededHash> edges;  // keys of the client's vertex indices
  std::vector<int64_t> euler(pieces.size(), 0);          // V - E + F: F and -E here, V below
  std::vector<bool> bent(pieces.size(), false);
  auto vertex = [&](size_t t, int k) { return m.triangles[3 * t + size_t(k)]; };
  for (size_t t = 0; t < piece_of.size(); ++t) {
    const size_t i = piece_of[t];
    euler[i] += 1;
    for (int k = 0; k < 3; ++k) {
      const uint32_t u = vertex(t, k), v = vertex(t, (k + 1) % 3), w = vertex(t, (k + 2) % 3);
      const uint64_t key = uint64_t(std::min(u, v)) << 32 | std::max(u, v);
      auto [it, first] = edges.try_emplace(key, Edge{u, w, t, 1});
      if (first) {
        euler[i] -= 1;
        continue;
      }
      Edge& e = it->second;
      if (++e.uses > 2 || e.from == u) {
        bent[i] = true;
        continue;
      }
      const Vec3d &a = m.vertices[vertex(e.triangle, 0)], &b = m.vertices[vertex(e.triangle, 1)],
                  &c = m.vertices[vertex(e.triangle, 2)], &far = m.vertices[w];
      const Vec3d n = cross(sub(b, a), sub(c, a)), to = sub(far, a);
      const double outward = signed_volume[i] > 0 ? 1 : -1;
      if (outward * dot(n, to) > 1e-9 * std::sqrt(dot(n, n) * dot(to, to))) bent[i] = true;
    }
  }
  // Each piece's border edge of the smallest key, so that the same mesh is always refused naming the same one.
  auto key_of = [](const MeshPiece& p) { return uint64_t(p.border_from) << 32 | uint64_t(p.border_to); };
  for (const auto& [key, e] : edges) {
    if (e.uses != 2) bent[piece_of[e.triangle]] = true;
    const uint32_t u = uint32_t(key >> 32), v = uint32_t(key);
    if (e.uses % 2 == 0 || u == v) continue;  // (u, u), of a triangle with a repeated vertex, is no edge
    MeshPiece& piece = pieces[piece_of[e.triangle]];
    if (piece.border_from < 0 || key < key_of(piece)) piece.border_from = u, piece.border_to = v;
  }
  std::vector<size_t> seen(m.vertices.size(), SIZE_MAX);  // the piece that counted the vertex
  for (size_t t = 0; t < piece_of.size(); ++t)
    for (int k = 0; k < 3; ++k)
      if (size_t& by = seen[vertex(t, k)]; by != piece_of[t]) by = piece_of[t], euler[piece_of[t]] += 1;
  for (size_t i = 0; i < pieces.size(); ++i) pieces[i].convex = !bent[i] && euler[i] == 2 && signed_volume[i] != 0;
}

// The mesh with each triangle's vertices named by the first vertex at their position: exporters split a
// vertex along seams of texture coordinates or normals, which leaves a surface closed by its positions open by
// its indices.
TriangleMesh welded(const TriangleMesh& m) {
  struct Hash {
    size_t operator()(const Vec3d& v) const {
      uint64_t h = hash_seed();
      for (double c : v) h = mix_in(h, std::bit_cast<uint64_t>(c + 0.0));  // -0 as +0: equal positions, equal hashes
      return size_t(h);
    }
  };
  std::unordered_map<Vec3d, uint32_t, Hash> first;
  first.reserve(m.vertices.size());
  std::vector<uint32_t> canonical(m.vertices.size());
  for (size_t k = 0; k < m.vertices.size(); ++k)
    canonical[k] = first.try_emplace(m.vertices[k], uint32_t(k)).first->second;
  TriangleMesh w{m.vertices, {}, m.from_obj};
  w.triangles.reserve(m.triangles.size());
  for (uint32_t t : m.triangles) w.triangles.push_back(canonical[t]);
  return w;
}

std::vector<MeshPiece> pieces_of(const TriangleMesh& m) {
  size_t count = 0;
  const std::vector<size_t> piece_of = piece_of_triangles(m, &count);
  std::vector<MeshPiece> pieces(count);
  std::vector<double> signed_volume(count, 0);
  std::vector<Vec3d> apex(count);  // of a piece: the tetrahedra's common vertex, one of its own
  std::vector<bool> started(count, false);
  for (size_t t = 0; t < piece_of.size(); ++t) {
    const Vec3d &a = m.vertices[m.triangles[3 * t]], &b = m.vertices[m.triangles[3 * t + 1]],
                &c = m.vertices[m.triangles[3 * t + 2]];
    const size_t i = piece_of[t];
    MeshPiece& piece = pieces[i];
    if (!started[i]) {
      started[i] = true;
      piece.lo = piece.hi = apex[i] = a;
    }
    const Vec3d n = cross(sub(b, a), sub(c, a)), &o = apex[i];
    piece.area += std::sqrt(dot(n, n)) / 2;
    signed_volume[i] += dot(sub(a, o), cross(sub(b, o), sub(c, o))) / 6;
    for (const Vec3d* v : {&a, &b, &c})
      for (int k = 0; k < 3; ++k)
        piece.lo[k] = std::min(piece.lo[k], (*v)[k]), piece.hi[k] = std::max(piece.hi[k], (*v)[k]);
  }
  for (size_t i = 0; i < count; ++i) pieces[i].volume = std::abs(signed_volume[i]);
  mark_convex(m, piece_of, signed_volume, pieces);
  return pieces;
}

}  // namespace

std::vector<MeshPiece> mesh_pieces(const TriangleMesh& m) { return pieces_of(welded(m)); }

double validate(const CloudModel& m, const std::string& prefix, std::vector<MeshPiece>* mesh_pieces) {
  const std::string& f = prefix;
  validate::in(f + ".voxel_size", m.voxel_size, validate::closed(kMinVoxelSize, kMaxVoxelSize));
  positive(f + ".skin", m.skin);
  const auto& p = m.pyroclastic;
  if (p.layers < 0 || p.layers > 8)
    fail(Code::InvalidArgument, f + ".pyroclastic.layers = " + std::to_string(p.layers) + " must be in [0, 8]");
  validate::non_negative(f + ".pyroclastic.amplitude", p.amplitude, 1e6);
  validate::in(f + ".pyroclastic.gamma", p.gamma, validate::closed(1e-6, 16));
  check_noise(f + ".pyroclastic.noise", p.noise);
  const auto& a = m.advection;
  validate::non_negative(f + ".advection.speed", a.speed, 1e6);
  validate::non_negative(f + ".advection.time", a.time, 1e6);
  if (a.substeps < 1 || a.substeps > 256)
    fail(Code::InvalidArgument, f + ".advection.substeps = " + std::to_string(a.substeps) + " must be in [1, 256]");
  check_noise(f + ".advection.noise", a.noise);
  const Growth growth = growth_of(m);
  check_growth(f, m, growth);
  const double grow = growth.total();
  // Estimated active voxels: shape volumes grown by the displacement band (interior tiles included).
  double volume = 0;
  // A sphere or ellipsoid finer than half a voxel is not resolved (and OpenVDB refuses to build it).
  const validate::Interval radius = validate::at_least(0.5 * m.voxel_size);
  for (size_t i = 0; i < m.spheres.size(); ++i) {
    std::string s = validate::at(f + ".spheres", i);
    validate::finite_xyz(s + ".center", m.spheres[i].center);
    validate::in(s + ".radius", m.spheres[i].radius, radius);
    check_reach(s + ".center", m.spheres[i].center, m.spheres[i].radius + grow, m.voxel_size);
    volume += 4.18879 * std::pow(m.spheres[i].radius + grow, 3);
  }
  for (size_t i = 0; i < m.ellipsoids.size(); ++i) {
    std::string s = validate::at(f + ".ellipsoids", i);
    validate::finite_xyz(s + ".center", m.ellipsoids[i].center);
    const auto& r = m.ellipsoids[i].radii;
    validate::in(s + ".radii.x", r[0], radius);
    validate::in(s + ".radii.y", r[1], radius);
    validate::in(s + ".radii.z", r[2], radius);
    check_reach(s + ".center", m.ellipsoids[i].center, std::max({r[0], r[1], r[2]}) + grow, m.voxel_size);
    volume += 4.18879 * (r[0] + grow) * (r[1] + grow) * (r[2] + grow);
  }
  for (size_t i = 0; i < m.meshes.size(); ++i) {
    std::string s = validate::at(f + ".meshes", i);
    const std::vector<MeshPiece> pieces = check_mesh(s, m.meshes[i], grow, m.voxel_size);
    volume += mesh_volume_estimate(pieces, grow + 2 * m.voxel_size);  // the band's 2 more voxels
    if (mesh_pieces) mesh_pieces->insert(mesh_pieces->end(), pieces.begin(), pieces.end());
  }
  for (size_t i = 0; i < m.particles.size(); ++i) {
    std::string s = validate::at(f + ".particles", i);
    const auto& q = m.particles[i];
    validate::finite_xyz(s + ".center", q.center);
    positive(s + ".radius", q.radius);
    check_reach(s + ".center", q.center, q.radius + grow, m.voxel_size);
    validate::non_negative(s + ".amplitude", q.amplitude, 1e6);
    validate::in(s + ".bias", q.bias, validate::closed(-1, 1));
    validate::in(s + ".fade", q.fade, validate::closed(0, 100));
    check_noise(s + ".noise", q.noise);
    volume += 4.18879 * std::pow(q.radius + grow, 3);
  }
  const auto& t = m.temperature;
  validate::in(f + ".temperature.surface", t.surface, validate::closed(1e-3, 1e4));
  finite(f + ".temperature.base_altitude", t.base_altitude);
  validate::in(f + ".temperature.lapse_rate", t.lapse_rate, validate::closed(-0.1, 0.1));
  validate::in(f + ".temperature.fluctuation", t.fluctuation, validate::closed(0, 1e3));
  check_noise(f + ".temperature.noise", t.noise);
  if (m.spheres.empty() && m.ellipsoids.empty() && m.meshes.empty() && m.particles.empty())
    fail(Code::InvalidArgument, f + " has no spheres, ellipsoids, meshes or particles");
  double voxels = volume / std::pow(m.voxel_size, 3);
  if (!(voxels <= static_cast<double>(m.max_active_voxels)))  // NaN too (a voxel_size of 1e200)
    fail(Code::ResourceExhausted, f + ": an estimated " + validate::number(voxels) + " active voxels exceed " + f +
                                      ".max_active_voxels = " + std::to_string(m.max_active_voxels));
  if (a.speed > 0 && a.time > 0) {  // each voxel maps its point back through every substep (eqs 115-117)
    const double samples = voxels * a.substeps * (a.scheme == AdvectionScheme::ModifiedMacCormack ? 2 : 1);
    if (samples > m.max_advection_samples)
      fail(Code::ResourceExhausted, f + ".advection.substeps = " + std::to_string(a.substeps) + " makes an estimated " +
                                        validate::number(samples) +
                                        " velocity samples (active voxels x substeps, x2 for MacCormack), more than "
                                        "--max-advection-samples = " +
                                        validate::number(m.max_advection_samples));
  }
  return voxels;
}

}  // namespace squall::clouds
