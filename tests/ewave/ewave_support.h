// Helpers shared by the eWave tests: sessions on the test runtime, and independent double-precision
// references (FFTW, dispersion formulas written out from Table 1 of J. Tessendorf, "Gilligan: A Prototype
// Framework for Simulating and Rendering Maritime Environments" (2017)).
#pragma once

#include <cmath>
#include <functional>
#include <vector>

#include "ewave/ewave_config.h"
#include "ewave/ewave_session.h"

namespace squall::ewave::test {

// A 1 cm, deep-water, untrimmed config of nx x ny.
EWaveConfig plain_config(int64_t nx, int64_t ny, double spacing = 0.01);
// The plan cache of the sessions' FFTs: $SQUALL_EWAVE_TEST_FFT, else the engine tests' backend
// (squall::test::engine_fft_backend()).
fft::Fft& session_fft();
EWaveSession make_session(const EWaveConfig& config);  // on session_fft()

// omega(k) in double, written from Table 1 independently of kernels/common/dispersion.h.
double reference_omega(double k, const EWaveConfig& config);
// G(k) = g (1 + (k l)^2) with surface tension, g without, m/s^2: dphi/dt = -G h.
double reference_restoring(double k, const EWaveConfig& config);

// E = sum_k (G |h~|^2 + (omega^2/G) |phi~|^2) over the full spectrum (FFTW, double): the energy that the
// propagator of Gilligan eqs 64-65, in its energy-conserving form (omega/G in place of k/omega), keeps.
double spectral_energy(const std::vector<float>& h, const std::vector<float>& phi, const EWaveConfig& config);

// Frame with height and phi.
StepInputs plain_step(double dt);

// A field f(x, y) at the cell centres ((i + 0.5) dx, (j + 0.5) dy).
std::vector<float> field(const EWaveConfig& config, const std::function<double(double, double)>& f);

// Every field of two frames equal bit for bit (gtest expectations).
void expect_bit_identical(const Frame& a, const Frame& b);

double rms(const std::vector<float>& a);
double rms_difference(const std::vector<float>& a, const std::vector<float>& b);
double max_abs(const std::vector<float>& a);

}  // namespace squall::ewave::test
