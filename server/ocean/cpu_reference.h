// The independent CPU reference of the ocean engine: the same tile computed in double precision with FFTW
// (no OpenCL), for the tests and the benchmark. It shares the parameter structs (ocean_params.h) and the
// pure spectrum formulas (kernels/ocean/spectra.h, checked against closed forms by the tests) with the
// engine, and nothing else: its random generator, dispersion, mode layout, time evolution, derivatives,
// resampling and output stages are its own. Library: squall_ocean_reference (links FFTW).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "ocean/ocean_params.h"

namespace squall::ocean {

class CpuReference {
 public:
  // threads: FFTW threads (1 = single-threaded).
  explicit CpuReference(int threads = 1);
  ~CpuReference();

  // The same fields and conventions as OceanEngine::tile (no validation: pass a validated spec).
  // The h0 spectra are cached per layer like the engine's, so a stream of frames costs eq 43 + FFTs.
  TileFields tile(const TileSpec& spec, double t, unsigned outputs, WhitecapState* whitecaps = nullptr);

  // P(k) of a layer at wave vector (kx, ky), m^4 (eq 3, or Phillips), in double precision, with D over the
  // cell of a grid of steps dkx, dky about it (sq_mode_cell; 0 and 0: at the point).
  static double spectrum(const LayerSpec& layer, double kx, double ky, double dkx = 0, double dky = 0);
  // The mean frequency m1 / m0 of a Krylov layer's S(w) (Gilligan's eq 31), rad/s; 0 for other spreads.
  static double mean_frequency(const LayerSpec& layer);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace squall::ocean
