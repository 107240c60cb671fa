// Ocean tiles on the device: statistics against P(k), time evolution, drift, periodicity, determinism,
// choppy-wave invariants, whitecaps, sampling, and agreement with the FFTW double-precision reference.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <latch>
#include <map>
#include <span>
#include <thread>

#include "ocean/cpu_reference.h"
#include "ocean_test_util.h"
#include "support/expect_error.h"
#include "support/worst.h"

namespace squall::ocean {
namespace {

using test::engine;

// E|h~(k)|^2 = (P(k) + P(-k)) dkx dky for every mode of the layer grid (Nyquist row and column 0), with D
// over each mode's angular cell as the engine takes it.
std::vector<double> expected_power(const LayerSpec& L) {
  std::vector<double> e(size_t(L.nx * L.ny), 0.0);
  double dkx = 2 * M_PI / L.lx, dky = 2 * M_PI / L.ly;
  for (int64_t j = 0; j < L.ny; ++j)
    for (int64_t i = 0; i < L.nx; ++i) {
      int64_t n = test::signed_mode(i, L.nx), m = test::signed_mode(j, L.ny);
      if (2 * i == L.nx || 2 * j == L.ny) continue;
      const double kx = n * dkx, ky = m * dky;
      e[i + L.nx * j] =
          (CpuReference::spectrum(L, kx, ky, dkx, dky) + CpuReference::spectrum(L, -kx, -ky, dkx, dky)) * dkx * dky;
    }
  return e;
}

double sum_of(const std::vector<double>& values) {
  double sum = 0;
  for (double v : values) sum += v;
  return sum;
}

TEST(OceanTile, VarianceMatchesSpectrumSumAndHs) {
  TileSpec spec = test::single(SpectrumModel::PiersonMoskowitz, SpreadingModel::Mitsuyasu, 64, 400);
  std::vector<double> e = expected_power(spec.layers[0]);
  double expected = 0, e2 = 0;
  for (double v : e) expected += v, e2 += v * v;
  const int seeds = 32;
  double mean = 0;
  for (int s = 0; s < seeds; ++s) {
    spec.layers[0].seed = 1000 + s;
    double r = test::rms(engine().tile(spec, 3.0, Height).height);
    mean += r * r / seeds;
  }
  double sigma = std::sqrt(2 * e2 / seeds);  // |h~|^2 exponential per mode, h~(-k) = conj h~(k)
  EXPECT_NEAR(mean, expected, 4 * sigma) << "sigma " << sigma;
  // the band 2 pi / 400 .. pi / 6.25 holds 96.5% of m0 = alpha g^2 / (5 w_p^4) (the tail above 2.2 rad/s)
  double wp = 0.879 * 9.81 / 10, m0 = 0.0081 * 9.81 * 9.81 / (5 * std::pow(wp, 4));
  EXPECT_NEAR(expected / m0, 0.97, 0.02);
  EXPECT_NEAR(4 * std::sqrt(mean), 4 * std::sqrt(m0), 0.05 * 4 * std::sqrt(m0));  // Hs
}

TEST(OceanTile, RadialPowerSpectrumMatchesP) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::VonMises, 64, 300);
  spec.layers[0].wind_direction = 0.4;
  const LayerSpec& L = spec.layers[0];
  std::vector<double> e = expected_power(L);
  const int seeds = 24, bins = 6;
  double k_nyq = M_PI * L.nx / L.lx;
  std::vector<double> measured(bins, 0), expected(bins, 0), variance(bins, 0);
  for (int s = 0; s < seeds; ++s) {
    spec.layers[0].seed = 77 + s;
    auto H = test::spectrum_of(engine().tile(spec, 10.0, Height).height, L.nx, L.ny);
    for (int64_t j = 0; j < L.ny; ++j)
      for (int64_t i = 0; i < L.nx; ++i) {
        double kx = test::signed_mode(i, L.nx) * 2 * M_PI / L.lx, ky = test::signed_mode(j, L.ny) * 2 * M_PI / L.ly;
        int b = int(std::hypot(kx, ky) / k_nyq * bins);
        if (b >= bins) continue;
        size_t at = size_t(i + L.nx * j);
        measured[b] += std::norm(H[at]);
        expected[b] += e[at];  // summed over the seeds, like measured
        variance[b] += 2 * e[at] * e[at];
      }
  }
  for (int b = 0; b < bins; ++b) {
    if (expected[b] < 1e-6 * expected[1]) continue;
    double sigma = std::sqrt(variance[b]);
    EXPECT_NEAR(measured[b], expected[b], 5 * sigma) << "bin " << b << " ratio " << measured[b] / expected[b];
  }
}

TEST(OceanTile, EachModeAdvancesByOmegaT) {
  // Pierson cos^2 spreading: P(-k) = 0 for downwind k, so h~(k, t) = h0(k) e^{-i w t} exactly.
  TileSpec spec = test::single(SpectrumModel::PiersonMoskowitz, SpreadingModel::PiersonCos2, 64, 200);
  spec.layers[0].dispersion = DispersionKind::Combined;
  spec.layers[0].depth = 8;
  const LayerSpec& L = spec.layers[0];
  double t0 = 2.0, t1 = 5.5;
  auto a = test::spectrum_of(engine().tile(spec, t0, Height).height, L.nx, L.ny);
  auto b = test::spectrum_of(engine().tile(spec, t1, Height).height, L.nx, L.ny);
  double peak = 0;
  for (auto& c : a) peak = std::max(peak, std::abs(c));
  double worst = 0;
  int checked = 0;
  for (int64_t j = 0; j < L.ny; ++j)
    for (int64_t i = 0; i < L.nx; ++i) {
      int64_t n = test::signed_mode(i, L.nx), m = test::signed_mode(j, L.ny);
      size_t at = size_t(i + L.nx * j);
      if (n <= 0 || std::abs(m) >= n || std::abs(a[at]) < 1e-3 * peak) continue;  // downwind cone
      double k = std::hypot(n * 2 * M_PI / L.lx, m * 2 * M_PI / L.ly);
      double w = std::sqrt(9.81 * k * std::tanh(k * 8) * (1 + std::pow(k * 2.7e-3, 2)));
      std::complex<double> ratio = b[at] / a[at] * std::polar(1.0, w * (t1 - t0));
      worst = squall::test::worse(worst, std::abs(std::arg(ratio)));
      ++checked;
    }
  EXPECT_GT(checked, 50);
  EXPECT_LT(worst, 2e-3);
}

TEST(OceanTile, DriftCurrentTranslatesTheField) {
  TileSpec still = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 64, 128);
  TileSpec moving = still;
  double t = 4.0, dx = 128.0 / 64;
  moving.layers[0].drift_x = 3 * dx / t;   // 3 cells in x
  moving.layers[0].drift_y = -5 * dx / t;  // -5 cells in y
  auto a = engine().tile(still, t, Height).height, b = engine().tile(moving, t, Height).height;
  double worst = 0;
  for (int j = 0; j < 64; ++j)
    for (int i = 0; i < 64; ++i)
      worst = squall::test::worse(worst, double(std::abs(b[i + 64 * j] - a[(i - 3 + 64) % 64 + 64 * ((j + 5) % 64)])));
  EXPECT_LT(worst, 1e-4 * test::rms(a));
}

// A wind direction 1e5 turns away is the same direction: reduced in double before the device's float32
// (whose spacing at 6e5 rad is 0.06 rad) sees it.
TEST(OceanTile, WindDirectionsWholeTurnsApartGiveOneSea) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 64, 128);
  spec.layers[0].wind_direction = 0.3;
  TileSpec turned = spec;
  turned.layers[0].wind_direction = 0.3 + 2 * M_PI * 1e5;
  auto a = engine().tile(spec, 2.0, Height).height, b = engine().tile(turned, 2.0, Height).height;
  double worst = 0;
  for (size_t k = 0; k < a.size(); ++k) worst = squall::test::worse(worst, double(std::abs(a[k] - b[k])));
  EXPECT_LT(worst, 1e-5 * test::rms(a));
}

