// Multiple layers: with the B(k) correction (eqs 56-57, B = count of covering layers) the composite keeps
// the single-layer spectrum; without it the overlaps carry B times the power.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "ocean/cpu_reference.h"
#include "ocean_test_util.h"

namespace squall::ocean {
namespace {

TileSpec nested_layers(bool correction) {
  // 64 m / 64, 32 m / 32 and 16 m / 16 cells: all 1 m apart, so the output grid (the first layer's)
  // samples every layer exactly, and the smaller patches' modes sit on the first layer's lattice.
  TileSpec spec = test::single(SpectrumModel::PiersonMoskowitz, SpreadingModel::Isotropic, 64, 64);
  spec.layers[0].wind_speed = 4;
  for (int a = 1; a < 3; ++a) {
    LayerSpec L = spec.layers[0];
    L.lx = L.ly = 64.0 / (1 << a);
    L.nx = L.ny = 64 >> a;
    spec.layers.push_back(L);
  }
  spec.b_correction = correction;
  return spec;
}

struct Bins {
  std::vector<double> measured, single_layer, exact, variance;
};

// B(k): layers whose band holds k (a third implementation, for the test).
double covering(const TileSpec& spec, double kx, double ky) {
  double count = 0;
  for (const LayerSpec& L : spec.layers) {
    double ax = std::abs(kx), ay = std::abs(ky);
    count += ax < (L.nx - 1) * M_PI / L.lx && ay < (L.ny - 1) * M_PI / L.ly && !(ax < M_PI / L.lx && ay < M_PI / L.ly);
  }
  return count;
}

// Exact expectation of the composite's power per bin: every layer's modes, (P(k)+P(-k)) dk_a^2 / B(k)
// (1 without the correction), and the variance of the bin sum (exponential |h~|^2, h~(-k) = conj h~(k)).
void exact_expectation(const TileSpec& spec, Bins& out, int bins, double k_top) {
  for (const LayerSpec& L : spec.layers) {
    double dk = 2 * M_PI / L.lx;
    for (int64_t m = -L.ny / 2 + 1; m < L.ny / 2; ++m)
      for (int64_t n = -L.nx / 2 + 1; n < L.nx / 2; ++n) {
        double kx = n * dk, ky = m * dk;
        int b = int(std::hypot(kx, ky) / k_top * bins);
        if (b >= bins || (n == 0 && m == 0)) continue;
        double B = spec.b_correction ? covering(spec, kx, ky) : 1.0;
        double e = (CpuReference::spectrum(L, kx, ky) + CpuReference::spectrum(L, -kx, -ky)) * dk * dk / B;
        out.exact[b] += e;
        out.variance[b] += 2 * e * e;
      }
  }
}

Bins radial_power(bool correction, int seeds, int bins, double k_top) {
  Bins out{std::vector<double>(bins, 0), std::vector<double>(bins, 0), std::vector<double>(bins, 0),
           std::vector<double>(bins, 0)};
  TileSpec spec = nested_layers(correction);
  exact_expectation(spec, out, bins, k_top);
  const LayerSpec& L = spec.layers[0];
  double dk = 2 * M_PI / L.lx;
  for (int s = 0; s < seeds; ++s) {
    for (size_t a = 0; a < spec.layers.size(); ++a) spec.layers[a].seed = 3000 + 7 * s + a;
    auto H = test::spectrum_of(test::engine().tile(spec, 1.5, Height).height, L.nx, L.ny);
    for (int64_t j = 0; j < L.ny; ++j)
      for (int64_t i = 0; i < L.nx; ++i) {
        int64_t n = test::signed_mode(i, L.nx), m = test::signed_mode(j, L.ny);
        if (2 * i == L.nx || 2 * j == L.ny) continue;
        int b = int(std::hypot(n * dk, m * dk) / k_top * bins);
        if (b >= bins) continue;
        out.measured[b] += std::norm(H[i + L.nx * j]);
        if (s == 0)
          out.single_layer[b] +=
              (CpuReference::spectrum(L, n * dk, m * dk) + CpuReference::spectrum(L, -n * dk, -m * dk)) * dk * dk;
      }
  }
  for (int b = 0; b < bins; ++b) out.measured[b] /= seeds, out.variance[b] /= seeds;
  return out;
}

TEST(OceanLayers, BCorrectionRestoresTheSingleLayerSpectrum) {
  const int seeds = 48, bins = 5;
  const double k_top = 0.9 * M_PI;  // inside the Nyquist band of every layer
  Bins with = radial_power(true, seeds, bins, k_top), without = radial_power(false, seeds, bins, k_top);
  for (int b = 0; b < bins; ++b) {
    // the realized power is the expectation of the layers' modes within the sampling error
    EXPECT_NEAR(with.measured[b], with.exact[b], 5 * std::sqrt(with.variance[b])) << "bin " << b;
    EXPECT_NEAR(without.measured[b], without.exact[b], 5 * std::sqrt(without.variance[b])) << "bin " << b;
    if (b == 0) continue;  // bin 0 holds the cells below the small layers' bands
    // three layers cover bins 1..: the correction divides every layer's power there by exactly B = 3
    EXPECT_NEAR(with.exact[b] / without.exact[b], 1.0 / 3.0, 1e-9) << "bin " << b;
    EXPECT_NEAR(without.measured[b] / with.measured[b], 3.0, 0.3) << "bin " << b;
  }
  // Over the band the expected composite power with B(k) is the single-layer power (per narrow bin the
  // coarse layers' lattices, 4 and 16 output cells per mode, leave up to 13% of mode-counting noise);
  // without the correction it is three times the physical power.
  // The same for the power the engine realized.
  double with_sum = 0, without_sum = 0, single = 0, with_realized = 0, without_realized = 0;
  for (int b = 1; b < bins; ++b) {
    with_sum += with.exact[b], without_sum += without.exact[b], single += with.single_layer[b];
    with_realized += with.measured[b], without_realized += without.measured[b];
  }
  EXPECT_NEAR(with_sum / single, 1.0, 0.1);
  EXPECT_NEAR(without_sum / single, 3.0, 0.3);
  EXPECT_NEAR(with_realized / single, 1.0, 0.1);
  EXPECT_NEAR(without_realized / single, 3.0, 0.3);
  printf("band power / single layer: corrected %.4f (realized %.4f), uncorrected %.4f (realized %.4f)\n",
         with_sum / single, with_realized / single, without_sum / single, without_realized / single);
}

}  // namespace
}  // namespace squall::ocean
