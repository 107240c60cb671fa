// eWave sessions: save/restore, the engine's ids, limits and TTL, and input validation.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <latch>
#include <thread>
#include <vector>

#include "common/byte_codec.h"
#include "common/error.h"
#include "common/limits.h"
#include "ewave/ewave_engine.h"
#include "ewave/ewave_state_format.h"
#include "ewave/propagator.h"
#include "ewave_support.h"
#include "support/expect_error.h"
#include "support/fftw_wisdom.h"
#include "support/test_runtime.h"

namespace squall::ewave::test {
namespace {

EWaveConfig busy_config() {
  EWaveConfig c = plain_config(48, 40);
  c.trim = true;
  c.trim_width = 0.04;
  c.source_scale = 0.3;
  c.friction_time = 2.0;
  c.initial_height = field(
      c, [](double x, double y) { return 0.003 * std::exp(-((x - 0.2) * (x - 0.2) + (y - 0.2) * (y - 0.2)) / 2e-4); });
  return c;
}

StepInputs busy_step(int n) {
  StepInputs in = plain_step(0.01);
  Shape hull;
  hull.kind = ShapeKind::Ellipse;
  hull.x = 0.1 + 0.004 * n, hull.y = 0.2, hull.a = 0.03, hull.b = 0.012, hull.heading = 0.2;
  in.shapes.push_back(hull);
  in.drift_x = 0.013;
  in.outputs.displacement = in.outputs.normals = true;
  return in;
}

TEST(EWaveSession, SaveAndRestoreContinueBitIdentically) {
  EWaveSession a = make_session(busy_config());
  for (int n = 0; n < 5; ++n) a.step(busy_step(n));
  std::string saved = a.state();
  const LimitGate gate{Limits{}};
  EWaveSession b = make_session(EWaveSession::config_from_state(saved, gate));
  b.restore(saved);
  for (int n = 5; n < 10; ++n) expect_bit_identical(a.step(busy_step(n)), b.step(busy_step(n)));
  // And into the original session: rewinding it reproduces the same steps.
  a.restore(saved);
  EWaveSession c = make_session(busy_config());
  c.restore(saved);
  expect_bit_identical(a.step(busy_step(5)), c.step(busy_step(5)));
}

// A new session's state is its initial h and phi, bit for bit, in the state's type (float or double), and
// zero where a field is not given.
TEST(EWaveSession, ItsStateIsItsInitialFieldsBitForBit) {
  for (const bool wide : {false, true}) {
    if (wide && !squall::test::runtime().device_info().double_precision) continue;
    EWaveConfig c = plain_config(24, 20);
    c.double_precision = wide;
    c.initial_height = field(c, [](double x, double y) { return 0.01 * std::sin(40 * x) * std::cos(30 * y); });
    c.initial_phi = field(c, [](double x, double y) { return 0.002 * std::cos(50 * x + 20 * y); });
    for (const bool phi : {true, false}) {
      EWaveConfig given = c;
      if (!phi) given.initial_phi.clear();
      const std::string state = make_session(given).state();
      const char* fields = state_fields(state);
      const size_t cells = c.initial_height.size();
      for (size_t i = 0; i < 2 * cells; ++i) {
        const float expected = i < cells ? c.initial_height[i] : phi ? c.initial_phi[i - cells] : 0.0f;
        double value = 0;
        if (wide) {
          std::memcpy(&value, fields + i * sizeof(double), sizeof(double));
        } else {
          float f = 0;
          std::memcpy(&f, fields + i * sizeof(float), sizeof(float));
          value = f;
        }
        ASSERT_EQ(value, double(expected)) << (wide ? "double" : "float") << " state, value " << i;
      }
    }
  }
}

// A step sent again with its retry key (a retry whose first attempt was made and its reply lost) is not
// made again: the frame of that step comes back, bit for bit. A new key steps on; a count the session is
// not at is refused. A session restored from a checkpoint keeps the key but not the step's displacement, so a
// retry asking for it is refused rather than stepped twice.
TEST(EWaveSession, AStepRetriedWithItsKeyIsMadeOnce) {
  EWaveSession a = make_session(busy_config()), reference = make_session(busy_config());
  const Frame first = a.step(busy_step(0), {"key 1", 0});
  expect_bit_identical(first, reference.step(busy_step(0)));
  expect_bit_identical(a.step(busy_step(0), {"key 1", 0}), first);
  EXPECT_EQ(a.step_index(), 1u);
  squall::test::expect_error(Code::Aborted, "after_step = 0, but the session has made 1 steps (another caller", [&] {
    a.step(busy_step(1), {"key 2", 0});
  });
  squall::test::expect_error(Code::Aborted, "after_step = 7, but the session has made 1 steps (after_step is past them",
                             [&] {
                               a.step(busy_step(1), {"key 2", 7});
                             });
  const Frame second = a.step(busy_step(1), {"key 2", 1});
  expect_bit_identical(second, reference.step(busy_step(1)));
  expect_bit_identical(a.step(busy_step(1), {"key 2", std::nullopt}), second);
  EXPECT_EQ(a.step_index(), 2u);
  EXPECT_EQ(a.time(), reference.time());

  const std::string saved = a.state();
  EWaveSession b = make_session(EWaveSession::config_from_state(saved, LimitGate{Limits{}}));
  b.restore(saved);
  b.set_retry_key(a.retry_key());  // as a checkpoint carries it
  squall::test::expect_error(Code::FailedPrecondition, "whose displacement and normals the session no longer holds",
                             [&] {
                               b.step(busy_step(1), {"key 2", std::nullopt});
                             });
  StepInputs height_only = busy_step(1);
  height_only.outputs = OutputSelection{};
  const Frame again = b.step(height_only, {"key 2", std::nullopt});
  EXPECT_EQ(again.step, 2u);
  EXPECT_EQ(again.height, second.height);
  expect_bit_identical(b.step(busy_step(2), {"key 3", 2}), reference.step(busy_step(2)));
  expect_bit_identical(b.step(busy_step(3)), reference.step(busy_step(3)));  // no key: always a new step
}

// What --max-session-bytes and the memory budget count for a session covers the device buffers it holds
// once a step has uploaded every input map (obstruction, ambient height, sources, drift field), in float
// and in double: all but the second plane of an ambient ocean, which a map of heights does not fill.
TEST(EWaveSession, ItsBudgetCoversTheBuffersItHolds) {
  for (bool double_precision : {false, true}) {
    if (double_precision && !squall::test::runtime().device_info().double_precision) continue;
    EWaveConfig c = plain_config(48, 40);
    c.double_precision = double_precision;
    EWaveSession session = make_session(c);
    const size_t cells = 48 * 40;
    StepInputs in = busy_step(0);
    in.obstruction.assign(cells, 1.0f);
    in.ambient_height.assign(cells, 0.0f);
    in.source_height.assign(cells, 0.0f);
    in.source_phi.assign(cells, 0.0f);
    in.drift_field_x.assign(cells, 0.0f);
    in.drift_field_y.assign(cells, 0.0f);
    session.step(in);
    const uint64_t budget = session_bytes(c), held = session.device_bytes();
    EXPECT_LE(held, budget) << "double " << double_precision;
    EXPECT_EQ(held + cells * sizeof(float), budget) << "double " << double_precision;
  }
}

// A hull alone rewrites only its cells and those of the hull before (the map is filled with 1 once); the
// same steps with an explicit map of ones (the map uploaded, the hull multiplied in) give the same frames
// bit for bit, also when the hull jumps clear of where it was (a cell the last hull left at 0 must be 1).
TEST(EWaveSession, AHullAloneRewritesItsOldCellsAsAFreshMapWould) {
  EWaveSession alone = make_session(busy_config()), mapped = make_session(busy_config());
  for (int n = 0; n < 6; ++n) {
    StepInputs in = busy_step(n);
    in.shapes[0].x = 0.1 + 0.08 * (n % 3);  // 0.1, 0.18, 0.26, back to 0.1: jumps of more than its length
    StepInputs with_map = in;
    with_map.obstruction.assign(busy_config().cells(), 1.0f);
    expect_bit_identical(alone.step(in), mapped.step(with_map));
  }
}

// The surface current is grad phi (Gilligan eq 11): for phi = a sin(kx x) cos(ky y), u = a kx cos(kx x) cos(ky y)
// and v = -a ky sin(kx x) sin(ky y), to the central difference's factor sin(k h) / (k h) (0.99 here); and it
// follows the state: after steps it is the gradient of the new phi.
TEST(EWaveSession, SurfaceCurrentIsTheGradientOfPhi) {
  EWaveConfig c = plain_config(64, 48, 0.02);
  const double kx = 2 * 3.14159265358979 / c.length_x(), ky = 2 * 2 * 3.14159265358979 / c.length_y(), a = 0.01;
  c.initial_phi = field(c, [&](double x, double y) { return a * std::sin(kx * x) * std::cos(ky * y); });
  EWaveSession session = make_session(c);
  SurfaceCurrent current = session.surface_current();
  ASSERT_EQ(current.u.size(), c.cells());
  EXPECT_EQ(current.dx, c.dx);
  std::vector<float> u = field(c, [&](double x, double y) { return a * kx * std::cos(kx * x) * std::cos(ky * y); });
  std::vector<float> v = field(c, [&](double x, double y) { return -a * ky * std::sin(kx * x) * std::sin(ky * y); });
  const double fx = std::sin(kx * c.dx) / (kx * c.dx), fy = std::sin(ky * c.dy) / (ky * c.dy);
  for (size_t n = 0; n < c.cells(); ++n) {
    ASSERT_NEAR(current.u[n], fx * u[n], 1e-6) << n;
    ASSERT_NEAR(current.v[n], fy * v[n], 1e-6) << n;
  }
  EXPECT_GT(max_abs(current.u), 0.9 * a * kx);
  Frame after = session.step(plain_step(0.05));
  current = session.surface_current();
  EXPECT_EQ(current.time, after.time);
  const size_t nx = size_t(c.nx), cell = 5 * nx + 7;
  EXPECT_NEAR(current.u[cell], (after.phi[cell + 1] - after.phi[cell - 1]) / (2 * c.dx), 1e-6);
  EXPECT_NEAR(current.v[cell], (after.phi[cell + nx] - after.phi[cell - nx]) / (2 * c.dy), 1e-6);
}

using squall::test::expect_error;

// A session makes the FFT plans of its steps when it is created. On the fftw backend, which measures a
// plan on first use, neither a step of the state alone nor one with the derived outputs adds to FFTW's
// wisdom.
TEST(EWaveSession, StepsOnFftwMakeNoPlanOfTheirOwn) {
  if (squall::test::runtime().device_info().type != "cpu") GTEST_SKIP() << "the fftw backend runs on CPU devices only";
  EWaveSession session(squall::test::runtime(), squall::test::fft("fftw"), plain_config(44, 36));  // a size of its own
  const std::string created = squall::test::fftwf_wisdom();
  Frame state = session.step(plain_step(0.01));
  Frame outputs = session.step(busy_step(0));
  EXPECT_EQ(squall::test::fftwf_wisdom(), created) << "a step made an FFTW plan";
  EXPECT_EQ(state.height.size(), size_t(44 * 36));
  EXPECT_EQ(outputs.normals.size(), size_t(3 * 44 * 36));
}

TEST(EWaveSession, BadInputsAreInvalidArgumentsNamingTheField) {
  EWaveSession s = make_session(plain_config(32, 16));
  StepInputs in = plain_step(0.01);
  in.obstruction.assign(32 * 15, 1.0f);
  expect_error(Code::InvalidArgument, "inputs.obstruction", [&] { s.step(in); });
  in = plain_step(0.01);
  in.ambient_height.assign(32 * 16, 0.0f);
  in.ambient_height[17] = NAN;
  expect_error(Code::InvalidArgument, "inputs.ambient_height[17]", [&] { s.step(in); });
  in = plain_step(0.0);
  expect_error(Code::InvalidArgument, "inputs.dt", [&] { s.step(in); });
  in = plain_step(-1);
  expect_error(Code::InvalidArgument, "inputs.dt", [&] { s.step(in); });
  in = plain_step(NAN);
  expect_error(Code::InvalidArgument, "inputs.dt", [&] { s.step(in); });
  in = plain_step(0.01);
  in.obstruction.assign(32 * 16, 1.5f);
  expect_error(Code::InvalidArgument, "inputs.obstruction[0]", [&] { s.step(in); });
  in = plain_step(0.01);
  in.shapes.push_back(Shape{ShapeKind::Circle, 0.1, 0.1, -1, 0, 0, {}});
  expect_error(Code::InvalidArgument, "inputs.shapes[0].a", [&] { s.step(in); });
  EXPECT_EQ(s.step_index(), 0u) << "a rejected step changes nothing";
  EWaveConfig c = plain_config(32, 16);
  c.dx = NAN;
  expect_error(Code::InvalidArgument, "config.dx", [&] { make_session(c); });
  c = plain_config(32, 16);
  c.dispersion = DispersionKind::Shallow;
  expect_error(Code::InvalidArgument, "config.depth", [&] { make_session(c); });
  c = plain_config(32, 16);
  c.initial_height.assign(7, 0.0f);
  expect_error(Code::InvalidArgument, "config.initial_height", [&] { make_session(c); });
  c = plain_config(32, 16);
  c.trim = true;
  c.trim_width = 1.0;
  expect_error(Code::InvalidArgument, "config.trim_width", [&] { make_session(c); });
  expect_error(Code::InvalidArgument, "state", [&] { s.restore("not a state"); });
}

// A session driven past the fields a state holds (+-1e25; here phi -= g h dt with h = 1e25) hands out no
// state that Restore would refuse: GetState is FAILED_PRECONDITION naming the field, and the state taken
// before it restores.
TEST(EWaveSession, AStateRestoreWouldRefuseIsNotHandedOut) {
  EWaveSession s = make_session(plain_config(32, 16));
  std::string state = s.state();
  std::vector<float> h(32 * 16, 1e25f);
  std::memcpy(state_fields(state), h.data(), h.size() * sizeof(float));
  s.restore(state);
  EXPECT_EQ(s.state(), state);
  s.step(plain_step(1.0));
  expect_error(Code::FailedPrecondition, "the session's fields have grown past what a state holds (state.fields[",
               [&] { s.state(); });
  s.restore(state);
  EXPECT_EQ(s.state(), state);
}

// A step may not take the session's time past kMaxTime (1e9 s, a SimTime's range), which its state bytes
// could then not be restored with.
TEST(EWaveSession, AStepPastTheTimeRangeIsRefused) {
  EWaveConfig c = plain_config(32, 16);
  c.start_time = kMaxTime - 0.05;
  EWaveSession s = make_session(c);
  StepInputs in;
  in.dt = 0.1;
  expect_error(Code::InvalidArgument, "inputs.dt = 0.1 takes the session's time", [&] { s.step(in); });
  EXPECT_EQ(s.step_index(), 0u);
  in.dt = 0.01;
  s.step(in);
  EXPECT_EQ(s.step_index(), 1u);
}

// The host's table of (config, dt), in the state's type, as bytes.
std::vector<char> host_table(const EWaveConfig& config, double dt) {
  return to_state_type(propagator_coefficients(config, dt), config.double_precision);
}

void expect_table(const cl::Buffer& table, const EWaveConfig& config, double dt) {
  const std::vector<char> expected = host_table(config, dt);
  EXPECT_EQ(squall::test::read<char>(table, expected.size()), expected);
}

// One table per grid, dispersion and dt, equal to the host's: a second request of the same is the same
// buffer, and another dt, gravity, cell size, dispersion, depth, capillary length or precision makes one
// of its own.
TEST(CoefficientCache, OneTablePerGridDispersionAndDt) {
  Runtime& runtime = squall::test::runtime();
  CoefficientCache cache;
  const EWaveConfig a = plain_config(32, 24);
  const cl::Buffer table = cache.get(runtime, a, 0.01);
  expect_table(table, a, 0.01);
  EXPECT_EQ(cache.get(runtime, a, 0.01)(), table());
  EXPECT_EQ(cache.computed(), 1u);
  expect_table(cache.get(runtime, a, 0.02), a, 0.02);
  uint64_t made = 2;
  auto expect_own_table = [&](const std::function<void(EWaveConfig&)>& change) {
    EWaveConfig b = a;
    change(b);
    expect_table(cache.get(runtime, b, 0.01), b, 0.01);
    EXPECT_EQ(cache.computed(), ++made);
  };
  expect_own_table([](EWaveConfig& c) { c.gravity = 9.7; });
  expect_own_table([](EWaveConfig& c) { c.dx = 0.012; });
  expect_own_table([](EWaveConfig& c) { c.dispersion = DispersionKind::Shallow, c.depth = 0.05; });
  expect_own_table([](EWaveConfig& c) { c.dispersion = DispersionKind::Shallow, c.depth = 0.08; });
  expect_own_table([](EWaveConfig& c) { c.dispersion = DispersionKind::Capillary, c.capillary_length = 0.003; });
  if (runtime.device_info().double_precision) expect_own_table([](EWaveConfig& c) { c.double_precision = true; });
}

// Past the byte budget the least recently used table goes; a table larger than the budget is not kept.
TEST(CoefficientCache, TablesPastTheBudgetEvictTheLeastRecentlyUsed) {
  Runtime& runtime = squall::test::runtime();
  const EWaveConfig config = plain_config(32, 24);
  CoefficientCache cache(2 * host_table(config, 0.01).size());
  cache.get(runtime, config, 0.01);
  cache.get(runtime, config, 0.02);
  cache.get(runtime, config, 0.01);  // now the most recently used
  cache.get(runtime, config, 0.03);  // evicts 0.02
  EXPECT_EQ(cache.computed(), 3u);
  EXPECT_EQ(cache.bytes(), 2 * host_table(config, 0.01).size());
  cache.get(runtime, config, 0.01);
  EXPECT_EQ(cache.computed(), 3u);
  cache.get(runtime, config, 0.02);  // evicts 0.03
  cache.get(runtime, config, 0.03);  // evicts 0.01
  cache.get(runtime, config, 0.01);
  EXPECT_EQ(cache.computed(), 6u);
  const EWaveConfig larger = plain_config(64, 48);
  cache.get(runtime, larger, 0.01);
  cache.get(runtime, larger, 0.01);
  EXPECT_EQ(cache.computed(), 8u);
  EXPECT_EQ(cache.bytes(), 2 * host_table(config, 0.01).size());
  EWaveConfig double_precision = larger;
  double_precision.double_precision = true;
  for (const EWaveConfig& c : {config, larger, double_precision})
    EXPECT_EQ(CoefficientCache::table_bytes(c), host_table(c, 0.01).size()) << "what a session's own cache keeps";
}

// Kept tables hold their bytes in the memory budget until evicted or the cache goes. Where the budget has
// no room for a new table the least recently used give theirs; where even all of theirs would be too
// little, the table serves its caller, equal to the host's, is not kept, and the others stay.
TEST(CoefficientCache, KeptTablesHoldTheirBytesInTheMemoryBudget) {
  Runtime& runtime = squall::test::runtime();
  const EWaveConfig config = plain_config(32, 24), larger = plain_config(64, 24);  // a table of 1.9x
  const uint64_t table = host_table(config, 0.01).size();
  Limits limits;
  limits.memory_budget = table + table / 2;
  LimitGate gate(limits);
  {
    CoefficientCache cache(CoefficientCache::kDefaultMaxBytes, &gate);
    cache.get(runtime, config, 0.01);
    EXPECT_EQ(gate.memory_bytes(), table);
    cache.get(runtime, config, 0.02);  // 0.01 gives its budget to it
    cache.get(runtime, config, 0.02);
    EXPECT_EQ(cache.computed(), 2u);
    EXPECT_EQ(gate.memory_bytes(), table);
    expect_table(cache.get(runtime, larger, 0.01), larger, 0.01);  // past the budget even alone
    cache.get(runtime, larger, 0.01);
    EXPECT_EQ(cache.computed(), 4u);
    EXPECT_EQ(cache.bytes(), table);  // 0.02 stays
    cache.get(runtime, config, 0.02);
    EXPECT_EQ(cache.computed(), 4u);
    EXPECT_EQ(gate.memory_bytes(), table);
    EXPECT_EQ(gate.cached_memory_bytes(), table);
    {
      Slot call = gate.acquire_memory("a call", table);  // takes the kept table's budget back
      EXPECT_EQ(cache.bytes(), 0u);
    }
    cache.get(runtime, config, 0.02);
    EXPECT_EQ(cache.computed(), 5u);
  }
  EXPECT_EQ(gate.memory_bytes(), 0u);
}

// Sessions missing one table at once compute it once: the others wait for it.
TEST(CoefficientCache, SessionsMissingOneTableAtOnceComputeItOnce) {
  CoefficientCache cache;
  const EWaveConfig config = plain_config(256, 256);  // a table of about a millisecond's work
  std::latch start(8);
  std::vector<cl_mem> got(8);
  std::vector<std::thread> sessions;
  for (size_t i = 0; i < got.size(); ++i)
    sessions.emplace_back([&, i] {
      start.arrive_and_wait();
      got[i] = cache.get(squall::test::runtime(), config, 0.01)();
    });
  for (auto& t : sessions) t.join();
  EXPECT_EQ(cache.computed(), 1u);
  for (cl_mem m : got) EXPECT_EQ(m, got.front());
}

class EngineTest : public testing::Test {
 protected:
  EngineTest() : gate_(limits()) {}
  static Limits limits() {
    Limits l;
    l.max_sessions = 2;
    l.max_grid_cells = 64 * 64;
    return l;
  }
  EWaveEngine engine(std::chrono::milliseconds ttl = std::chrono::minutes(1)) {
    EWaveEngineOptions o;
    o.sessions.ttl = ttl;
    o.sessions.clock = [this] { return now_; };
    return EWaveEngine(squall::test::runtime(), squall::test::fft(), gate_, o);
  }
  LimitGate gate_;
  std::chrono::steady_clock::time_point now_{};
};

// The engine's propagator tables may keep cache_bound() of its memory budget and device: a 4096^2 grid's
// single-precision table (4 x 2049 x 4096 floats, 128 MiB) under a budget of 1 GiB, where a fixed 64 MiB
// computed it for every step.
TEST(EWaveEngineCache, PropagatorTablesKeepAQuarterOfTheMemoryBudget) {
  Limits limits;
  limits.memory_budget = uint64_t(1) << 30;
  LimitGate gate(limits);
  Runtime& runtime = squall::test::runtime();
  EWaveEngine e(runtime, squall::test::fft(), gate);
  EXPECT_EQ(e.coefficients().max_bytes(), cache_bound(limits.memory_budget, runtime.device_info().global_memory_bytes,
                                                      CoefficientCache::kDefaultMaxBytes));
  if (runtime.device_info().global_memory_bytes >= (uint64_t(2) << 30)) {  // an eighth of it past 256 MiB
    EXPECT_EQ(e.coefficients().max_bytes(), limits.memory_budget / 4);
  }
}

TEST_F(EngineTest, ClosedIdIsNotFoundAndIdsAreRandom128Bit) {
  EWaveEngine e = engine();
  std::string a = e.create(plain_config(32, 32)), b = e.create(plain_config(32, 32));
  EXPECT_EQ(a.size(), 32u);
  EXPECT_NE(a, b);
  EXPECT_EQ(gate_.live_sessions(), 2u);
  e.step(a, plain_step(0.01));
  e.close(a);
  EXPECT_EQ(gate_.live_sessions(), 1u);
  expect_error(Code::NotFound, "session_id", [&] { e.step(a, plain_step(0.01)); });
  expect_error(Code::NotFound, "session_id", [&] { e.state(a); });
  expect_error(Code::NotFound, "session_id", [&] { e.close(a); });
  expect_error(Code::NotFound, "session_id", [&] { e.step(std::string(32, '0'), plain_step(0.01)); });
  e.step(b, plain_step(0.01));  // the other session is untouched
}

// A call reads its session's config to validate and size what it does, then steps, reads the state or closes
// it in a second locked call: where the id names a session made again under it meanwhile (closed and
// created), the second part is refused rather than run on a session the first did not see.
TEST_F(EngineTest, ACallThatReadASessionsConfigRunsOnThatSessionOnly) {
  EWaveEngine e = engine();
  SessionView made;
  const std::string id = e.create(plain_config(32, 32), std::string(32, 'a'), {}, "", &made);
  EXPECT_EQ(made.id, id);
  EXPECT_EQ(made.config.nx, 32);
  EXPECT_EQ(made.steps, 0u);
  const SessionView first = e.view(id);
  EXPECT_EQ(first.serial, made.serial);
  StepGuard guard;
  guard.session_serial = first.serial;
  EXPECT_EQ(e.step(id, plain_step(0.01), guard).step, 1u) << "the session read is stepped";
  EXPECT_FALSE(e.state(id, first.serial).empty());
  EXPECT_EQ(e.view(id).steps, 1u);
  e.close(id);
  ASSERT_EQ(e.create(plain_config(16, 16), id), id);
  expect_error(Code::Aborted, "session_id names a session made again under that id",
               [&] { e.step(id, plain_step(0.01), guard); });
  expect_error(Code::Aborted, "session_id names a session made again", [&] { e.state(id, first.serial); });
  expect_error(Code::NotFound, "session_id", [&] { e.close(id, first.serial); });
  const SessionView second = e.view(id);
  EXPECT_EQ(second.config.nx, 16);
  EXPECT_NE(second.serial, first.serial);
  EXPECT_EQ(second.steps, 0u) << "the refused step left the new session as it was";
  guard.session_serial = second.serial;
  EXPECT_EQ(e.step(id, plain_step(0.01), guard).step, 1u);
  e.close(id, second.serial);
  expect_error(Code::NotFound, "session_id", [&] { e.view(id); });
}

TEST_F(EngineTest, SessionLimitAndGridLimitAreResourceExhausted) {
  EWaveEngine e = engine();
  e.create(plain_config(32, 32));
  e.create(plain_config(32, 32));
  expect_error(Code::ResourceExhausted, "max-sessions", [&] { e.create(plain_config(32, 32)); });
  expect_error(Code::ResourceExhausted, "config.nx * config.ny", [&] { e.create(plain_config(128, 64)); });
}

TEST_F(EngineTest, IdleSessionsAreEvictedAfterTheTtl) {
  EWaveEngine e = engine(std::chrono::seconds(10));
  std::string a = e.create(plain_config(32, 32));
  now_ += std::chrono::seconds(6);
  std::string b = e.create(plain_config(32, 32));
  now_ += std::chrono::seconds(6);  // a idle 12 s, b 6 s
  EXPECT_EQ(e.evict_idle(), 1u);
  expect_error(Code::NotFound, "session_id", [&] { e.step(a, plain_step(0.01)); });
  e.step(b, plain_step(0.01));
  EXPECT_EQ(gate_.live_sessions(), 1u);
}

TEST_F(EngineTest, CheckpointRestoresTheSessionUnderItsIdBitIdentically) {
  std::string id, saved;
  Frame expected;
  {
    EWaveEngine first = engine();
    id = first.create(plain_config(32, 32));
    for (int n = 0; n < 5; ++n) first.step(id, busy_step(n));
    saved = first.checkpoint(id);
    expected = first.step(id, busy_step(5));
  }
  EWaveEngine second = engine();  // a restarted daemon
  EXPECT_EQ(second.restore_checkpoint(saved), id);
  expect_bit_identical(second.step(id, busy_step(5)), expected);
  expect_error(Code::AlreadyExists, "already a live eWave session", [&] { second.restore_checkpoint(saved); });
  expect_error(Code::InvalidArgument, "checkpoint", [&] { second.restore_checkpoint(second.state(id)); });
}

// A session moved to another daemon by its checkpoint takes its last step's retry key along: the retry of
// that step sent to the new daemon gets the step's frame, and the session is not stepped twice. Only a
// session with a key writes payload version 3; without one it writes version 2, which older daemons read.
// A key of more than 64 bytes in a checkpoint is refused by name.
TEST_F(EngineTest, ACheckpointCarriesTheLastStepsRetryKey) {
  StepInputs heights = busy_step(0);
  heights.outputs = OutputSelection{};
  std::string id, saved, keyless;
  Frame made;
  {
    EWaveEngine first = engine();
    id = first.create(plain_config(32, 32));
    keyless = first.checkpoint(id);
    made = first.step(id, heights, {"the only step", std::nullopt});
    saved = first.checkpoint(id);
  }
  CheckpointHeader header;
  const std::string keyless_payload = decode_checkpoint(keyless, "eWave session", "checkpoint", &header);
  EXPECT_EQ(header.version, 2u);
  decode_checkpoint(saved, "eWave session", "checkpoint", &header);
  EXPECT_EQ(header.version, 3u);
  EWaveEngine second = engine();
  second.restore_checkpoint(saved);
  expect_bit_identical(second.step(id, heights, {"the only step", std::nullopt}), made);
  EXPECT_EQ(second.view(id).steps, 1u);
  EXPECT_EQ(second.step(id, heights, {"another step", std::nullopt}).step, 2u);

  ByteWriter long_key(keyless_payload);
  long_key.put_counted(std::string(65, 'k'));
  expect_error(Code::InvalidArgument, "checkpoint holds a retry key of 65 bytes", [&] {
    second.restore_checkpoint(encode_checkpoint({"eWave session", 3, std::string(32, 'a')}, long_key.take()));
  });
}

// Sessions of one engine share their propagator tables: two sessions of one grid stepping with one dt
// compute one, and a later session finds it made after the first two have gone. Their steps are those
// of a session with a table of its own, bit for bit.
TEST_F(EngineTest, SessionsOfOneGridAndDtShareAPropagatorTable) {
  EWaveEngine e = engine();
  std::string a = e.create(busy_config()), b = e.create(busy_config());
  e.step(a, busy_step(0));
  e.step(b, busy_step(0));
  EXPECT_EQ(e.coefficients().computed(), 1u);
  e.step(a, plain_step(0.02));
  EXPECT_EQ(e.coefficients().computed(), 2u);
  e.close(a);
  e.close(b);
  std::string c = e.create(busy_config());
  EWaveSession alone(squall::test::runtime(), squall::test::fft(), busy_config());  // the engine's FFT
  for (int n = 0; n < 3; ++n) expect_bit_identical(e.step(c, busy_step(n)), alone.step(busy_step(n)));
  EXPECT_EQ(e.coefficients().computed(), 2u);
}

TEST_F(EngineTest, StateMovesASessionToAnotherEngine) {
  EWaveEngine e1 = engine(), e2 = engine();
  std::string a = e1.create(busy_config());
  for (int n = 0; n < 3; ++n) e1.step(a, busy_step(n));
  std::string b = e2.create_from_state(e1.state(a));
  for (int n = 3; n < 6; ++n) expect_bit_identical(e1.step(a, busy_step(n)), e2.step(b, busy_step(n)));
}

}  // namespace
}  // namespace squall::ewave::test