// Sampling asks its Cancellation before each layer and each 4096 points: cancelled after its first two
// answers, a sample of 5000 points stops at point 4096.
TEST(OceanTile, ACancelledSampleStopsAmongItsPoints) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 32, 64);
  engine().sample(spec, 1.0, {{0, 0}}, false);  // the spectrum kept: building it would look once more
  int asked = 0;
  const Cancellation after_two([&] { return ++asked > 2; });
  const std::vector<Vec2> points(5000, Vec2{1.5, 2.5});
  squall::test::expect_error(Code::Cancelled, "sample: at points[4096] cancelled",
                             [&] { engine().sample(spec, 1.0, points, false, after_two); });
  EXPECT_EQ(engine().sample(spec, 1.0, points, false).size(), 5000u);
}

// A tile asks its Cancellation before each layer, the first included: one whose caller went away while it
// waited for a device queue builds no spectrum and runs no kernel.
TEST(OceanTile, ACancelledTileStopsBeforeItsFirstLayer) {
  const TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 32, 64, 4711);
  const Cancellation cancelled([] { return true; });
  const size_t built = engine().spectra_built();
  squall::test::expect_error(Code::Cancelled, "tile: before layer 0 cancelled",
                             [&] { engine().tile(spec, 1.0, Height, nullptr, cancelled); });
  EXPECT_EQ(engine().spectra_built(), built);
  engine().tile(spec, 1.0, Height);
  EXPECT_EQ(engine().spectra_built(), built + 1);
}

// A layer's spectrum is built in slices of rows (2^20 modes, 0.2 s on two CPU cores) with the Cancellation
// asked after each: a 4096^2 layer's 2.7 s could not be stopped before. A 2048 x 1024 layer is two slices.
// Cancelled from its second look on (the first is the tile's, before the layer), the call stops after the
// first slice and caches nothing; the next tile builds the spectrum whole, asking once a slice, and agrees
// with the FFTW double reference (each slice's rows and frequencies where they belong).
TEST(OceanTile, ACancelledSpectrumStopsAfterItsSlice) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 1024, 2000, 4712);
  spec.layers[0].nx = 2048, spec.layers[0].lx = 4000;
  int looks = 0;
  const Cancellation second_look([&] { return ++looks >= 2; });
  const size_t built = engine().spectra_built();
  squall::test::expect_error(Code::Cancelled, "the spectrum of layer 0 cancelled",
                             [&] { engine().tile(spec, 1.0, Height, nullptr, second_look); });
  EXPECT_EQ(looks, 2);
  EXPECT_EQ(engine().spectra_built(), built);
  looks = 0;
  const Cancellation counted([&] { return ++looks < 0; });
  const TileFields whole = engine().tile(spec, 1.0, Height, nullptr, counted);
  EXPECT_EQ(looks, 1 + 2 + 2) << "the tile's look, one a slice and one between each two of the frame's stages";
  EXPECT_EQ(engine().spectra_built(), built + 1);
  EXPECT_LT(test::relative_rms_error(whole.height, CpuReference().tile(spec, 1.0, Height).height), 1e-4);
}

// A frame over more than 2^20 cells waits for each of its stages and looks at the Cancellation before the
// next (a 4096^2 layer's evolve, transform and finalize take 0.19, 0.27 and 0.14 s on two CPU cores). With
// its spectrum kept, a 2048 x 1024 tile looks three times: before its layer, before the transform and before
// the finalize, and stops at the look it is cancelled at. A 1024^2 frame's stages are not waited for.
TEST(OceanTile, ALargeFrameStopsBetweenItsStages) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 1024, 2000, 4713);
  int looks = 0;
  const Cancellation counted([&] { return ++looks < 0; });
  engine().tile(spec, 0.0, Height);  // the spectrum, kept
  engine().tile(spec, 1.0, Height, nullptr, counted);
  EXPECT_EQ(looks, 1) << "a 1024^2 frame: the tile's look alone";
  spec.layers[0].nx = 2048, spec.layers[0].lx = 4000;
  engine().tile(spec, 0.0, Height);
  looks = 0;
  engine().tile(spec, 1.0, Height, nullptr, counted);
  EXPECT_EQ(looks, 3) << "a 2048 x 1024 frame: the tile's look and one before each stage after the first";
  for (const auto& [at, stopped] :
       {std::pair{2, "the transform of layer 0 cancelled"}, std::pair{3, "tile: the finalize cancelled"}}) {
    looks = 0;
    const Cancellation cancelled_at([&, at = at] { return ++looks >= at; });
    squall::test::expect_error(Code::Cancelled, stopped,
                               [&] { engine().tile(spec, 1.0, Height, nullptr, cancelled_at); });
    EXPECT_EQ(looks, at);
  }
}

// What a tile would build now, for the caller's memory budget: the spectrum (6 floats a mode) of each of its
// layers that is not kept, nothing once it is.
TEST(OceanTile, NewSpectraBytesAreThoseOfTheLayersNotKept) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 96, 300, 4714);
  spec.layers.push_back(spec.layers[0]);
  spec.layers[1].nx = 64, spec.layers[1].lx = 200;
  EXPECT_EQ(engine().new_spectra_bytes(spec), (96u * 96u + 64u * 96u) * 6 * sizeof(float));
  engine().tile(spec, 1.0, Height);
  EXPECT_EQ(engine().new_spectra_bytes(spec), 0u);
  spec.layers[1].seed = 4715;
  EXPECT_EQ(engine().new_spectra_bytes(spec), 64u * 96u * 6 * sizeof(float));
}

// A spectrum the caller reserved for (new_spectra_bytes) moves its bytes from the reservation to the cache
// when kept: under a budget with room for the tile and one spectrum, the spectrum is kept (it would need
// room for a second copy if the cache asked the budget for it again) and the reservation keeps the rest.
TEST(OceanTile, AKeptSpectrumTakesItsBytesFromTheCallersReservation) {
  const TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 256, 500, 4716);
  const uint64_t h0 = 256 * 256 * 6 * sizeof(float), working = tile_device_bytes(spec, Height);
  Limits limits;
  limits.memory_budget = working + h0 + h0 / 2;
  LimitGate gate(limits);
  OceanEngine budgeted(squall::test::runtime(), squall::test::fft(), limits, 1 << 30, &gate);
  ASSERT_EQ(budgeted.new_spectra_bytes(spec), h0);
  Slot memory = gate.acquire_memory("the tile", working + h0);
  budgeted.tile(spec, 1.0, Height, nullptr, {}, kAllPlanes, &memory);
  EXPECT_EQ(budgeted.cached_spectra(), 1u);
  EXPECT_EQ(memory.amount(), working);
  EXPECT_EQ(gate.cached_memory_bytes(), h0);
  EXPECT_EQ(budgeted.new_spectra_bytes(spec), 0u);
}

// A spectrum kept when the caller reserved for the spectra it builds (so it reserved nothing for it), and
// evicted since by another call, is reserved anew before it is built: while the other call holds the room,
// the tile is refused before the spectrum is built (it was built outside the budget); once that room is
// given back, the spectrum's bytes are reserved, then move to the cache.
TEST(OceanTile, ASpectrumEvictedSinceTheCallReservedIsReservedAnewBeforeItIsBuilt) {
  const TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 64, 200, 4717);
  const uint64_t h0 = 64 * 64 * 6 * sizeof(float);
  Limits limits;
  limits.memory_budget = h0 + h0 / 2;
  LimitGate gate(limits);
  OceanEngine budgeted(squall::test::runtime(), squall::test::fft(), limits, 1 << 30, &gate);
  budgeted.tile(spec, 0.0, Height);
  ASSERT_EQ(budgeted.new_spectra_bytes(spec), 0u);
  Slot reserved = gate.acquire_memory("the tile", budgeted.new_spectra_bytes(spec));
  auto tile = [&] { budgeted.tile(spec, 1.0, Height, nullptr, {}, kAllPlanes, &reserved); };
  {
    Slot other = gate.acquire_memory("another call", h0);  // evicts the spectrum to make room
    ASSERT_EQ(budgeted.cached_spectra(), 0u);
    squall::test::expect_error(Code::ResourceExhausted, "the spectrum of layer 0 (98304 bytes) would pass", tile);
    EXPECT_EQ(budgeted.spectra_built(), 1u);
  }
  tile();
  EXPECT_EQ(budgeted.spectra_built(), 2u);
  EXPECT_EQ(gate.cached_memory_bytes(), h0);
  EXPECT_EQ(gate.memory_bytes(), h0);
  EXPECT_EQ(reserved.amount(), 0u);
}

