// The NanoVDB path on the device: a grid built with OpenVDB, converted with nanovdb::openToNanoVDB and
// uploaded as is, read through PNanoVDB.h in an OpenCL kernel, gives exactly the host's values.
#include <gtest/gtest.h>

#include <random>

#include "clouds/nanovdb_volume.h"
#include "clouds/volume.h"
#include "runtime/kernel.h"
#include "runtime/kernel_sources.h"
#include "support/test_runtime.h"

namespace squall::clouds {
namespace {

TEST(NanoVdb, DeviceLookupsEqualHostReadAccessorExactly) {
  CloudModel model;
  model.voxel_size = 0.5;
  model.skin = 2;
  model.spheres.push_back({{1, -2, 3}, 8});
  model.pyroclastic.layers = 2;
  model.pyroclastic.amplitude = 2;
  model.pyroclastic.noise.frequency = 0.2;
  CloudVolume volume = build_cloud(model);
  NanoHandle handle = to_nanovdb(*volume.density);
  auto* grid = handle.grid<float>();
  ASSERT_NE(grid, nullptr);
  auto acc = grid->getAccessor();

  // Random voxels in and around the active bounds (ramp, interior tiles, background) plus far away.
  const auto& bounds = volume.stats.bounds;
  std::mt19937 rng(7);
  std::vector<int> ijk;
  std::vector<float> expected;
  for (int i = 0; i < 20000; ++i) {
    nanovdb::Coord c;
    for (int a = 0; a < 3; ++a) {
      std::uniform_int_distribution<int> d(bounds.min()[a] - 3, bounds.max()[a] + 3);
      c[a] = i % 100 == 0 ? d(rng) * 1000 : d(rng);
    }
    ijk.insert(ijk.end(), {c[0], c[1], c[2]});
    expected.push_back(acc.getValue(c));
  }
  size_t nonzero = 0, partial = 0;
  for (float v : expected) {
    nonzero += v > 0;
    partial += v > 0 && v < 1;
  }
  ASSERT_GT(nonzero, 1000u);
  ASSERT_GT(partial, 100u);

  Runtime& rt = test::runtime();
  cl::Buffer device_grid = upload_nanovdb(rt, handle);
  cl::Buffer coords = test::upload(ijk);
  cl::Buffer out(rt.context(), CL_MEM_WRITE_ONLY, expected.size() * sizeof(float));
  Kernel<cl::Buffer, cl::Buffer, cl_int, cl::Buffer> lookup(rt, "clouds/probe.cl", "nanovdb_lookup");
  lookup.launch(cl::NDRange(round_up(expected.size(), 64)), cl::NDRange(64), device_grid, coords,
                cl_int(expected.size()), out);
  std::vector<float> got = test::read<float>(out, expected.size());
  for (size_t i = 0; i < expected.size(); ++i)
    ASSERT_EQ(got[i], expected[i]) << "voxel " << ijk[3 * i] << "," << ijk[3 * i + 1] << "," << ijk[3 * i + 2];
  // And the NanoVDB values equal the OpenVDB grid's.
  auto vdb = volume.density->getConstAccessor();
  for (size_t i = 0; i < expected.size(); ++i)
    ASSERT_EQ(expected[i], vdb.getValue(openvdb::Coord(ijk[3 * i], ijk[3 * i + 1], ijk[3 * i + 2])));
}

// PNanoVDB.h is an embedded system header under "nanovdb/PNanoVDB.h": spliced into the programs that
// include it, with its libc includes blanked, from the embedded copy and with --kernel-dir alike.
TEST(NanoVdb, KernelSourcesSplicePNanoVdbEmbeddedAndFromAKernelDir) {
  for (const std::string& dir : {std::string(), std::string(SQUALL_SOURCE_DIR) + "/kernels"}) {
    KernelSources sources(dir);
    std::string text = sources.expanded("clouds/render.cl");
    EXPECT_NE(text.find("pnanovdb_hdda_ray_clip("), std::string::npos) << dir;
    EXPECT_NE(text.find("#line 1 \"nanovdb/PNanoVDB.h\""), std::string::npos) << dir;
    EXPECT_EQ(text.find("#include <"), std::string::npos) << dir;
    // OpenCL C 1.2 (no -cl-std=CL2.0, which NVIDIA's compiler refuses): the tables are __constant.
    EXPECT_EQ(sources.build_options("clouds/render.cl"), "") << dir;
    EXPECT_NE(text.find("#define PNANOVDB_STATIC_CONST __constant"), std::string::npos) << dir;
  }
}

}  // namespace
}  // namespace squall::clouds
