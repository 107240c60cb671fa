// The heap a cloud model's meshes take while they are read from a request and checked, measured, against
// the bound the service reserves before reading them (rpc::mesh_read_bytes). The global operator new is
// replaced here to count the bytes in use (malloc_usable_size) and their peak, so this is a binary of its own.
#include <gtest/gtest.h>
#include <malloc.h>

#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <new>
#include <string>

#include "clouds/build_memory.h"
#include "clouds/clouds_request.h"
#include "clouds/obj_mesh.h"
#include "clouds/renderer.h"
#include "clouds/volume.h"
#include "common/error.h"

namespace {

std::atomic<int64_t> g_in_use{0}, g_peak{0};

void count(int64_t bytes) {
  const int64_t now = g_in_use.fetch_add(bytes) + bytes;
  for (int64_t peak = g_peak.load(); now > peak && !g_peak.compare_exchange_weak(peak, now);) {
  }
}

}  // namespace

void* operator new(size_t bytes) {
  void* p = std::malloc(bytes ? bytes : 1);
  if (!p) throw std::bad_alloc();
  count(int64_t(malloc_usable_size(p)));
  return p;
}
void operator delete(void* p) noexcept {
  if (!p) return;
  count(-int64_t(malloc_usable_size(p)));
  std::free(p);
}
void operator delete(void* p, size_t) noexcept { operator delete(p); }
void* operator new[](size_t bytes) { return operator new(bytes); }
void operator delete[](void* p) noexcept { operator delete(p); }
void operator delete[](void* p, size_t) noexcept { operator delete(p); }

