// eWave with the ocean engine: a session started from an ocean tile at t0 reproduces the ocean tile at
// t0 + T (eWave "is mathematically identical to that of the spectral model solution", J. Tessendorf,
// "Gilligan: A Prototype Framework for Simulating and Rendering Maritime Environments" (2017), sec. 3), and
// an ambient sea given as an ocean spec is subtracted inside obstructions (eq 77 read as
// h <- h - h_A (1 - O): as printed, h <- h_A (1 - O), it would overwrite h, while sec. 3.4 adds
// -h_A (1 - O) to the eWave height).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>

#include "common/byte_codec.h"
#include "common/error.h"
#include "common/limits.h"
#include "common/session_checkpoint.h"
#include "ewave/ewave_engine.h"
#include "ewave_support.h"
#include "ocean/ocean_engine.h"
#include "ocean/tile_spec_bytes.h"
#include "support/expect_error.h"
#include "support/test_runtime.h"
#include "support/worst.h"

namespace squall::ewave::test {
namespace {

ocean::OceanEngine& ocean_engine() {
  static ocean::OceanEngine engine(squall::test::runtime(), session_fft());
  return engine;
}

EWaveSession ocean_session(const EWaveConfig& c) {
  return EWaveSession(squall::test::runtime(), session_fft(), c, &ocean_engine());
}

// A 64 m x 64 m session at 1 m (Pierson-Moskowitz, 5 m/s: peak wavelength ~20 m, all modes resolved). With
// surface tension a capillary length of 0.3 m (k l up to 1.3 at the corner modes) makes it matter here.
EWaveConfig sea_config(DispersionKind dispersion) {
  EWaveConfig c = plain_config(64, 64, 1.0);
  c.dispersion = dispersion;
  const bool bottom = dispersion == DispersionKind::Shallow || dispersion == DispersionKind::Combined;
  c.depth = bottom ? 3.0 : 0.0;  // k_p h ~ 0.9: clearly not deep
  if (dispersion == DispersionKind::Capillary || dispersion == DispersionKind::Combined) c.capillary_length = 0.3;
  return c;
}

// One layer on the session grid with the session's dispersion, no drift.
ocean::TileSpec sea_spec(const EWaveConfig& c) {
  ocean::LayerSpec L;
  L.lx = c.length_x(), L.ly = c.length_y(), L.nx = c.nx, L.ny = c.ny;
  L.spectrum = ocean::SpectrumModel::PiersonMoskowitz;
  L.wind_speed = 5;
  L.wind_direction = 0.4;
  L.dispersion = ocean::DispersionKind(int(c.dispersion));
  L.depth = c.depth > 0 ? c.depth : 100;
  L.capillary_length = c.capillary_length;
  L.gravity = c.gravity;
  L.seed = 7;
  ocean::TileSpec spec;
  spec.layers = {L};
  return spec;
}

std::vector<float> ocean_height(const ocean::TileSpec& spec, const EWaveConfig& c, double t) {
  return ocean_engine().tile(ocean_on_grid(spec, c), t, ocean::Height).height.to_vector();
}

// Runs `steps` free steps of dt and returns the relative rms difference of h from the ocean at the end.
double relative_error_after(EWaveSession& s, const ocean::TileSpec& spec, const EWaveConfig& c, int steps, double dt) {
  Frame f;
  for (int n = 0; n < steps; ++n) f = s.step(plain_step(dt));
  std::vector<float> want = ocean_height(spec, c, f.time);
  return rms_difference(f.height, want) / rms(want);
}

class OceanStart : public ::testing::TestWithParam<DispersionKind> {};

// h and phi = -i (G/w)[h0 e^{-iwt} - conj(h0(-k)) e^{iwt}] at t0 = 12.3 s, then 50 free steps of 0.1 s (T = 5 s,
// ~1.4 peak periods; the ocean's phase w t reaches ~90 rad at the highest modes). The error budget is float round-off:
// the ocean's phase (within 1e-6 rad), eWave's float omega (~1e-7 relative) and 100 float FFTs (~1e-6 each);
// together a few 1e-6, so 1e-4 holds a 10x margin and still fails for any wrong sign or factor
// of phi, which errs by O(1). Control: the same h with phi = 0 splits into two opposite waves (O(1) error).
TEST_P(OceanStart, ReproducesTheOceanTileAtT0PlusT) {
  EWaveConfig c = sea_config(GetParam());
  const ocean::TileSpec spec = sea_spec(c);
  const double t0 = 12.3, dt = 0.1;
  const int steps = 50;
  c.start_time = t0;
  c.initial_ocean = spec;
  EWaveSession s = ocean_session(c);
  EXPECT_EQ(s.time(), t0);
  double error = relative_error_after(s, spec, c, steps, dt);
  EXPECT_NEAR(s.time(), t0 + steps * dt, 1e-9);
  std::printf("[ocean start] dispersion %d: relative rms difference after %d steps = %.3g\n", int(GetParam()), steps,
              error);
  EXPECT_LT(error, 1e-4);

  EWaveConfig control = sea_config(GetParam());
  control.start_time = t0;
  control.initial_height = ocean_height(spec, control, t0);  // phi = 0
  EWaveSession zero_phi = ocean_session(control);
  double control_error = relative_error_after(zero_phi, spec, control, steps, dt);
  std::printf("[ocean start] dispersion %d: control with phi = 0: %.3g\n", int(GetParam()), control_error);
  EXPECT_GT(control_error, 0.3);
}

INSTANTIATE_TEST_SUITE_P(EveryDispersion, OceanStart,
                         ::testing::Values(DispersionKind::Deep, DispersionKind::Shallow, DispersionKind::Capillary,
                                           DispersionKind::Combined));

// Double-precision state: the float ocean fields are converted at creation (a host round trip, once).
TEST(OceanStartDouble, StartsFromTheOceanTile) {
  if (!squall::test::runtime().device_info().double_precision) GTEST_SKIP() << "no fp64";
  EWaveConfig c = sea_config(DispersionKind::Deep);
  const ocean::TileSpec spec = sea_spec(c);
  c.start_time = 3.0;
  c.initial_ocean = spec;
  c.double_precision = true;
  EWaveSession s = ocean_session(c);
  double error = relative_error_after(s, spec, c, 10, 0.1);
  EXPECT_LT(error, 1e-4);
}

// Eq 77 with h_A from an ocean spec, evaluated at the session time at the start of the step. From rest
// (h = phi = 0 stays 0 over 3 steps of 0.05 s), one step of dt = 1e-6 s with O = 0 in a disc of radius 10 m
// (soft edge to 14 m): h1 = -h_A(0.15 s) (1 - O) before propagation; the propagator keeps h1 and gives
// phi = -(g/w) sin(w dt) h1 = -g dt h1 (1 + O(1e-11)); the step-6 mask then gives h = O h1.
// Where O = 0 the height is 0 after the step and the composite before the mask, h_A + h1 = h_A - phi/(g dt),
// is about 0 (float FFT round-off ~1e-6 of max|h_A|; asserted < 1e-4). Controls: without the ambient the
// composite is h_A, with eq 77 read as an overwrite it is 2 h_A; h_A taken at the end of the step (0.150001 s)
// differs from h_A(0.15 s) by ~1e-6 relative only, so the time check compares with h_A at 0.10 s, 0.05 s away.
TEST(OceanAmbient, CompositeIsZeroInsideTheObstruction) {
  EWaveConfig c = sea_config(DispersionKind::Deep);
  const ocean::TileSpec spec = sea_spec(c);
  c.ambient_ocean = spec;
  EWaveSession s = ocean_session(c);
  for (int n = 0; n < 3; ++n) s.step(plain_step(0.05));  // no obstruction: the ambient has no effect
  StepInputs in = plain_step(1e-6);
  in.obstruction =
      field(c, [](double x, double y) { return std::clamp((std::hypot(x - 32, y - 32) - 10) / 4, 0.0, 1.0); });
  Frame f = s.step(in);
  const std::vector<float> h_A = ocean_height(spec, c, 0.15), h_A_early = ocean_height(spec, c, 0.10);
  const double scale = max_abs(h_A), g_dt = c.gravity * in.dt;
  double composite = 0, masked = 0, edge = 0, against_early = 0, against_now = 0;
  size_t inside = 0;
  for (size_t i = 0; i < c.cells(); ++i) {
    double o = in.obstruction[i], h1 = -f.phi[i] / g_dt;
    if (o == 0) {
      ++inside;
      composite = squall::test::worse(composite, std::abs(h_A[i] + h1));
      masked = squall::test::worse(masked, double(std::abs(f.height[i])));
    }
    edge = squall::test::worse(edge, std::abs(f.height[i] + h_A[i] * (1 - o) * o));
    against_now = squall::test::worse(against_now, std::abs(h1 + h_A[i] * (1 - o)));
    against_early = squall::test::worse(against_early, std::abs(h1 + h_A_early[i] * (1 - o)));
  }
  std::printf(
      "[ocean ambient] max|h_A| = %.3g m, %zu cells with O = 0: max composite %.3g, soft edge %.3g, "
      "h1 vs h_A(0.15 s) %.3g, vs h_A(0.10 s) %.3g\n",
      scale, inside, composite / scale, edge / scale, against_now / scale, against_early / scale);
  EXPECT_GT(inside, 250u);  // ~pi 10^2 = 314 cells
  EXPECT_GT(scale, 0.01);
  EXPECT_EQ(masked, 0.0);                // eq 74 at step 6
  EXPECT_LT(composite / scale, 1e-4);    // eq 77: h_A + h = 0 where O = 0
  EXPECT_LT(edge / scale, 1e-4);         // h = -h_A (1 - O) O on the soft edge
  EXPECT_LT(against_now / scale, 1e-4);  // h_A at the session time at the start of the step
  EXPECT_GT(against_early / scale, 0.01);
}

// A step's own ocean spec overrides the config's, and a step's field overrides both.
TEST(OceanAmbient, StepSpecOverridesTheConfig) {
  EWaveConfig c = sea_config(DispersionKind::Deep);
  ocean::TileSpec config_spec = sea_spec(c), step_spec = sea_spec(c);
  step_spec.layers[0].seed = 99;
  c.ambient_ocean = config_spec;
  EWaveSession s = ocean_session(c);
  StepInputs in = plain_step(1e-6);
  in.obstruction.assign(c.cells(), 0.0f);  // O = 0 everywhere: phi = g dt h_A
  in.ambient_ocean = step_spec;
  Frame f = s.step(in);
  std::vector<float> want = ocean_height(step_spec, c, 0.0), phi_over = f.phi;
  for (float& v : phi_over) v = float(v / (c.gravity * in.dt));
  EXPECT_LT(rms_difference(phi_over, want) / rms(want), 1e-4);
  // A step's own field (no ocean of its own: the two are exclusive) over the config's ocean.
  EWaveSession fresh = ocean_session(c);
  StepInputs given = plain_step(1e-6);
  given.obstruction.assign(c.cells(), 0.0f);
  given.ambient_height = field(c, [](double x, double y) { return 0.01 * std::sin(x) * std::cos(2 * y); });
  phi_over = fresh.step(given).phi;
  for (float& v : phi_over) v = float(v / (c.gravity * given.dt));
  EXPECT_LT(rms_difference(phi_over, given.ambient_height) / rms(given.ambient_height), 1e-4);
}

using squall::test::expect_error;

// A step's ambient ocean looks at the call's cancellation before each layer and between the slices of a
// spectrum it builds: a cancelled step stops there, the session as it was and nothing built. A spectrum it
// keeps takes its bytes from the call's reservation of them.
TEST(OceanAmbient, AStepsOceanStopsWhenCancelledAndTakesTheCallsReservation) {
  const EWaveConfig c = sea_config(DispersionKind::Deep);
  Limits limits;
  limits.memory_budget = 1 << 30;
  LimitGate gate(limits);
  ocean::OceanEngine ocean(squall::test::runtime(), session_fft(), limits, 1 << 30, &gate);
  EWaveSession s(squall::test::runtime(), session_fft(), c, &ocean);
  StepInputs in = plain_step(0.1);
  in.obstruction.assign(c.cells(), 0.0f);
  in.ambient_ocean = sea_spec(c);
  expect_error(Code::Cancelled, "surface: before layer 0",
               [&] { s.step(in, {}, {Cancellation([] { return true; })}); });
  EXPECT_EQ(s.step_index(), 0u);
  EXPECT_EQ(ocean.spectra_built(), 0u);
  const uint64_t h0 = ocean.new_spectra_bytes(ocean_on_grid(*in.ambient_ocean, c));
  ASSERT_GT(h0, 0u);
  Slot call = gate.acquire_memory("the step", h0 + 1000);
  Slot spectra = call.split(h0);
  s.step(in, {}, {{}, &spectra});
  EXPECT_EQ(s.step_index(), 1u);
  EXPECT_EQ(ocean.spectra_built(), 1u);
  EXPECT_EQ(spectra.amount(), 0u);
  EXPECT_EQ(gate.cached_memory_bytes(), h0);
  EXPECT_EQ(gate.memory_bytes(), h0 + 1000);
}

// A session's initial ocean is evaluated as it is made, lent the creating call's cancellation and spectra
// reservation alike: a cancelled creation builds nothing, and a spectrum kept takes the call's share.
TEST(OceanAmbient, ASessionsInitialOceanStopsWhenCancelledAndTakesTheCallsReservation) {
  EWaveConfig c = sea_config(DispersionKind::Deep);
  c.initial_ocean = sea_spec(c);
  Limits limits;
  limits.memory_budget = 1 << 30;
  LimitGate gate(limits);
  ocean::OceanEngine ocean(squall::test::runtime(), session_fft(), limits, 1 << 30, &gate);
  expect_error(Code::Cancelled, "surface: before layer 0", [&] {
    EWaveSession(squall::test::runtime(), session_fft(), c, &ocean, &gate, nullptr,
                 {Cancellation([] { return true; })});
  });
  EXPECT_EQ(ocean.spectra_built(), 0u);
  const uint64_t h0 = ocean.new_spectra_bytes(ocean_on_grid(*c.initial_ocean, c));
  Slot spectra = gate.acquire_memory("the creation", h0);
  EWaveSession s(squall::test::runtime(), session_fft(), c, &ocean, &gate, nullptr, {{}, &spectra});
  EXPECT_EQ(ocean.spectra_built(), 1u);
  EXPECT_EQ(spectra.amount(), 0u);
  EXPECT_EQ(gate.cached_memory_bytes(), h0);
}

TEST(OceanAmbient, BadSpecsNameTheField) {
  EWaveConfig c = sea_config(DispersionKind::Deep);
  ocean::TileSpec bad = sea_spec(c);
  bad.layers[0].wind_speed = NAN;
  EWaveConfig with_bad = c;
  with_bad.ambient_ocean = bad;
  expect_error(Code::InvalidArgument, "config.ambient_ocean.layers[0].wind_speed", [&] { validate(with_bad); });
  with_bad = c;
  with_bad.initial_ocean = bad;
  expect_error(Code::InvalidArgument, "config.initial_ocean.layers[0].wind_speed", [&] { ocean_session(with_bad); });
  ocean::TileSpec wrong_grid = sea_spec(c);
  wrong_grid.nx = 32, wrong_grid.ny = 64;
  with_bad = c;
  with_bad.ambient_ocean = wrong_grid;
  expect_error(Code::InvalidArgument, "config.ambient_ocean.output", [&] { validate(with_bad); });
  with_bad = c;
  with_bad.initial_ocean = sea_spec(c);
  with_bad.initial_height.assign(c.cells(), 0.0f);
  expect_error(Code::InvalidArgument, "config.initial_ocean excludes", [&] { validate(with_bad); });

  EWaveSession s = ocean_session(c);
  StepInputs in = plain_step(0.1);
  in.ambient_ocean = bad;
  expect_error(Code::InvalidArgument, "inputs.ambient_ocean.layers[0].wind_speed", [&] { s.step(in); });
  in.ambient_ocean = sea_spec(c);
  in.ambient_height.assign(c.cells(), 0.0f);
  expect_error(Code::InvalidArgument, "inputs.ambient_ocean and inputs.ambient_height", [&] { s.step(in); });
  EXPECT_EQ(s.step_index(), 0u);

  with_bad = c;
  with_bad.ambient_ocean = sea_spec(c);
  expect_error(Code::FailedPrecondition, "config.ambient_ocean needs the ocean engine",
               [&] { make_session(with_bad); });
}

// A step's ambient ocean has its layers checked against the daemon's --max-grid-cells, not the default:
// a smaller limit refuses a layer the default allows, and a larger one allows a layer the default refuses.
TEST(OceanAmbient, AStepsOceanLayersAreCheckedAgainstTheDaemonsGridLimit) {
  const EWaveConfig c = sea_config(DispersionKind::Deep);  // 64 x 64
  StepInputs in = plain_step(0.1);
  in.ambient_ocean = sea_spec(c);
  in.ambient_ocean->layers[0].nx = in.ambient_ocean->layers[0].ny = 128;
  Limits small;
  small.max_grid_cells = uint64_t(c.cells());
  const LimitGate small_gate{small};
  EXPECT_NO_THROW(validate(in, c));
  expect_error(Code::ResourceExhausted, "inputs.ambient_ocean.layers[0]", [&] { validate(in, c, &small_gate); });
  EWaveEngineOptions options;
  options.ocean = &ocean_engine();
  LimitGate engine_gate{small};
  EWaveEngine engine(squall::test::runtime(), session_fft(), engine_gate, options);
  const std::string id = engine.create(c);
  expect_error(Code::ResourceExhausted, "inputs.ambient_ocean.layers[0]", [&] { engine.step(id, in); });

  Limits large;
  large.max_grid_cells = 2 * Limits{}.max_grid_cells;
  const LimitGate large_gate{large};
  in.ambient_ocean->layers[0].nx = 8192, in.ambient_ocean->layers[0].ny = 3072;  // 1.5 x the default limit
  EXPECT_NO_THROW(validate(in, c, &large_gate));
  expect_error(Code::ResourceExhausted, "inputs.ambient_ocean.layers[0]", [&] { validate(in, c); });
}

// An engine as squalld builds it (server/ewave/shared_engine.h): its sessions' ocean specs evaluated.
EWaveEngine ocean_ewave_engine(LimitGate& gate) {
  EWaveEngineOptions options;
  options.ocean = &ocean_engine();
  return EWaveEngine(squall::test::runtime(), session_fft(), gate, options);
}

// A hull (O = 0 inside, soft edge) moving across the 64 m sea, so that eq 77 subtracts h_A (1 - O) every step.
StepInputs hull_step(int n) {
  StepInputs in = plain_step(0.05);
  Shape hull;
  hull.kind = ShapeKind::Ellipse;
  hull.x = 20 + 1.5 * n, hull.y = 30, hull.a = 8, hull.b = 3, hull.heading = 0.3;
  in.shapes.push_back(hull);
  in.outputs.displacement = in.outputs.normals = true;
  return in;
}

// Lengths the FFT backend cannot transform (clFFT's are products of 2, 3, 5, 7, 11 and 13; 34 = 2 x 17) are
// refused by name before a session is made: its grid (config.ny; state.nx for a state restored), its initial
// and ambient oceans' layers, and a step's ambient ocean before the step changes anything, whether the step
// evaluates it (an obstruction) or not (36 runs).
TEST(OceanAmbient, LengthsTheFftBackendCannotTransformAreRefusedByName) {
  fft::Fft& clfft = squall::test::fft("clfft");
  ocean::OceanEngine ocean(squall::test::runtime(), clfft);
  EWaveEngineOptions options;
  options.ocean = &ocean;
  LimitGate gate{Limits{}};
  EWaveEngine engine(squall::test::runtime(), clfft, gate, options);
  const std::string backend = ": the clfft FFT backend transforms";
  EWaveConfig c = sea_config(DispersionKind::Deep);  // 64 x 64
  c.ny = 34;
  expect_error(Code::InvalidArgument, "config.ny = 34" + backend, [&] { engine.create(c); });
  c = sea_config(DispersionKind::Deep);
  c.initial_ocean = sea_spec(c);
  c.initial_ocean->layers[0].ny = 34;
  expect_error(Code::InvalidArgument, "config.initial_ocean.layers[0].ny = 34" + backend, [&] { engine.create(c); });
  c.ambient_ocean = c.initial_ocean;
  c.initial_ocean.reset();
  expect_error(Code::InvalidArgument, "config.ambient_ocean.layers[0].ny = 34" + backend, [&] { engine.create(c); });
  const std::string state =
      EWaveSession(squall::test::runtime(), squall::test::fft("vkfft"), plain_config(34, 64)).state();
  expect_error(Code::InvalidArgument, "state.nx = 34" + backend, [&] { engine.create_from_state(state); });
  EXPECT_EQ(engine.size(), 0u);

  c = sea_config(DispersionKind::Deep);
  const std::string id = engine.create(c);
  for (StepInputs in : {plain_step(0.05), hull_step(0)}) {
    in.ambient_ocean = sea_spec(c);
    in.ambient_ocean->layers[0].nx = 34;
    expect_error(Code::InvalidArgument, "inputs.ambient_ocean.layers[0].nx = 34" + backend,
                 [&] { engine.step(id, in); });
    EXPECT_NO_THROW(engine.check_runs_here(StepInputs{}));
    expect_error(Code::InvalidArgument, "inputs.ambient_ocean.layers[0].nx = 34", [&] { engine.check_runs_here(in); });
  }
  EXPECT_EQ(engine.view(id).steps, 0u);
  StepInputs in = hull_step(0);
  in.ambient_ocean = sea_spec(c);
  in.ambient_ocean->layers[0].nx = 36;
  EXPECT_EQ(engine.step(id, in).step, 1u);
}

// A config's ambient_ocean with a second layer and its other members away from their defaults.
EWaveConfig ambient_config() {
  EWaveConfig c = sea_config(DispersionKind::Deep);
  ocean::TileSpec spec = sea_spec(c);
  ocean::LayerSpec swell = spec.layers[0];
  swell.lx = swell.ly = 128, swell.nx = swell.ny = 32;
  swell.spectrum = ocean::SpectrumModel::Jonswap;
  swell.wind_speed = 9, swell.fetch = 40e3, swell.gamma = 2.5, swell.wind_direction = -0.7, swell.seed = 11;
  spec.layers.push_back(swell);
  spec.b_correction = true, spec.choppiness = 0.8, spec.whitecap_threshold = 0.2, spec.slope_k_max = 500;
  c.ambient_ocean = spec;
  return c;
}

// A version-2 checkpoint payload written out (the layout in server/ewave/ewave_engine.cpp): the state's
// bytes and the ambient ocean's, each after its u64 length.
std::string checkpoint_payload(const std::string& state, const std::string& spec) {
  ByteWriter out;
  out.put_counted(state);
  out.put_counted(spec);
  return out.take();
}

// The checkpoint of a session with an ambient ocean (EWaveEngine::checkpoint, what --state-dir writes) and
// its state bytes (GetState, for Restore) carry its config's ambient_ocean: restored into another engine
// (another replica, a restarted squalld), the session steps on bit-identically with the obstruction
// subtracting the same h_A (eq 77). Control: the same state of version 1, which holds no ambient ocean,
// gives other frames.
TEST(OceanAmbient, CheckpointAndStateResumeWithTheAmbientOceanBitIdentically) {
  LimitGate gate{Limits{}};
  const EWaveConfig c = ambient_config();
  std::string id, saved, state;
  std::vector<Frame> expected;
  {
    EWaveEngine first = ocean_ewave_engine(gate);
    id = first.create(c);
    for (int n = 0; n < 4; ++n) first.step(id, hull_step(n));
    saved = first.checkpoint(id);
    state = first.state(id);
    for (int n = 4; n < 10; ++n) expected.push_back(first.step(id, hull_step(n)));
  }
  EWaveEngine second = ocean_ewave_engine(gate);
  EXPECT_EQ(second.restore_checkpoint(saved), id);
  const std::string from_state = second.create_from_state(state);
  for (const std::string& restored : {id, from_state}) {
    const EWaveConfig config = second.view(restored).config;
    ASSERT_TRUE(config.ambient_ocean.has_value()) << restored << " lost config.ambient_ocean";
    EXPECT_EQ(ocean::encode_tile_spec(*config.ambient_ocean), ocean::encode_tile_spec(*c.ambient_ocean));
    for (int n = 4; n < 10; ++n) expect_bit_identical(second.step(restored, hull_step(n)), expected[n - 4]);
  }

  const std::string without = second.create_from_state(without_ambient_ocean(state));
  EXPECT_FALSE(second.view(without).config.ambient_ocean.has_value());
  EXPECT_GT(rms_difference(second.step(without, hull_step(4)).height, expected[0].height),
            1e-3 * rms(expected[0].height));
}

// A version-1 checkpoint (the state bytes alone, as squalld wrote them before payload version 2) still
// resumes, without an ambient ocean: like a session made from those state bytes.
TEST(OceanAmbient, VersionOneCheckpointResumesWithoutTheAmbientOcean) {
  LimitGate gate{Limits{}};
  EWaveEngine e = ocean_ewave_engine(gate);
  const std::string id = e.create(ambient_config());
  for (int n = 0; n < 3; ++n) e.step(id, hull_step(n));
  const std::string state = without_ambient_ocean(e.state(id));
  e.close(id);
  EXPECT_EQ(e.restore_checkpoint(encode_checkpoint({"eWave session", 1, id}, state)), id);
  EXPECT_FALSE(e.view(id).config.ambient_ocean.has_value());
  const std::string from_state = e.create_from_state(state);
  for (int n = 3; n < 6; ++n) expect_bit_identical(e.step(id, hull_step(n)), e.step(from_state, hull_step(n)));
  e.close(id);

  expect_error(Code::Unavailable, "payload version 4; this squalld reads versions 1 to 3", [&] {
    e.restore_checkpoint(encode_checkpoint({"eWave session", 4, id}, state));
  });
}

// Older daemons read what a session without an ambient ocean writes: its state is of version 1 (magic
// "SQEWAVE1", nothing after phi) and its checkpoint's payload of version 2, as before state version 2. A
// session with one writes a state of version 2.
TEST(OceanAmbient, OnlyAStateWithAnAmbientOceanIsOfVersionTwo) {
  LimitGate gate{Limits{}};
  EWaveEngine e = ocean_ewave_engine(gate);
  const EWaveConfig plain = sea_config(DispersionKind::Deep);
  const std::string id = e.create(plain), ambient = e.create(ambient_config());
  const std::string state = e.state(id);
  EXPECT_EQ(state.substr(0, 8), "SQEWAVE1");
  EXPECT_EQ(state.size(), sizeof(StateHeader) + state_field_bytes(plain.nx, plain.ny, false));
  EXPECT_EQ(without_ambient_ocean(state), state);
  EXPECT_EQ(e.state(ambient).substr(0, 8), "SQEWAVE2");
  CheckpointHeader header;
  decode_checkpoint(e.checkpoint(ambient), "eWave session", "checkpoint", &header);
  EXPECT_EQ(header.version, 2u);
}

// State bytes whose ambient ocean is cut short, followed by more bytes, or invalid are InvalidArgument
// naming them, and make no session.
TEST(OceanAmbient, BadAmbientOceansInStateBytesAreInvalidArgument) {
  LimitGate gate{Limits{}};
  EWaveEngine e = ocean_ewave_engine(gate);
  const EWaveConfig c = ambient_config();
  const std::string id = e.create(c), state = e.state(id);
  e.close(id);
  const std::string v1 = without_ambient_ocean(state);
  const std::string head = state.substr(0, v1.size());  // the version-2 header, h and phi
  ASSERT_EQ(state.size(), v1.size() + 8 + ocean::encode_tile_spec(*c.ambient_ocean).size());
  expect_error(Code::InvalidArgument, "want " + std::to_string(state.size()) + " for its grid and ambient ocean",
               [&] { e.create_from_state(state.substr(0, state.size() - 1)); });
  expect_error(Code::InvalidArgument, "for its grid and ambient ocean", [&] { e.create_from_state(state + "x"); });
  expect_error(Code::InvalidArgument, "want " + std::to_string(v1.size() + 8), [&] { e.create_from_state(head); });
  ocean::TileSpec bad = *c.ambient_ocean;
  bad.layers[1].wind_speed = NAN;
  ByteWriter with_bad(head);
  with_bad.put_counted(ocean::encode_tile_spec(bad));
  expect_error(Code::InvalidArgument, "state.ambient_ocean.layers[1].wind_speed",
               [&] { e.create_from_state(with_bad.take()); });
  EXPECT_EQ(e.size(), 0u);
  EXPECT_TRUE(e.view(e.create_from_state(state)).config.ambient_ocean.has_value()) << "the good bytes restore";
}

// A version-2 payload that is cut short, or whose ambient ocean is invalid, is InvalidArgument naming it.
TEST(OceanAmbient, BadCheckpointPayloadsAreInvalidArgument) {
  LimitGate gate{Limits{}};
  EWaveEngine e = ocean_ewave_engine(gate);
  const EWaveConfig c = ambient_config();
  const std::string id = e.create(c), state = without_ambient_ocean(e.state(id));
  e.close(id);
  auto restore = [&](const std::string& payload) {
    e.restore_checkpoint(encode_checkpoint({"eWave session", 2, id}, payload));
  };
  const std::string good = checkpoint_payload(state, ocean::encode_tile_spec(*c.ambient_ocean));
  expect_error(Code::InvalidArgument, "checkpoint is not an eWave session payload: truncated",
               [&] { restore(good.substr(0, 4)); });
  expect_error(Code::InvalidArgument, "ambient ocean of", [&] { restore(good.substr(0, good.size() - 1)); });
  expect_error(Code::InvalidArgument, "1 bytes follow the ambient ocean", [&] { restore(good + "x"); });
  ocean::TileSpec bad = *c.ambient_ocean;
  bad.layers[1].wind_speed = NAN;
  expect_error(Code::InvalidArgument, "checkpoint.ambient_ocean.layers[1].wind_speed",
               [&] { restore(checkpoint_payload(state, ocean::encode_tile_spec(bad))); });
  EXPECT_EQ(e.size(), 0u);
  EXPECT_EQ(e.restore_checkpoint(encode_checkpoint({"eWave session", 2, id}, good)), id);
  EXPECT_TRUE(e.view(id).config.ambient_ocean.has_value());
}

}  // namespace
}  // namespace squall::ewave::test