// A layer grid the FFT backend cannot transform (clfft: 34 = 2 x 17) is refused by name before its spectrum
// is built; one it can (36) runs.
TEST(OceanTile, AGridTheFftBackendCannotTransformIsRefusedBeforeItsSpectrum) {
  OceanEngine clfft(squall::test::runtime(), squall::test::fft("clfft"));
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 34, 100);
  squall::test::expect_error(Code::InvalidArgument, "layers[0].nx = 34: the clfft FFT backend",
                             [&] { clfft.tile(spec, 1.0, Height); });
  squall::test::expect_error(Code::InvalidArgument, "tile.layers[0].nx = 34",
                             [&] { clfft.check_transforms(spec, "tile"); });
  EXPECT_EQ(clfft.spectra_built(), 0u);
  spec.layers[0].nx = spec.layers[0].ny = 36;
  EXPECT_EQ(clfft.tile(spec, 1.0, Height).height.size(), 36u * 36u);
}

TEST(OceanTile, PeriodicAcrossEdgesAndInSampling) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Hyperbolic, 64, 100);
  auto h = engine().tile(spec, 1.0, Height).height;
  // the step from the last column to the first is an ordinary neighbour difference: its mean over the
  // rows lies among the other 63 columns' (a jump at the edge would be larger, a first column repeated
  // at the end would make it 0)
  auto mean_step = [&](int i) {  // from column i to column i + 1, periodically
    double sum = 0;
    for (int j = 0; j < 64; ++j) sum += std::abs(h[(i + 1) % 64 + 64 * j] - h[i + 64 * j]) / 64.0;
    return sum;
  };
  double least = INFINITY, most = 0;
  for (int i = 0; i + 1 < 64; ++i) least = std::min(least, mean_step(i)), most = std::max(most, mean_step(i));
  std::printf("mean |step| at the edge %.4g, inside %.4g to %.4g\n", mean_step(63), least, most);
  EXPECT_GT(mean_step(63), least);
  EXPECT_LT(mean_step(63), most);
  auto s = engine().sample(spec, 1.0, {{13.3, 71.9}, {13.3 + 100, 71.9 - 300}}, false);
  EXPECT_NEAR(s[0].height, s[1].height, 1e-6 * test::rms(h));
  // A point however far away is the point its whole periods away in the patch: finite, and bit for bit.
  const double lx = spec.layers[0].lx, ly = spec.layers[0].ly;
  auto far = engine().sample(spec, 1.0, {{1e300, -3e299}}, false)[0];
  auto near = engine().sample(spec, 1.0, {{std::fmod(1e300, lx), std::fmod(-3e299, ly) + ly}}, false)[0];
  EXPECT_TRUE(std::isfinite(far.height) && std::isfinite(far.normal_z)) << far.height;
  EXPECT_EQ(far.height, near.height);
  EXPECT_EQ(far.normal_z, near.normal_z);
}

TEST(OceanTile, BitIdenticalRepeatAndLargeWavesKeptAcrossResolutions) {
  TileSpec spec = test::single(SpectrumModel::Tma, SpreadingModel::Jonswap, 64, 200);
  spec.layers[0].dispersion = DispersionKind::Shallow;
  spec.layers[0].depth = 15;
  auto a = engine().tile(spec, 7.0, kAllOutputs), b = engine().tile(spec, 7.0, kAllOutputs);
  ASSERT_EQ(a.height.size(), b.height.size());
  EXPECT_EQ(0, std::memcmp(a.height.data(), b.height.data(), a.height.size() * 4));
  EXPECT_EQ(0, std::memcmp(a.normal_z.data(), b.normal_z.data(), a.normal_z.size() * 4));
  EXPECT_EQ(0, std::memcmp(a.jacobian_minus.data(), b.jacobian_minus.data(), a.jacobian_minus.size() * 4));
  // Doubling the resolution over the same patch keeps every mode the coarse grid has.
  TileSpec fine = spec;
  fine.layers[0].nx = fine.layers[0].ny = 128;
  auto coarse_k = test::spectrum_of(a.height, 64, 64);
  auto fine_k = test::spectrum_of(engine().tile(fine, 7.0, Height).height, 128, 128);
  double peak = 0, worst = 0;
  for (auto& c : coarse_k) peak = std::max(peak, std::abs(c));
  for (int m = -31; m <= 31; ++m)
    for (int n = -31; n <= 31; ++n)
      worst = squall::test::worse(worst, std::abs(coarse_k[(n + 64) % 64 + 64 * ((m + 64) % 64)] -
                                                  fine_k[(n + 128) % 128 + 128 * ((m + 128) % 128)]));
  EXPECT_LT(worst, 1e-5 * peak);
}

TEST(OceanTile, ChoppyJacobianInvariantsAndCrests) {
  TileSpec spec = test::single(SpectrumModel::PiersonMoskowitz, SpreadingModel::PiersonCos2, 128, 200);
  spec.choppiness = 1.5;
  auto f = engine().tile(spec, 3.0, Height | Jacobian | Normals | Slopes | Displacement);
  double mean = 0, worst_product = 0, worst_order = 0, hj = 0, hh = 0, jj = 0;
  size_t n = f.jacobian.size();
  for (size_t i = 0; i < n; ++i) mean += f.jacobian[i] / double(n);
  for (size_t i = 0; i < n; ++i) {
    worst_product =
        squall::test::worse(worst_product, double(std::abs(f.jacobian_minus[i] * f.jacobian_plus[i] - f.jacobian[i])));
    worst_order = squall::test::worse(worst_order, double(f.jacobian_minus[i] - f.jacobian_plus[i]));
    hj += f.height[i] * (f.jacobian[i] - mean), hh += f.height[i] * f.height[i],
        jj += std::pow(f.jacobian[i] - mean, 2);
  }
  EXPECT_NEAR(mean, 1.0, 1e-5);
  EXPECT_LT(worst_product, 1e-5);
  EXPECT_LE(worst_order, 0.0);
  // lambda > 0 sharpens crests: J is smallest where h is largest (strong negative correlation)
  EXPECT_LT(hj / std::sqrt(hh * jj), -0.5);
  // the normals are unit vectors (their direction: ChoppyNormalsAndJacobianAreThoseOfTheDisplacedSurface)
  double worst_unit = 0, worst_lambda0 = 0;
  for (size_t i = 0; i < n; ++i) {
    double nx = f.normal_x[i], ny = f.normal_y[i], nz = f.normal_z[i];
    worst_unit = squall::test::worse(worst_unit, std::abs(std::sqrt(nx * nx + ny * ny + nz * nz) - 1));
  }
  EXPECT_LT(worst_unit, 1e-6);
  // with lambda = 0, eq 94 reduces to eq 90: n = (-eps_x, -eps_y, 1) / sqrt(1 + |eps|^2), and J = J- = J+ = 1
  spec.choppiness = 0;
  auto g = engine().tile(spec, 3.0, Slopes | Normals | Jacobian);
  for (size_t i = 0; i < n; ++i) {
    double norm = std::sqrt(1 + g.slope_x[i] * g.slope_x[i] + g.slope_y[i] * g.slope_y[i]);
    worst_lambda0 = squall::test::worse(worst_lambda0, std::abs(g.normal_x[i] + g.slope_x[i] / norm));
    worst_lambda0 = squall::test::worse(worst_lambda0, std::abs(g.normal_z[i] - 1 / norm));
    worst_lambda0 = squall::test::worse(worst_lambda0,
                                        double(std::abs(g.jacobian_minus[i] - 1)) + std::abs(g.jacobian_plus[i] - 1));
  }
  EXPECT_LT(worst_lambda0, 1e-6);
}