namespace squall::clouds {
namespace {

namespace v1 = squall::v1;

// The heap's peak above what was in use when `f` started, bytes; an Error `f` throws ends it like a return.
int64_t peak_of(const std::function<void()>& f) {
  const int64_t start = g_in_use.load();
  g_peak.store(start);
  try {
    f();
  } catch (const Error&) {
  }
  return g_peak.load() - start;
}

// Reads and checks `model` as BuildVolume does before its build is reserved; returns the heap's peak over it
// as a fraction of the bytes reserved for it.
double peak_over_reserved(const v1::CloudModel& model) {
  const int64_t peak = peak_of([&] {
    const CloudModel m = rpc::model(model);
    CloudModel copy = m;  // CloudEngine::validate's, which takes the model by value
    std::vector<MeshPiece> pieces;
    validate(copy, "model", &pieces);
    build_bytes(copy, pieces);
  });
  return double(peak) / double(rpc::mesh_read_bytes(model));
}

// A sphere of radius 10 m with `rings` rings of `segments` vertices between its poles, in OBJ: quads between
// the rings, triangles at the caps. `split`: every face has vertices of its own, as exporters split them along
// seams, so that only welding closes it.
std::string sphere_obj(int rings, int segments, bool split) {
  std::vector<std::array<double, 3>> points{{0, 0, 10}};
  for (int r = 1; r <= rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const double theta = M_PI * r / (rings + 1), phi = 2 * M_PI * s / segments;
      points.push_back(
          {10 * std::sin(theta) * std::cos(phi), 10 * std::sin(theta) * std::sin(phi), 10 * std::cos(theta)});
    }
  points.push_back({0, 0, -10});
  const int south = int(points.size()) - 1;
  auto at = [&](int r, int s) { return 1 + (r - 1) * segments + s % segments; };
  std::vector<std::vector<int>> faces;
  for (int s = 0; s < segments; ++s) {
    faces.push_back({0, at(1, s), at(1, s + 1)});
    for (int r = 1; r < rings; ++r) faces.push_back({at(r, s), at(r + 1, s), at(r + 1, s + 1), at(r, s + 1)});
    faces.push_back({south, at(rings, s + 1), at(rings, s)});
  }
  std::string obj;
  auto vertex = [&](const std::array<double, 3>& p) {
    char line[96];
    std::snprintf(line, sizeof line, "v %.9g %.9g %.9g\n", p[0], p[1], p[2]);
    obj += line;
  };
  if (!split)
    for (const auto& p : points) vertex(p);
  for (const auto& face : faces) {
    std::string f = "f";
    for (size_t k = 0; k < face.size(); ++k) {
      if (split) vertex(points[size_t(face[k])]);
      f += ' ';
      f += std::to_string(split ? int(k) - int(face.size()) : face[k] + 1);  // relative: -n for the first
    }
    obj += f + "\n";
  }
  return obj;
}

v1::CloudModel model_with_obj(const std::string& obj) {
  v1::CloudModel model;
  model.set_voxel_size(0.5);
  model.add_meshes()->set_obj(obj);
  return model;
}

TEST(MeshMemory, CountingAnObjAgreesWithReadingIt) {
  const std::string obj = sphere_obj(30, 40, false) + "v 1 2 3 # unused\n\tf 1/1/1 2//2 3 4 5 -1\r\nf 1 2\n";
  const ObjCounts counts = count_obj(obj);
  std::string text = obj.substr(0, obj.rfind("f 1 2\n"));  // the two-index face is refused when read
  const TriangleMesh mesh = parse_obj(text, "obj");
  EXPECT_EQ(counts.vertices, mesh.vertices.size());
  EXPECT_EQ(counts.triangles, mesh.triangles.size() / 3);
  EXPECT_EQ(counts.vertices, 30u * 40 + 3);
  EXPECT_EQ(counts.triangles, 2u * 40 + 29u * 40 * 2 + 4);
  EXPECT_EQ(mesh.vertices.capacity(), mesh.vertices.size());  // read into room counted out before
  EXPECT_EQ(mesh.triangles.capacity(), mesh.triangles.size());
}

// `count` vertices no face uses, in OBJ.
std::string unused_vertices(int count) {
  std::string unused;
  for (int k = 0; k < count; ++k) {
    char line[48];
    std::snprintf(line, sizeof line, "v %.4f 0 0\n", k * 1e-4);
    unused += line;
  }
  return unused;
}

// Welded, split and indexed spheres; a sphere beside many vertices no face uses; one face fanned into many
// triangles over a few vertices; the flat form. Each peaks within its reservation and above a quarter of it.
TEST(MeshMemory, ReadingAndCheckingAMeshStaysWithinItsReservation) {
  std::vector<std::pair<std::string, v1::CloudModel>> cases;
  for (int rings : {60, 100, 141, 200})  // the hash tables' sizes fall differently against their prime steps
    cases.emplace_back("indexed sphere of " + std::to_string(rings) + " rings",
                       model_with_obj(sphere_obj(rings, rings, false)));
  cases.emplace_back("split sphere", model_with_obj(sphere_obj(150, 150, true)));
  cases.emplace_back("unused vertices", model_with_obj(sphere_obj(4, 4, false) + unused_vertices(100000)));
  std::string fan = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf";
  for (int k = 0; k < 200000; ++k) fan += k % 4 == 0 ? " 1" : k % 4 == 1 ? " 2" : k % 4 == 2 ? " 3" : " 4";
  cases.emplace_back("one long face", model_with_obj(fan + "\n"));
  v1::CloudModel flat;
  flat.set_voxel_size(0.5);
  const TriangleMesh sphere = parse_obj(sphere_obj(200, 200, false), "obj");
  v1::MeshSpec* mesh = flat.add_meshes();
  for (const Vec3d& v : sphere.vertices)
    for (double c : v) mesh->add_vertices(c);
  for (uint32_t t : sphere.triangles) mesh->add_triangles(t);
  cases.emplace_back("flat sphere", flat);
  for (const auto& [name, model] : cases) {
    const double fraction = peak_over_reserved(model);
    EXPECT_LE(fraction, 1.0) << name;
    EXPECT_GE(fraction, 1.0 / 4) << name << ": the reservation is loose";
  }
}

// A build, from reading its request to the grids for the device, stays within what the service holds for it:
// the mesh's read bytes, held through the build (the request's model lives on, and build_cloud checks the
// model again, welded copy and tables), and the build's own. The build's bytes alone fall short for a model of
// a small sphere beside 10^6 vertices no face uses (each counted at 36 bytes in them): 140 MB against 98.
TEST(MeshMemory, ABuildStaysWithinItsMeshAndBuildReservations) {
  const v1::CloudModel request = model_with_obj(sphere_obj(4, 4, false) + unused_vertices(1000000));
  uint64_t read = 0, build = 0;
  const int64_t peak = peak_of([&] {
    read = rpc::mesh_read_bytes(request);
    CloudModel model = rpc::model(request);
    {
      CloudModel copy = model;  // CloudEngine::validate's
      std::vector<MeshPiece> pieces;
      validate(copy, "model", &pieces);
      build = build_bytes(copy, pieces);
    }
    const CloudVolume volume = build_cloud(std::move(model));  // moved into CloudEngine::build
    const NanoGrids grids = to_nanovdb(volume);
  });
  EXPECT_LE(double(peak), double(read + build));
  EXPECT_GT(double(peak), 1.2 * double(build)) << "the build's bytes alone would hold it";
}

}  // namespace
}  // namespace squall::clouds
