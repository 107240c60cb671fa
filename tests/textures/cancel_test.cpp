// Long Lagrangian work stops when its caller goes: the advection of the grids' vertices and the
// reconstruction run in slices of about 0.1 s on the device, and the advection asks its Cancellation
// between them (the RPC layer's "client gone, deadline passed, shutting down").
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "common/cancel.h"
#include "support/expect_error.h"
#include "support/test_runtime.h"
#include "textures/textures_support.h"

namespace squall::test {
namespace {

using namespace squall::textures;
using Clock = std::chrono::steady_clock;

// Seconds that advection->next() takes when its cancellation is requested `after` s into it (it throws
// Error(Cancelled) then).
double seconds_to_stop(Advection& advection, std::atomic<bool>& stop, double after) {
  const auto start = Clock::now();
  std::thread timer([&] {
    std::this_thread::sleep_for(std::chrono::duration<double>(after));
    stop = true;
  });
  expect_error(Code::Cancelled, "the advection", [&] { advection.next(); });
  timer.join();
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// About 3e6 vertices (d = 0.007 over the unit square, 16 x 16 vertices a grid) carried over 64 RK4
// substeps a frame: seconds of the two cores in one launch. Asked to stop 0.2 s into a frame, the
// advection stops within a few slices.
TEST(TexturesCancel, ALagrangianAdvectionStopsBetweenSlicesOfItsVertices) {
  if (runtime().device_info().type != "cpu") GTEST_SKIP() << "the frame is sized for a CPU device's pace";
  AdvectSpec spec = noise_spec(Method::LagrangianGrids, SQUALL_VELOCITY_UNIFORM, {0.2, 0.1}, 32);
  spec.lagrangian.d = 0.007;
  spec.lagrangian.grid_res = 16;
  spec.substeps = 64;
  std::atomic<bool> stop{false};
  std::unique_ptr<Advection> advection = texture_engine().start(spec, {}, Cancellation([&] { return stop.load(); }));
  advection->next();  // frame 0 lays the grids out; frame 1 advects them
  EXPECT_LT(seconds_to_stop(*advection, stop, 0.2), 1.0);
}

}  // namespace
}  // namespace squall::test