// d/di of a periodic grid field at (i, j) (4th-order central difference, unit spacing); `period` is what the
// field gains over one period along i (the grid extent for a position, 0 for a displacement).
double ddi(const std::vector<double>& f, int n, int i, int j, double period) {
  auto at = [&](int di) {
    const int k = i + di;
    return f[size_t((k + n) % n + n * j)] + period * ((k >= n) - (k < 0));
  };
  return (8 * (at(1) - at(-1)) - (at(2) - at(-2))) / 12;
}

// The normal and J of eq 94 from the displaced surface itself: P(x) = (x + lambda D_x, y + lambda D_y, h),
// differentiated on the grid. The band ends at an eighth of the grid's Nyquist wavenumber, where the
// 4th-order difference is exact to 1e-3 relative.
TEST(OceanTile, ChoppyNormalsAndJacobianAreThoseOfTheDisplacedSurface) {
  const int n = 128;
  const double L = 200, dx = L / n;
  TileSpec spec = test::single(SpectrumModel::PiersonMoskowitz, SpreadingModel::PiersonCos2, n, L);
  spec.layers[0].k_max = M_PI / dx / 8;
  spec.choppiness = 1.5;
  const TileFields f = engine().tile(spec, 3.0, Height | Jacobian | Normals | Displacement | Slopes);
  std::vector<double> P[3], Q[3];  // P: the surface point of each grid point; Q: the same, transposed (j, i)
  for (int c = 0; c < 3; ++c) P[c].resize(size_t(n * n)), Q[c].resize(size_t(n * n));
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const size_t at = size_t(i + n * j), swapped = size_t(j + n * i);
      const double p[3] = {i * dx + f.displacement_x[at], j * dx + f.displacement_y[at], f.height[at]};
      for (int c = 0; c < 3; ++c) P[c][at] = p[c], Q[c][swapped] = p[c];
    }
  double worst_dot = 0, worst_eq90 = 0, worst_j = 0, fold_free = 1;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const size_t at = size_t(i + n * j);
      double tx[3], ty[3];
      for (int c = 0; c < 3; ++c) {
        tx[c] = ddi(P[c], n, i, j, c == 0 ? L : 0) / dx;
        ty[c] = ddi(Q[c], n, j, i, c == 1 ? L : 0) / dx;
      }
      const double normal[3] = {f.normal_x[at], f.normal_y[at], f.normal_z[at]};
      const double flat = std::hypot(1.0, f.slope_x[at], f.slope_y[at]);  // eq 90's normal, lambda left out
      const double eq90[3] = {-f.slope_x[at] / flat, -f.slope_y[at] / flat, 1 / flat};
      auto cosine = [&](const double* n, const double* t) {
        return std::abs(n[0] * t[0] + n[1] * t[1] + n[2] * t[2]) / std::hypot(t[0], t[1], t[2]);
      };
      worst_dot = squall::test::worse(worst_dot, cosine(normal, tx), cosine(normal, ty));
      worst_eq90 = squall::test::worse(worst_eq90, cosine(eq90, tx), cosine(eq90, ty));
      worst_j = squall::test::worse(worst_j, std::abs(f.jacobian[at] - (tx[0] * ty[1] - tx[1] * ty[0])));
      fold_free = std::min(fold_free, double(f.jacobian[at]));
    }
  std::printf("displaced surface: worst |n.t| %.2e (eq 90's normal: %.2e), worst |J - det| %.2e, smallest J %.3f\n",
              worst_dot, worst_eq90, worst_j, fold_free);
  EXPECT_GT(fold_free, 0.0);
  EXPECT_LT(worst_dot, 5e-4);  // 4.6e-5 measured
  EXPECT_GT(worst_eq90, 1e-2) << "the test tells a normal that leaves out lambda";
  EXPECT_LT(worst_j, 5e-4);  // 6.2e-5 measured
}

TEST(OceanTile, WhitecapsFollowThresholdAndDecay) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 64, 150);
  spec.layers[0].wind_speed = 20;
  spec.choppiness = 2.0;
  spec.whitecap_threshold = 0.5;
  spec.whitecap_decay = 3.0;
  WhitecapState state;
  std::vector<float> previous;
  int ones = 0, decayed = 0;
  for (int frame = 0; frame < 4; ++frame) {
    double t = 1.0 + 0.5 * frame;
    auto f = engine().tile(spec, t, Jacobian | Whitecaps, &state);
    for (size_t i = 0; i < f.whitecaps.size(); ++i) {
      bool breaking = f.jacobian_minus[i] < spec.whitecap_threshold;
      float expected = breaking ? 1.0f : (frame == 0 ? 0.0f : previous[i] * float(std::exp(-0.5 / 3.0)));
      ASSERT_NEAR(f.whitecaps[i], expected, 1e-6) << "frame " << frame << " cell " << i;
      if (frame > 0) ones += breaking, decayed += !breaking && previous[i] > 0;
    }
    previous = f.whitecaps.to_vector();
    EXPECT_EQ(state.map(), previous);
  }
  EXPECT_GT(ones, 0);
  EXPECT_GT(decayed, 0);
}

TEST(OceanTile, SampleMatchesTileAndInvertsDisplacement) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 64, 128);
  spec.choppiness = 0.8;
  auto f = engine().tile(spec, 2.0, Height | Displacement | Normals);
  std::vector<Vec2> points = {{0, 0}, {2.0 * 5, 2.0 * 7}, {2.0 * 63, 2.0 * 31}};
  std::vector<size_t> at = {0, 5 + 64 * 7, 63 + 64 * 31};
  auto s = engine().sample(spec, 2.0, points, false);
  for (size_t p = 0; p < points.size(); ++p) {
    EXPECT_NEAR(s[p].height, f.height[at[p]], 1e-6);
    EXPECT_NEAR(s[p].displacement_x, f.displacement_x[at[p]], 1e-6);
    EXPECT_NEAR(s[p].normal_z, f.normal_z[at[p]], 1e-6);
  }
  // inverted: the source point x0 of query x satisfies x0 + lambda D(x0) = x
  Vec2 query{37.7, 81.2};
  auto inv = engine().sample(spec, 2.0, {query}, true)[0];
  Vec2 source{query.x - inv.displacement_x, query.y - inv.displacement_y};
  auto direct = engine().sample(spec, 2.0, {source}, false)[0];
  EXPECT_NEAR(source.x + direct.displacement_x, query.x, 1e-6);
  EXPECT_NEAR(source.y + direct.displacement_y, query.y, 1e-6);
  EXPECT_NEAR(direct.height, inv.height, 1e-6);
}

// -(the most negative eigenvalue of grad D) of spec's sea at choppiness 1 and t = 2 s: past
// 1 / steepest_fold the surface folds.
double steepest_fold(TileSpec spec) {
  spec.choppiness = 1;
  const auto unit = engine().tile(spec, 2.0, Jacobian);
  return 1 - *std::min_element(unit.jacobian_minus.begin(), unit.jacobian_minus.end());
}

// Where the points of tile f's 64 x 64 grid, `cell` apart, land: each one's displaced position.
std::vector<Vec2> landing_places(const TileFields& f, double cell) {
  std::vector<Vec2> landed;
  for (int j = 0; j < 64; ++j)
    for (int i = 0; i < 64; ++i) {
      const size_t k = size_t(i + 64 * j);
      landed.push_back({i * cell + f.displacement_x[k], j * cell + f.displacement_y[k]});
    }
  return landed;
}

