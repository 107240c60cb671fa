// squall::ocean::OceanEngine: spectral ocean tiles in OpenCL (J. Tessendorf, "Gilligan: A Prototype Framework
// for Simulating and Rendering Maritime Environments" (2017), sec. 2 and 5.3.3, and its App. A, J. Tessendorf,
// "Simulating Ocean Water", sec. 4.3-4.6). Parameters, output flags and conventions: ocean_params.h.
//
// Per frame the engine only does the time evolution (Gilligan eq 1, App A eq 43) and batched inverse FFTs:
// the amplitude spectrum h0(k) of each layer depends on the layer spec alone and is cached on the device
// (bounded cache, keyed by the layer spec, its index and the B(k) geometry), so a stream of frames at
// increasing t reuses it. Thread-safe: device work runs under Runtime::exclusive().
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "common/cancel.h"
#include "common/limits.h"
#include "common/surface_current.h"
#include "fft/fft.h"
#include "ocean/ocean_params.h"
#include "runtime/runtime.h"

namespace squall::ocean {

class OceanEngine {
 public:
  static constexpr size_t kDefaultMaxCachedBytes = size_t(256) << 20;

  // The runtime must have built the "ocean/" programs. `limits` (the daemon's) bound the grids tile() and
  // sample() accept. max_cached_bytes bounds the h0 cache (a layer's spectrum larger than it serves its
  // tile and is not kept), and the spectra kept hold their bytes in `budget`'s memory budget (none: not
  // counted); where the budget has no room, the least recently used give theirs or the new one is not kept.
  OceanEngine(Runtime& runtime, fft::Fft& fft, const Limits& limits = {},
              size_t max_cached_bytes = kDefaultMaxCachedBytes, LimitGate* budget = nullptr);
  ~OceanEngine();

  // Throws squall::Error(InvalidArgument) naming the field ("layers[0].wind_speed = nan must be finite
  // and > 0", "layers[1].spectrum = 9 is not a known model", "choppiness", "nx", ...), or
  // ResourceExhausted from the gate's grid limit (layers[i] and the output grid). tile() and sample()
  // call it with the engine's limits; the service validates each request first, under its field path.
  void validate(const TileSpec& spec, const LimitGate& gate) const;
  void validate(const TileSpec& spec) const;  // with the engine's limits
  // INVALID_ARGUMENT naming "<path>.layers[i].nx" (or ny) where the engine's FFT backend cannot transform a
  // layer's grid (fft::Backend::transforms: clfft's lengths are products of its radices); validate() checks
  // it too, before anything is built.
  void check_transforms(const TileSpec& spec, const std::string& path = "") const;

  // The fields of `outputs` (Output flags, at least one) at absolute time t (s, finite). whitecaps may be
  // null (then the map of this frame alone: 1 where J- < threshold, else 0); otherwise it carries the
  // map of one stream across frames (see WhitecapState).
  // `cancel` is checked before each layer, after each slice of a spectrum it builds and, on grids of more
  // than 2^20 cells, between a frame's stages (each waited for): a cancelled call frees the device within
  // a slice or a stage (Error(Cancelled)). `planes` (kAllPlanes bits): of the outputs' fields, those read
  // back; the others are left empty (whitecaps, when asked for, are always read: the stream's map needs them).
  // The fields are views (TileFields): where the device computes in its pool buffers' host storage
  // (PoCL's CPU devices), of the buffer the kernels wrote them in; elsewhere of one pinned host block they
  // were read into. Either is held from the runtime's pool until the last view goes (so the fields must
  // not outlive the runtime). `spectra_memory`: where given, the caller's reservation, which counted the
  // spectra the tile builds (new_spectra_bytes); a spectrum kept moves its bytes from there to the cache,
  // and one evicted since the reservation was made is reserved anew before it is built.
  TileFields tile(const TileSpec& spec, double t, unsigned outputs, WhitecapState* whitecaps = nullptr,
                  const Cancellation& cancel = {}, unsigned planes = kAllPlanes, Slot* spectra_memory = nullptr);

