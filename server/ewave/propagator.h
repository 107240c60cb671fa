// Host-side tables of an eWave session: the per-mode propagator coefficients (eq 64-65 in the
// energy-conserving form), the 1D trim profiles (eq 82), and obstruction shapes in device layout. Equation
// numbers are those of J. Tessendorf, "Gilligan: A Prototype Framework for Simulating and Rendering
// Maritime Environments" (2017), sec. 3.
#pragma once

#include <vector>

#include "common/dispersion.h"
#include "ewave/ewave_config.h"
#include "ewave/shapes.h"

namespace squall::ewave {

Dispersion dispersion_of(const EWaveConfig& config);

// Wavenumber of half-spectrum column i and row j (rad/m): kx = 2 pi i / Lx, ky = 2 pi j' / Ly with
// j' = j for j <= ny/2, j - ny above.
double wavenumber(const EWaveConfig& config, size_t i, size_t j);

// 4 floats per mode of the (nx/2+1) x ny half spectrum: (c, (omega/G) s, (G/omega) s, 0) / (nx ny),
// c = cos(omega dt), s = sin(omega dt), omega = dispersion_omega(k), G = dispersion_restoring(k) (g, and
// surface tension's g (k l)^2): the exact flow of dh/dt = (omega^2 / G) phi = k tanh(kh) phi and
// dphi/dt = -G h, phi the velocity potential at the surface. At k = 0: (1, 0, g dt, 0) / (nx ny). The
// determinant c^2 + s^2 = 1 per mode, so E = sum G|h~|^2 + (omega^2/G)|phi~|^2 is conserved (Gilligan
// sec. 3.2 keeps eq 64's k/omega with a general omega; that gives the determinant c^2 + (g k/omega^2) s^2
// and loses energy unless omega^2 = g k. (omega/G) s equals k/omega in deep water).
std::vector<double> propagator_coefficients(const EWaveConfig& config, double dt);

// The period 2 pi / omega of the grid's shortest wave, at its corner mode (pi/dx, pi/dy), s. With the trim
// on, steps longer than it feed energy in: the taper multiplies phi as well as h (eqs 78-80), and the
// gradient it gives phi is turned into waves by the next step's full rotation of the shortest modes.
double shortest_wave_period(const EWaveConfig& config);

// The 1D trim of eq 82 at the n cell centres x = (i + 0.5) d of a side of length n d, taper width L:
// (x/L)^alpha near 0, ((n d - x)/L)^alpha near n d, 1 elsewhere.
std::vector<float> trim_profile(size_t n, double d, double width, double alpha);

// Device layout of the shapes (bounding boxes filled in); polygon vertices appended to *vertices.
std::vector<EWaveShape> device_shapes(const std::vector<Shape>& shapes, std::vector<float>* vertices);

}  // namespace squall::ewave