// With the displacement as strong as a sea that does not fold at its grid points takes (its tile's smallest J-
// 0.05), an inverted sample of each grid point's landing place finds a source that lands there, to 1e-5 of
// a cell, and that source is the grid point itself but where the bilinear surface between the grid points
// folds (one point of 4096 here, landing where another does). The fixed-point iteration x0 = x - lambda D(x0)
// converges as |1 - J|^n there: after its 16 steps, 0.95^16 = 0.44 of the way.
TEST(OceanTile, InvertedSamplesFindTheSourcesOfASteepSea) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 64, 128);
  const double steepest = steepest_fold(spec);
  ASSERT_GT(steepest, 0.1);
  spec.choppiness = 0.95 / steepest;
  const auto f = engine().tile(spec, 2.0, Displacement | Jacobian);
  EXPECT_NEAR(*std::min_element(f.jacobian_minus.begin(), f.jacobian_minus.end()), 0.05, 1e-3);
  const double cell = 2.0, period = 128;
  const std::vector<Vec2> landed = landing_places(f, cell);
  const auto inverted = engine().sample(spec, 2.0, landed, true);
  std::vector<Vec2> sources;
  for (const SurfaceSample& s : inverted) sources.push_back(s.source);
  const auto at_source = engine().sample(spec, 2.0, sources, false);
  auto apart = [&](double a, double b) { return std::remainder(a - b, period); };  // periodic images alike
  double residual = 0;
  int elsewhere = 0;
  for (int j = 0; j < 64; ++j)
    for (int i = 0; i < 64; ++i) {
      const size_t k = size_t(i + 64 * j);
      const Vec2 x = sources[k];
      residual = squall::test::worse(residual, std::hypot(x.x + at_source[k].displacement_x - landed[k].x,
                                                          x.y + at_source[k].displacement_y - landed[k].y) /
                                                   cell);
      elsewhere += std::hypot(apart(x.x, i * cell), apart(x.y, j * cell)) > 1e-3 * cell;
    }
  EXPECT_LT(residual, 1e-5);
  EXPECT_LE(elsewhere, 4);
}

// Past the fold (the surface overturns where J < 0) a landing point may have several sources, and the search
// from x itself can stall at a local minimum of |x0 + lambda D(x0) - x| beside a fold, short of every one.
// Each grid point's landing place has a source by construction: one is found for each (any of them).
TEST(OceanTile, InvertedSamplesFindASourceOfEveryPointOfAFoldedSea) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 64, 128);
  const double steepest = steepest_fold(spec), cell = 2.0;
  for (double past_the_fold : {1.1, 1.3, 1.6}) {
    spec.choppiness = past_the_fold / steepest;
    const std::vector<Vec2> landed = landing_places(engine().tile(spec, 2.0, Displacement), cell);
    const auto inverted = engine().sample(spec, 2.0, landed, true);
    std::vector<Vec2> sources;
    for (const SurfaceSample& s : inverted) sources.push_back(s.source);
    const auto at_source = engine().sample(spec, 2.0, sources, false);
    int stalled = 0;
    for (size_t k = 0; k < landed.size(); ++k) {
      const double off = std::hypot(sources[k].x + at_source[k].displacement_x - landed[k].x,
                                    sources[k].y + at_source[k].displacement_y - landed[k].y);
      stalled += !(off < 1e-5 * cell);
    }
    EXPECT_EQ(stalled, 0) << past_the_fold << " times the choppiness of the first fold";
  }
}

// Far from the origin the residual's rounding in double passes 1e-6 of a cell (4e-4 m at 1e12 m): the
// search stops at that rounding instead of starting again 97 times at every point. The same landing places
// shifted by 1e12 m (a whole number of periods) find the same sources, in about the same time.
TEST(OceanTile, InvertedSamplesFarFromTheOriginStopAtTheRoundingOfDouble) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 64, 128);
  spec.choppiness = 0.9 / steepest_fold(spec);
  std::vector<Vec2> near, far;
  for (int k = 0; k < 4096; ++k) {
    near.push_back({0.031 * k, 0.017 * k});
    far.push_back({near.back().x + 1e12, near.back().y + 1e12});  // 1e12 = 7812500000 periods of 128 m
  }
  auto timed = [&](const std::vector<Vec2>& points, double* seconds) {
    const auto start = std::chrono::steady_clock::now();
    auto samples = engine().sample(spec, 2.0, points, true);
    *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return samples;
  };
  double near_seconds = 0, far_seconds = 0;
  engine().sample(spec, 2.0, {near[0]}, true);  // the spectrum built and kept, outside the timings
  const auto a = timed(near, &near_seconds), b = timed(far, &far_seconds);
  double apart = 0;
  for (size_t k = 0; k < a.size(); ++k)
    apart = squall::test::worse(apart,
                                std::hypot(b[k].source.x - 1e12 - a[k].source.x, b[k].source.y - 1e12 - a[k].source.y));
  EXPECT_LT(apart, 1e-2);
  EXPECT_LT(far_seconds, 5 * near_seconds + 0.05) << "a search restarted at points that had converged";
}

TEST(OceanTile, SpectrumCachedAcrossFrames) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Krylov, 64, 90, 4242);
  engine().tile(spec, 0.0, Height);
  size_t built = engine().spectra_built();
  for (int frame = 1; frame < 5; ++frame) engine().tile(spec, frame * 0.1, Height | Normals);
  EXPECT_EQ(engine().spectra_built(), built);
  spec.layers[0].seed = 4243;
  engine().tile(spec, 0.0, Height);
  EXPECT_EQ(engine().spectra_built(), built + 1);
}

// A layer's spectrum larger than the cache serves its tile and is not kept; the spectra kept hold their bytes
// in the memory budget, where it has no room for a new one the least recently used give theirs, and a call
// that needs their room takes it back.
TEST(OceanTile, KeptSpectraStayWithinTheCacheAndHoldTheirBytesInTheMemoryBudget) {
  const TileSpec a = test::single(SpectrumModel::Jonswap, SpreadingModel::Krylov, 32, 90, 1),
                 b = test::single(SpectrumModel::Jonswap, SpreadingModel::Krylov, 32, 90, 2),
                 large = test::single(SpectrumModel::Jonswap, SpreadingModel::Krylov, 64, 90, 3);
  const uint64_t spectrum = 32 * 32 * 6 * sizeof(float);  // six planes of a 32^2 layer; a 64^2 one's is 4x
  Limits limits;
  limits.memory_budget = spectrum + spectrum / 2;
  LimitGate gate(limits);
  {
    OceanEngine cached(squall::test::runtime(), squall::test::fft(), {}, 3 * spectrum, &gate);
    cached.tile(a, 0.0, Height);
    EXPECT_EQ(cached.cached_spectrum_bytes(), spectrum);
    EXPECT_EQ(gate.memory_bytes(), spectrum);
    cached.tile(b, 0.0, Height);  // a gives its budget to b
    EXPECT_EQ(cached.cached_spectra(), 1u);
    EXPECT_EQ(gate.memory_bytes(), spectrum);
    EXPECT_EQ(cached.tile(large, 0.5, Height).height, engine().tile(large, 0.5, Height).height);
    cached.tile(large, 0.5, Height);
    EXPECT_EQ(cached.spectra_built(), 4u) << "a spectrum larger than the cache was kept";
    EXPECT_EQ(cached.cached_spectrum_bytes(), spectrum);
    cached.tile(b, 1.0, Height);
    EXPECT_EQ(cached.spectra_built(), 4u) << "b was evicted by a spectrum that was not kept";
    EXPECT_EQ(gate.cached_memory_bytes(), spectrum);
    {
      Slot call = gate.acquire_memory("a call", spectrum);  // takes the kept spectrum's budget back
      EXPECT_EQ(cached.cached_spectra(), 0u);
    }
    cached.tile(b, 1.5, Height);
    EXPECT_EQ(cached.spectra_built(), 5u);
  }
  EXPECT_EQ(gate.memory_bytes(), 0u);
}

// Tiles missing one spectrum at once compute it once: the others wait for it. The tiles are equal bit for
// bit, whichever ran alone (the fftw backend's plans do not depend on the load).
TEST(OceanTile, TilesMissingOneSpectrumAtOnceComputeItOnce) {
  OceanEngine fresh(squall::test::runtime(), squall::test::fft());
  const TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Krylov, 128, 200, 77);
  std::vector<std::vector<float>> heights(4);
  std::latch start(int(heights.size()));
  std::vector<std::thread> tiles;
  for (auto& height : heights)
    tiles.emplace_back([&] {
      start.arrive_and_wait();
      height = fresh.tile(spec, 2.0, Height).height.to_vector();
    });
  for (auto& t : tiles) t.join();
  EXPECT_EQ(fresh.spectra_built(), 1u);
  for (const auto& height : heights) EXPECT_EQ(height, heights.front());
}

