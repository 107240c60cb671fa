// The same request and seed give bit-identical frames on one device, and a stream resumed from a
// checkpoint continues exactly as the uninterrupted one.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "common/error.h"
#include "support/expect_error.h"
#include "textures/lagrangian.h"
#include "textures/state_codec.h"
#include "textures/textures_support.h"

namespace squall::test {
namespace {

using namespace squall::textures;

void expect_resumes_exactly(const AdvectSpec& spec) {
  auto through = run(spec, 12);
  auto again = run(spec, 12);
  for (int i = 0; i < 12; ++i) ASSERT_EQ(through[i].planes, again[i].planes) << "frame " << i;

  auto first = texture_engine().start(spec);
  for (int i = 0; i <= 5; ++i) first->next();
  std::string state = first->checkpoint();
  first.reset();
  auto resumed = texture_engine().start(spec, state);
  for (int i = 6; i < 12; ++i) {
    TextureFrame frame = resumed->next();
    ASSERT_EQ(frame.index, i);
    ASSERT_EQ(frame.planes, through[i].planes) << "frame " << i;
  }
}

TEST(TexturesDeterminism, LagrangianGridsResumeBitIdentically) {
  expect_resumes_exactly(noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_VORTEX, {0.5, 0.5, 0.5, 0.1}));
}

TEST(TexturesDeterminism, EulerianLayersResumeBitIdentically) {
  expect_resumes_exactly(noise_spec(Method::EulerianMultilayer, SQUALL_VELOCITY_VORTEX, {0.5, 0.5, 0.5, 0.1}));
}

TEST(TexturesDeterminism, EulerianCascadeResumesBitIdentically) {
  // The vorticity cascade's (w_k, theta_k) are part of the checkpoint (F. Neyret, "Advected Textures",
  // SCA 2003, sec. 4).
  expect_resumes_exactly(cascade_spec(SQUALL_VELOCITY_VORTEX, {0.06, 0.5, 0.5, 0.1}, 2.0));
}

TEST(TexturesDeterminism, RandomRegenerationOffsetsResumeBitIdentically) {
  AdvectSpec spec = noise_spec(Method::TwoPhaseFlowMap, SQUALL_VELOCITY_VORTEX, {0.5, 0.5, 0.5, 0.1});
  spec.eulerian.latencies = {0.1};  // regenerations before and after the checkpoint
  spec.eulerian.random_offset = true;
  expect_resumes_exactly(spec);
}

TEST(TexturesDeterminism, ACheckpointOfAnotherShapeIsRefused) {
  AdvectSpec spec = noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_UNIFORM);
  auto advection = texture_engine().start(spec);
  advection->next();
  std::string state = advection->checkpoint();
  spec.lagrangian.grid_res = 6;
  EXPECT_THROW(texture_engine().start(spec, state), squall::Error);
  EXPECT_THROW(texture_engine().start(spec, "garbage"), squall::Error);
}

// A checkpoint's last value (the Lagrangian vertices' uvs, the Eulerian nodes' state) made NaN, or past
// what a stream reaches (kMaxStateValue): refused by name rather than resumed into planes of NaN; within
// it, resumed.
TEST(TexturesDeterminism, ACheckpointHoldingAValueNoStreamReachesIsRefused) {
  for (Method method : {Method::LagrangianGrids, Method::EulerianMultilayer}) {
    AdvectSpec spec = noise_spec(method, SQUALL_VELOCITY_UNIFORM);
    auto advection = texture_engine().start(spec);
    advection->next();
    const std::string state = advection->checkpoint();
    auto with_last = [&](float value) {
      std::string forged = state;
      std::memcpy(&forged[forged.size() - sizeof(float)], &value, sizeof(float));
      return forged;
    };
    for (float bad : {std::nanf(""), 3e38f, -1e21f})
      expect_error(Code::InvalidArgument, "resume_state holds the ",
                   [&] { texture_engine().start(spec, with_last(bad)); });
    EXPECT_NO_THROW(texture_engine().start(spec, with_last(1e19f)));
  }
}

// A checkpoint whose last regeneration time of a slot (a double after the version, the started flag, the
// frame index and the count: byte 21) lies far from its frame's time is refused: its phase weights would not
// be finite.
TEST(TexturesDeterminism, ARegenerationTimeFarFromTheFramesTimeIsRefused) {
  AdvectSpec spec = noise_spec(Method::EulerianMultilayer, SQUALL_VELOCITY_UNIFORM);
  auto advection = texture_engine().start(spec);
  for (int i = 0; i < 3; ++i) advection->next();
  const std::string state = advection->checkpoint();
  for (double forged : {1.7e308, 1e6, -1e6}) {
    std::string bad = state;
    std::memcpy(&bad[21], &forged, sizeof(double));
    expect_error(Code::InvalidArgument, "resume_state holds the regeneration time",
                 [&] { texture_engine().start(spec, bad); });
  }
  EXPECT_NO_THROW(texture_engine().start(spec, state));
}