  // The surface at world points (x, y in m, finite, any value: the layers repeat periodically), summed
  // over all layers, bilinear between the layers' grid points. With invert_displacement the sample is
  // that of the source point x0 whose displaced position x0 + lambda D(x0) lands on the query point
  // (Newton's method to 1e-6 of the finest cell, or the rounding of double at the point; past a fold, one
  // of its sources, searched again from around the point where the first search stalls). `cancel` is
  // asked before each layer, after each slice of a spectrum it builds, before a large layer's transform
  // (as in tile) and before each kSamplesPerCheck points or searches: Error(Cancelled) then.
  static constexpr size_t kSamplesPerCheck = 4096;
  std::vector<SurfaceSample> sample(const TileSpec& spec, double t, const std::vector<Vec2>& points,
                                    bool invert_displacement, const Cancellation& cancel = {},
                                    Slot* spectra_memory = nullptr);  // as tile()'s

  // For the eWave engine (server/ewave): the height h (m) and the linear-theory velocity potential at
  // z = 0, phi (m^2/s), at time t on the spec's output grid, left on the device in `out` (2 planes of
  // nx * ny floats: h, then phi). phi~ = -i (G/w) [h0(k) e^{-iwt} - conj(h0(-k)) e^{iwt}] e^{-ik.U_D t},
  // G = g (1 + (k l)^2), per layer with its own dispersion (ocean.cl ocean_evolve_potential). The spec
  // must be valid; the CALLER HOLDS runtime.exclusive() (the kernels are enqueued, not waited for, on the
  // runtime's queue). `cancel` and `spectra_memory` as tile()'s, for the spectra it builds.
  void surface_on_device(const TileSpec& spec, double t, const cl::Buffer& out, const Cancellation& cancel = {},
                         Slot* spectra_memory = nullptr);

  // For the textures that follow the waves (server/textures): the surface current at time t on the spec's
  // output grid (node (i, j) at (i lx / nx, j ly / ny)), u = grad phi of the potential above (the
  // orbital velocity of linear theory, exact spectral derivatives, summed over the layers) plus the drift
  // U_D the layers share. The spec must pass validate_current(). `spectra_memory` as tile()'s.
  SurfaceCurrent surface_current(const TileSpec& spec, double t, Slot* spectra_memory = nullptr);

  size_t cached_spectra() const;  // h0 entries on the device now
  size_t spectra_built() const;   // h0 computations so far (cache misses)
  // Bytes of the spectra (h0) a tile or sample of `spec` would build now: its layers' that are not kept.
  uint64_t new_spectra_bytes(const TileSpec& spec) const;
  // The spectra of `spec` kept now, for the caller to hold: the cache does not take back a spectrum held
  // (to make room for the caller's own reservation, say), so it need not be built again.
  std::vector<cl::Buffer> kept_spectra(const TileSpec& spec);
  size_t cached_spectrum_bytes() const;  // held by the h0 entries now

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Working memory of one call, for the caller's memory budget: the device buffers tile() takes from the
// pool for `spec` and `outputs` (Output bits; on the output grid its output planes, whitecap plane and
// layer sums, and the complex channels of one layer at a time), and the host copies of every layer's
// channels and the one layer's device buffer that sample() holds. The layers' spectra (h0) are not
// counted: those kept count in the budget as cached memory, and the caller adds those to be built
// (OceanEngine::new_spectra_bytes).
uint64_t tile_device_bytes(const TileSpec& spec, unsigned outputs);
uint64_t sample_bytes(const TileSpec& spec);
// The same for surface_on_device beside its output: one layer's (h, phi) pair at a time.
uint64_t surface_device_bytes(const TileSpec& spec);

// validate_tile(spec, gate, path), and one drift for every layer (a current carries the whole surface):
// "<path>.layers[i].drift_x = 0.5 must equal layers[0]'s 0".
void validate_current(const TileSpec& spec, const LimitGate& gate, const std::string& path);

}  // namespace squall::ocean
// API-READY