// Tiles of ever new grid sizes do not keep an FFT plan per size for good: each queue keeps its most
// recently used plans up to the limit.
TEST(OceanTile, TilesOfEverNewGridSizesKeepABoundedNumberOfPlans) {
  Runtime& runtime = squall::test::runtime();
  fft::FftwOptions estimate;  // on a CPU device, FFTW's plans made in no time (not measured)
  estimate.measure = false;
  const auto names = fft::available_backends(runtime);
  const bool fftw = std::find(names.begin(), names.end(), "fftw") != names.end();
  fft::Fft fft(fft::make_backend(runtime, fftw ? "fftw" : squall::test::engine_fft_backend(), estimate));
  OceanEngine sizes(runtime, fft);
  const size_t count = fft::Fft::kMaxPlansPerQueue + 8;
  for (size_t i = 0; i < count; ++i) {
    TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Krylov, 8, 90, 5);
    spec.layers[0].ny = int64_t(2 * (i + 1));
    spec.layers[0].ly = 90.0 * double(spec.layers[0].ny) / 8;
    EXPECT_GT(test::rms(sizes.tile(spec, 1.0, Height).height), 0.0);
  }
  EXPECT_EQ(sizes.spectra_built(), count);
  EXPECT_EQ(fft.cached_plans(), fft::Fft::kMaxPlansPerQueue) << "one tile at a time: each on the first queue";
}

// Relative rms of every output against the FFTW double reference.
void expect_matches_reference(const TileSpec& spec, double t, double tolerance = 1e-4) {
  CpuReference reference;
  auto e = engine().tile(spec, t, kAllOutputs), r = reference.tile(spec, t, kAllOutputs);
  std::map<std::string, std::pair<const FloatView*, const FloatView*>> fields = {
      {"height", {&e.height, &r.height}},
      {"displacement_x", {&e.displacement_x, &r.displacement_x}},
      {"displacement_y", {&e.displacement_y, &r.displacement_y}},
      {"slope_x", {&e.slope_x, &r.slope_x}},
      {"slope_y", {&e.slope_y, &r.slope_y}},
      {"normal_x", {&e.normal_x, &r.normal_x}},
      {"normal_y", {&e.normal_y, &r.normal_y}},
      {"normal_z", {&e.normal_z, &r.normal_z}},
      {"jacobian", {&e.jacobian, &r.jacobian}},
      {"jacobian_minus", {&e.jacobian_minus, &r.jacobian_minus}},
      {"jacobian_plus", {&e.jacobian_plus, &r.jacobian_plus}}};
  for (auto& [name, pair] : fields) {
    ASSERT_EQ(pair.first->size(), pair.second->size()) << name;
    EXPECT_LT(test::relative_rms_error(*pair.first, *pair.second), tolerance) << name;
  }
  size_t differ = 0;
  for (size_t i = 0; i < e.whitecaps.size(); ++i) differ += e.whitecaps[i] != r.whitecaps[i];
  EXPECT_LE(differ, e.whitecaps.size() / 1000) << "whitecap cells that differ";
  EXPECT_NEAR(e.unresolved_slope_variance / r.unresolved_slope_variance, 1.0, 2e-3);
}

TEST(OceanReference, SingleLayerAgreesWithFftwDouble) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 128, 250);
  spec.layers[0].dispersion = DispersionKind::Combined;
  spec.layers[0].depth = 40;
  spec.layers[0].drift_x = 0.7;
  spec.layers[0].wind_direction = 2.3;
  spec.choppiness = 1.1;
  expect_matches_reference(spec, 12.3);
}

// Far from t = 0 each mode keeps its phase: the device counts f(k) t in turns, f from the double-precision
// dispersion, and the drift's shift reduced to the layer's periods on the host. With w(k) and k.U_D in one
// float, the phase was off by about w t 2^-24 past 2^12 turns: at t = 1e6 s the heights were 7% off (rms).
TEST(OceanReference, ASeaFarFromTimeZeroAgreesWithFftwDouble) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 128, 250);
  spec.layers[0].dispersion = DispersionKind::Combined;
  spec.layers[0].depth = 40;
  spec.layers[0].drift_x = 0.7;
  spec.layers[0].drift_y = -0.3;
  spec.choppiness = 1.1;
  for (double t : {1e6 + 0.3, -3.3e7, 9.9e8}) {
    SCOPED_TRACE("t = " + std::to_string(t));
    expect_matches_reference(spec, t);
  }
}

TEST(OceanReference, PhillipsAndPierson) {
  TileSpec spec = test::single(SpectrumModel::Phillips, SpreadingModel::Isotropic, 64, 500);
  spec.layers[0].wind_speed = 20;
  spec.layers[0].phillips_cutoff = 1.0;
  expect_matches_reference(spec, 4.0);
  spec = test::single(SpectrumModel::PiersonMoskowitz, SpreadingModel::PiersonCos2, 64, 300);
  spec.layers[0].dispersion = DispersionKind::Capillary;
  expect_matches_reference(spec, 0.5);
}

// The kernel's spectra (float, sq_powr's exp(y ln x) for pow) against the host's (double, pow): every
// frequency spectrum with every directional spread, the wind along +x so that modes lie on the downwind,
// upwind and crosswind axes. 2e-4: a narrow spread's crosswind fields are small, and the float round-off
// of the others is measured against them (Krylov's displacement_y: 1.2e-4).
TEST(OceanReference, EverySpectrumWithEverySpreadAgrees) {
  for (int s = 1; s < kSpectrumModelCount; ++s) {
    for (int d = 0; d < kSpreadingModelCount; ++d) {
      SCOPED_TRACE("spectrum " + std::to_string(s) + ", spreading " + std::to_string(d));
      TileSpec spec = test::single(SpectrumModel(s), SpreadingModel(d), 64, 300, 11 + 7 * s + d);
      spec.layers[0].wind_speed = 14;
      spec.layers[0].depth = 12;  // TMA's depth factor below 1 at the peak
      if (SpectrumModel(s) == SpectrumModel::Multipeak) spec.layers[0].partials = {{0.5, 2.0}, {1.1, 0.8}};
      expect_matches_reference(spec, 7.5, 2e-4);
    }
  }
}

// A von Mises spread as narrow as a light wind makes it (Mitsuyasu's s about 3.5e7 at a swell's peak of
// 0.5 rad/s under 0.05 m/s of wind): its concentration c = ln 2 / (1 - cos(width)) cancelled in float to
// infinity past s = 1.16e7, the spread to NaN and the peak's modes to nothing; in the forms without the
// differences the device agrees with the double reference. The spread (3e-4 rad) is narrower than any grid
// resolves, so its energy lies on the modes along the wind and the cross-wind fields are rounding noise:
// the height and the along-wind displacement and slope are compared.
TEST(OceanReference, AVonMisesSpreadAsNarrowAsALightWindMakesAgrees) {
  TileSpec spec = test::single(SpectrumModel::Multipeak, SpreadingModel::VonMises, 256, 2000);
  spec.layers[0].partials = {PartialSpectrum{0.5, 1.5}};
  for (double wind : {0.05, 1e-20}) {  // the second overflows s in float: held at 1e12
    SCOPED_TRACE("wind_speed " + std::to_string(wind));
    spec.layers[0].wind_speed = wind;
    CpuReference reference;
    auto e = engine().tile(spec, 6.0, kAllOutputs), r = reference.tile(spec, 6.0, kAllOutputs);
    EXPECT_GT(test::rms(r.height), 0.2);
    EXPECT_LT(test::relative_rms_error(e.height, r.height), 1e-4);
    EXPECT_LT(test::relative_rms_error(e.displacement_x, r.displacement_x), 1e-4);
    EXPECT_LT(test::relative_rms_error(e.slope_x, r.slope_x), 1e-4);
  }
}