// A Lagrangian checkpoint's particle born after its frame's time (the first particle's birth: a double
// after the version, the started flag, the frame index, the counter, the next id, the count and its id, at
// byte 45) is refused: its age, and so its weight, would be negative.
TEST(TexturesDeterminism, AParticleBornAfterTheFramesTimeIsRefused) {
  AdvectSpec spec = noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_UNIFORM);
  auto advection = texture_engine().start(spec);
  for (int i = 0; i < 3; ++i) advection->next();
  const std::string state = advection->checkpoint();
  for (double forged : {1e308, advection->time() + 1}) {
    std::string bad = state;
    std::memcpy(&bad[45], &forged, sizeof(double));
    expect_error(Code::InvalidArgument, "resume_state holds a particle born at",
                 [&] { texture_engine().start(spec, bad); });
  }
  EXPECT_NO_THROW(texture_engine().start(spec, state));
}

// A Lagrangian checkpoint that holds more particles than the request's advection ever holds (twice its
// output region's area over d^2, which its memory estimate counts) is refused before they are read: the
// count (a u64 after the version, the started flag, the frame index, the counter and the next id: byte 29)
// forged one past that bound names both.
TEST(TexturesDeterminism, MoreParticlesThanTheAdvectionHoldsAreRefused) {
  AdvectSpec spec = noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_UNIFORM);
  auto advection = texture_engine().start(spec);
  advection->next();
  std::string bad = advection->checkpoint();
  const uint64_t bound = squall::textures::lagrangian_grid_bound(spec), forged = bound + 1;
  std::memcpy(&bad[29], &forged, sizeof(forged));
  expect_error(Code::InvalidArgument,
               "resume_state holds " + std::to_string(forged) + " particles, past the " + std::to_string(bound),
               [&] { texture_engine().start(spec, bad); });
}

// A Lagrangian checkpoint at frame 0 (started) of `grids` FADING particles (killed at 0 s) whose grids
// each span [0, 1]^2: the layout of Lagrangian::checkpoint.
std::string spanning_grids(size_t grids, int res, bool started = true) {
  textures::StateWriter out;
  out.put(uint32_t(1));  // the version
  out.put(started);
  out.put(int64_t(0));       // the frame index
  out.put(uint64_t(0));      // the particle counter
  out.put(uint64_t(grids));  // the next id
  out.put(uint64_t(grids));  // the count, then each particle's id, birth and kill
  for (size_t k = 0; k < grids; ++k) out.put(uint64_t(k)), out.put(0.0), out.put(0.0);
  std::vector<float> positions;
  for (size_t k = 0; k < grids; ++k)
    for (int b = 0; b < res; ++b)
      for (int a = 0; a < res; ++a) positions.insert(positions.end(), {float(a) / (res - 1), float(b) / (res - 1)});
  out.put_vector(positions);
  out.put_vector(std::vector<float>(positions.size(), 0.0f));  // the uvs
  return out.take();
}

// A Lagrangian checkpoint whose grids each span the whole output region, each in every one of its 32 x 32
// reconstruction tiles, is refused before any tile list is made when they meet more tiles in all than its
// request's grids ever meet (lagrangian_tile_bound): it would take the host's memory and the device for
// hours. So is one holding particles before its first frame.
TEST(TexturesDeterminism, GridsSpreadPastTheTilesAnAdvectionMeetsAreRefused) {
  const AdvectSpec spec = noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_UNIFORM, {}, 512);
  const size_t fit = lagrangian_tile_bound(spec.lagrangian, spec.output) / (32 * 32);
  const int res = spec.lagrangian.grid_res;
  expect_error(Code::InvalidArgument, "reconstruction tiles in all, past the",
               [&] { texture_engine().start(spec, spanning_grids(fit + 1, res)); });
  EXPECT_NO_THROW(texture_engine().start(spec, spanning_grids(fit, res)));
  expect_error(Code::InvalidArgument, "particles before its first frame",
               [&] { texture_engine().start(spec, spanning_grids(1, res, false)); });
}

// A frame whose grids would meet more tiles than the bound (FADING grids spread over the whole output, as
// ones fading for a long fade_tau in a strong flow would be, with the grids inserted around them) deletes the
// most spread until its tile lists fit: its checkpoint then resumes.
TEST(TexturesDeterminism, AFramesGridsAreKeptWithinTheTilesAnAdvectionMeets) {
  AdvectSpec spec = noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_UNIFORM, {}, 512);
  spec.lagrangian.fade_tau = 1e6;
  const size_t fit = lagrangian_tile_bound(spec.lagrangian, spec.output) / (32 * 32);
  auto advection = texture_engine().start(spec, spanning_grids(fit, spec.lagrangian.grid_res));
  const TextureFrame frame = advection->next();
  EXPECT_GT(frame.stats.particles.deleted, 0);
  EXPECT_GT(frame.stats.particles.alive, 0);
  EXPECT_NO_THROW(texture_engine().start(spec, advection->checkpoint()));
}

}  // namespace
}  // namespace squall::test