// A spread narrower than a mode's angular cell (Mitsuyasu's s about 2e4 under 1 m/s of wind and 3.5e7 under
// 0.05 at a swell's peak of 0.5 rad/s; sigma 0.01 and 2.4e-4 rad against cells of 0.12 rad there) keeps
// the sea's energy at any wind direction: each mode takes D averaged over its cell's angular profile.
// Taken at the cells' centres, it put sqrt(s / pi) / 2 times the energy on the modes along an axis (an rms
// height of 4.3 m for Hs = 1.5 m) and none at 0.3 rad; averaged over a box of sqrt(dkx dky) / k, 0.70 of
// it along a diagonal and 1.35 at atan 2. The grid's energy, sum (P(k) + P(-k)) dkx dky, against the same
// sea's isotropic one (D integrates to 1 either way), then the device's tiles' variance over seeds.
TEST(OceanReference, ASpreadNarrowerThanTheGridKeepsTheSeasEnergyAtAnyDirection) {
  TileSpec spec = test::single(SpectrumModel::Multipeak, SpreadingModel::Isotropic, 256, 2000);
  LayerSpec& L = spec.layers[0];
  L.partials = {PartialSpectrum{0.5, 1.5}};
  const double isotropic = sum_of(expected_power(L));
  EXPECT_NEAR(4 * std::sqrt(isotropic), 1.5, 0.1);  // Hs, less what lies past the grid's wave numbers
  for (SpreadingModel spreading : {SpreadingModel::VonMises, SpreadingModel::Mitsuyasu})
    for (double wind : {1.0, 0.05})
      for (double direction : {0.0, 0.3, 1.0, M_PI / 4, std::atan(2.0 / 3), std::atan(2.0)}) {
        L.spreading = spreading, L.wind_speed = wind, L.wind_direction = direction;
        const double ratio = sum_of(expected_power(L)) / isotropic;
        std::printf("spreading %d, wind %.2f m/s, direction %.1f: energy / isotropic %.4f\n", int(spreading), wind,
                    direction, ratio);
        EXPECT_NEAR(ratio, 1, 0.02);
      }
  // The device's cell averages against the reference's, off the axes. 3e-4: the device takes the second
  // difference of erf integrals in float (1.2e-4 to 1.7e-4 rms on the slopes and normals measured, where
  // the modes of the cells' edges weigh most; point samples at the cells' centres were 30% off in energy).
  L.spreading = SpreadingModel::VonMises, L.wind_speed = 0.05;
  for (double direction : {0.3, M_PI / 4, std::atan(2.0)}) {
    SCOPED_TRACE("direction " + std::to_string(direction));
    L.wind_direction = direction;
    expect_matches_reference(spec, 3.0, 3e-4);
  }
}

// Krylov's spread follows the mean frequency of the whole spectrum: a partial at 40 rad/s, past every mode
// of this grid and past 60 times the dominant peak, still raises it, narrowing the swell's spread.
TEST(OceanReference, AKrylovSeaCountsAPartialPastTheGridInItsMeanFrequency) {
  TileSpec spec = test::single(SpectrumModel::Multipeak, SpreadingModel::Krylov, 64, 300);
  spec.layers[0].partials = {PartialSpectrum{0.5, 1.5}, PartialSpectrum{40, 0.3}};
  expect_matches_reference(spec, 2.0);
}

TEST(OceanReference, LayersWithBCorrectionOnAnotherGridAgree) {
  TileSpec spec = test::single(SpectrumModel::Multipeak, SpreadingModel::VonMises, 64, 200);
  spec.layers[0].partials = {PartialSpectrum{0.5, 1.5}, PartialSpectrum{1.1, 0.8}};
  LayerSpec second = spec.layers[0];
  second.spectrum = SpectrumModel::Tma;
  second.spreading = SpreadingModel::Hyperbolic;
  second.dispersion = DispersionKind::Shallow;
  second.depth = 12;
  second.lx = second.ly = 47;
  second.nx = second.ny = 32;
  second.seed = 9;
  spec.layers.push_back(second);
  spec.b_correction = true;
  spec.nx = spec.ny = 96;
  spec.lx = spec.ly = 200;
  expect_matches_reference(spec, 6.0);
}

// Output points many layer periods apart: point i sits at i * s layer cells, s the ratio of the spacings,
// taken into the layer's period. In float, i * s of millions of cells kept little of a cell's fraction (a 20 m
// layer of 64 cells, output points 111 km apart: heights 1.8% off, rms), and at 2^24 periods the wrap fell
// hundreds of cells outside the layer (a 2 cm layer: 84% off, from reads outside its buffer). The host now
// takes s into the period first, in double, so that i * s stays within a few periods.
TEST(OceanReference, OutputPointsManyLayerPeriodsApartSampleTheLayerWhereTheReferenceDoes) {
  for (double extent : {20.0, 0.02}) {
    SCOPED_TRACE("layer extent " + std::to_string(extent) + " m");
    TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 64, extent);
    spec.nx = 9, spec.ny = 5;
    spec.lx = 1e6, spec.ly = 7e5;
    CpuReference reference;
    auto e = engine().tile(spec, 2.5, Height | Displacement | Slopes), r = reference.tile(spec, 2.5, Height);
    ASSERT_GT(test::rms(r.height), 0.0);
    EXPECT_LT(test::relative_rms_error(e.height, r.height), 1e-3);
    for (const FloatView* field : {&e.displacement_x, &e.slope_y})
      for (float value : *field) ASSERT_TRUE(std::isfinite(value));
  }
}

// A layer wider than a row group of work-items and not a multiple of one (300 x 40 cells): its kernels run
// in two launches, the second at an offset. Every output, then each smaller count of channel pairs.
TEST(OceanReference, AGridWiderThanARowGroupAgrees) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 40, 120);
  spec.layers[0].nx = 300, spec.layers[0].lx = 900;
  spec.choppiness = 0.9;
  expect_matches_reference(spec, 3.5);
  CpuReference reference;
  auto height = [](const TileFields& f) { return &f.height; };
  auto displacement = [](const TileFields& f) { return &f.displacement_y; };
  auto slope = [](const TileFields& f) { return &f.slope_y; };
  for (auto [outputs, field] : {std::pair<unsigned, const FloatView* (*)(const TileFields&)>{Height, height},
                                {Displacement, displacement},
                                {Slopes, slope}}) {
    auto e = engine().tile(spec, 3.5, outputs), r = reference.tile(spec, 3.5, outputs);
    ASSERT_EQ(field(e)->size(), 300u * 40u);
    EXPECT_LT(test::relative_rms_error(*field(e), *field(r)), 1e-4) << "outputs " << outputs;
  }
}

// A tile that asks for no displacement transforms the undisplaced channel layout, one pair fewer: every
// output of every such set (and of the displaced sets beside them) agrees with the FFTW double reference:
// on one layer (finalize reads the FFT's output), on two layers (the second added to the first's transform)
// and on two layers resampled onto an output grid of their own, wider than a row group of work-items and
// not a multiple of one (both added to a sum of their own, in two launches).
TEST(OceanReference, EveryOutputSetAgreesWithTheReference) {
  TileSpec one = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 64, 150);
  one.layers[0].drift_x = 0.4;
  one.choppiness = 1.2;
  TileSpec two = one;
  two.layers.push_back(one.layers[0]);
  two.layers[1].nx = two.layers[1].ny = 32, two.layers[1].lx = two.layers[1].ly = 41, two.layers[1].seed = 5;
  TileSpec resampled = two;
  resampled.nx = 300, resampled.ny = 40, resampled.lx = 150, resampled.ly = 60;
  using Field = FloatView TileFields::*;
  const std::vector<std::pair<Output, std::vector<Field>>> fields = {
      {Height, {&TileFields::height}},
      {Displacement, {&TileFields::displacement_x, &TileFields::displacement_y}},
      {Slopes, {&TileFields::slope_x, &TileFields::slope_y}},
      {Normals, {&TileFields::normal_x, &TileFields::normal_y, &TileFields::normal_z}},
      {Jacobian, {&TileFields::jacobian, &TileFields::jacobian_minus, &TileFields::jacobian_plus}}};
  const unsigned sets[] = {Height | Normals,
                           Slopes,
                           Height | Slopes,
                           Normals,
                           Jacobian,
                           Slopes | Jacobian,
                           Height | Whitecaps,
                           Height | Displacement | Normals,
                           Displacement | Slopes,
                           Height};
  for (const TileSpec* spec : {&one, &two, &resampled}) {
    const TileFields r = CpuReference().tile(*spec, 2.5, kAllOutputs);
    for (unsigned outputs : sets) {
      const TileFields e = engine().tile(*spec, 2.5, outputs);
      for (const auto& [output, members] : fields)
        for (Field f : members) {
          ASSERT_EQ((e.*f).size(), (outputs & output) ? (r.*f).size() : 0u) << "outputs " << outputs;
          if (outputs & output) {
            EXPECT_LT(test::relative_rms_error(e.*f, r.*f), 1e-4)
                << "outputs " << outputs << ", output " << output << ", layers " << spec->layers.size()
                << ", output grid " << spec->nx;
          }
        }
      ASSERT_EQ(e.whitecaps.size(), (outputs & Whitecaps) ? r.whitecaps.size() : 0u) << "outputs " << outputs;
      size_t differ = 0;  // J- is compared with a threshold: a cell at it may go either way
      for (size_t i = 0; i < e.whitecaps.size(); ++i) differ += e.whitecaps[i] != r.whitecaps[i];
      EXPECT_LE(differ, r.whitecaps.size() / 1000) << "outputs " << outputs << ", output grid " << spec->nx;
    }
  }
}

// `planes` names the fields read back: the others of their groups stay empty, the named ones are those of
// a tile that reads every plane; whitecaps asked for are read whatever `planes` says (the stream's map).
TEST(OceanTile, ReadsBackOnlyTheNamedPlanes) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 64, 150);
  const unsigned height_and_normal_z = (1u << 0) | (1u << 7);
  const TileFields all = engine().tile(spec, 1.5, Height | Normals | Whitecaps);
  const TileFields named = engine().tile(spec, 1.5, Height | Normals | Whitecaps, nullptr, {}, height_and_normal_z);
  EXPECT_EQ(named.height, all.height);
  EXPECT_EQ(named.normal_z, all.normal_z);
  EXPECT_EQ(named.whitecaps, all.whitecaps);
  EXPECT_EQ(named.height.size(), 64u * 64u);
  EXPECT_TRUE(named.normal_x.empty() && named.normal_y.empty());
}

// A tile's fields are views of the memory the engine read them into, which stays theirs while they live:
// the tiles computed after them (of the same shape, which the pool would hand that memory to) leave them
// as they were. Once they go, the next tiles take that memory again: no allocation per tile.
TEST(OceanTile, FieldsKeepTheirMemoryUntilTheyGo) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 64, 150);
  const unsigned outputs = Height | Normals;
  engine().tile(spec, 0.5, outputs);  // the buffers of this shape made
  TileFields kept = engine().tile(spec, 1.5, outputs);
  const std::vector<float> height = kept.height.to_vector(), normal_z = kept.normal_z.to_vector();
  for (int frame = 0; frame < 3; ++frame) {
    const TileFields later = engine().tile(spec, 2.5 + frame, outputs);
    EXPECT_NE(later.height.data(), kept.height.data()) << "frame " << frame;
  }
  EXPECT_EQ(kept.height.to_vector(), height);
  EXPECT_EQ(kept.normal_z.to_vector(), normal_z);
  kept = {};
  const size_t made = squall::test::runtime().buffers().allocations();
  for (int frame = 0; frame < 3; ++frame) engine().tile(spec, 2.5 + frame, outputs);
  EXPECT_EQ(squall::test::runtime().buffers().allocations(), made);
}

TEST(OceanSlopeVariance, UnresolvedSlopeVarianceGrowsWithPixelScale) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Mitsuyasu, 64, 200);
  double previous = 0;
  for (double R : {0.25, 1.0, 4.0}) {
    spec.pixel_scale = R;
    double s = engine().tile(spec, 0, Height).unresolved_slope_variance;
    EXPECT_GT(s, previous) << "R " << R;
    previous = s;
  }
  // R -> infinity with the eq-96 band equal to the tile's modes (a disc): the mean slope variance of
  // the realized fields over seeds
  spec.layers[0].k_max = 0.9 * M_PI * 64 / 200;
  spec.slope_k_max = spec.layers[0].k_max;
  spec.pixel_scale = 1e5;
  double sigma_u = engine().tile(spec, 0, Height).unresolved_slope_variance, measured = 0;
  const int seeds = 16;
  for (int s = 0; s < seeds; ++s) {
    spec.layers[0].seed = 500 + s;
    auto f = engine().tile(spec, 0, Slopes);
    measured += (test::rms(f.slope_x) * test::rms(f.slope_x) + test::rms(f.slope_y) * test::rms(f.slope_y)) / seeds;
  }
  EXPECT_NEAR(measured / sigma_u, 1.0, 0.06);
}

// Layers inside every range whose float dispersion or spectrum vanishes (a depth of 1e-300 m, a wind of
// 1e-300 m/s) make tiles of zeros; their unresolved slope variance is 0 too, not NaN.
TEST(OceanSlopeVariance, ALayerWithNoEnergyHasNone) {
  struct Case {
    SpectrumModel spectrum;
    DispersionKind dispersion;
    double depth, wind_speed;
  } cases[] = {{SpectrumModel::Tma, DispersionKind::Shallow, 1e-300, 12},
               {SpectrumModel::Jonswap, DispersionKind::Shallow, 1e-300, 12},
               {SpectrumModel::PiersonMoskowitz, DispersionKind::Combined, 1e-300, 12},
               {SpectrumModel::ModifiedJonswap, DispersionKind::Deep, 100, 1e-300}};
  for (const Case& c : cases) {
    TileSpec spec = test::single(c.spectrum, SpreadingModel::Mitsuyasu, 32, 200);
    spec.layers[0].dispersion = c.dispersion;
    spec.layers[0].depth = c.depth;
    spec.layers[0].wind_speed = c.wind_speed;
    spec.pixel_scale = 4;
    const TileFields f = engine().tile(spec, 0, Height);
    EXPECT_EQ(f.unresolved_slope_variance, 0.0) << int(c.spectrum) << " " << int(c.dispersion);
    ASSERT_EQ(f.height.size(), 32u * 32u);
    for (float h : f.height) ASSERT_EQ(h, 0.0f) << int(c.spectrum) << " " << int(c.dispersion);
  }
}

// Each inverse FFT transforms two real fields packed as one complex one (re, im): h with D_x when a tile
// asks for height alone, h with eps_x when it asks for slopes and no displacement, eps_x with D_y when it
// asks for everything (the layouts of kernels/ocean/ocean.cl). The packing is exact only if each field's
// spectrum is Hermitian, h~(-k, t) = conj h~(k, t) (eqs 43 and 1, drift included); one that was not would
// leak into its partner, and a field would change with the partner it was packed with.
TEST(OceanTile, AFieldIsTheSameWhicheverFieldItIsPackedWith) {
  TileSpec spec = test::single(SpectrumModel::Jonswap, SpreadingModel::Krylov, 64, 180);
  spec.layers[0].drift_x = 0.4;
  spec.layers[0].drift_y = -1.1;
  const TileFields alone = engine().tile(spec, 9.5, Height), undisplaced = engine().tile(spec, 9.5, Height | Slopes),
                   all = engine().tile(spec, 9.5, kAllOutputs);
  auto worst = [](std::span<const float> a, std::span<const float> b) {
    double w = 0;
    for (size_t i = 0; i < a.size(); ++i) w = squall::test::worse(w, double(std::abs(a[i] - b[i])));
    return w;
  };
  const double h = worst(alone.height, undisplaced.height) / test::rms(alone.height);     // with D_x, with eps_x
  const double eps_x = worst(undisplaced.slope_x, all.slope_x) / test::rms(all.slope_x);  // with h, with D_y
  std::printf("largest difference / rms: height %.2e, slope_x %.2e\n", h, eps_x);
  ASSERT_GT(test::rms(alone.height), 0.1);
  EXPECT_LT(h, 1e-6);      // 6.8e-7 measured: float round-off; a leak would be of the order of the partner
  EXPECT_LT(eps_x, 1e-5);  // 1.9e-6: a transform's round-off goes with the larger field of its pair, h here
}

}  // namespace
}  // namespace squall::ocean
