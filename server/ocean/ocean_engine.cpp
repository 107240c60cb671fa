#include "ocean/ocean_engine.h"

#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>

#include "common/error.h"
#include "common/validate.h"
#include "ocean/spectrum_setup.h"
#include "runtime/device_cache.h"
#include "runtime/host_transfer.h"
#include "runtime/kernel.h"

SQUALL_KERNEL_STRUCT(Dispersion)  // ocean_evolve_potential and ocean_evolve_current take the layer's

namespace squall::ocean {
namespace {

constexpr const char* kProgram = "ocean/ocean.cl";
constexpr int kOutputPlanes = 13;  // OUT_* of ocean.cl: plane::Index order, then scratch

// The kernels of ocean.cl, each argument list in the order of its signature.
using H0Kernel = Kernel<cl::Buffer, cl::Buffer, cl_int, cl::Buffer>;  // layer, bands, nbands, h0
using H0MirrorKernel = Kernel<cl::Buffer, cl_int, cl_int>;            // h0, nx, ny
constexpr size_t kH0Planes = 6;                                       // H0_PLANES of ocean.cl
constexpr size_t kH0FrequencyPlane = 2;                               // H0_FREQUENCY_HI, then H0_FREQUENCY_LO
constexpr size_t kFrequencyBlockModes = size_t(1) << 16;              // modes per write of the frequencies
// Modes of a spectrum computed between two looks at the call's cancellation (whole rows, at least one):
// ocean_h0 takes about 160 ns a mode on two CPU cores, so a 4096^2 layer's 2.7 s is cancelled within 0.2 s.
constexpr size_t kSpectrumSliceModes = size_t(1) << 20;
// A frame's stages (evolve, inverse FFT, finalize) over more cells than this are each waited for, and the
// call's cancellation looked at before the next: a 4096^2 layer's take 0.19, 0.27 and 0.14 s on two CPU
// cores. Smaller frames' stages are enqueued without a wait.
constexpr size_t kStageLookCells = kSpectrumSliceModes;
// h0, nx, ny, dkx, dky, t_hi, t_lo, shift, out (ocean_evolve1 to 4 and ocean_evolve_undisplaced2 and 3, one per
// channel layout and count of pairs)
using EvolveKernel = Kernel<cl::Buffer, cl_int, cl_int, cl_float, cl_float, cl_float, cl_float, cl_float2, cl::Buffer>;
// h0, nx, ny, dkx, dky, t_hi, t_lo, shift, the layer's dispersion, out
using PotentialKernel =
    Kernel<cl::Buffer, cl_int, cl_int, cl_float, cl_float, cl_float, cl_float, cl_float2, Dispersion, cl::Buffer>;
// fields, nx, ny, pairs, scale, onx, ony, first, interleaved, accum
using AccumulateKernel =
    Kernel<cl::Buffer, cl_int, cl_int, cl_int, cl_float2, cl_int, cl_int, cl_int, cl_int, cl::Buffer>;
// sums, cells, channels, displaced, lambda, flags, threshold, decay, whitecap, out
using FinalizeKernel =
    Kernel<cl::Buffer, cl_int, cl_int, cl_int, cl_float, cl_int, cl_float, cl_float, cl::Buffer, cl::Buffer>;

template <typename T>
void append(std::string& key, const T& value) {
  key.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

// Everything h0 of layer `index` depends on: the layer's spectrum, grid and seed, and the B(k) bands.
std::string h0_key(const TileSpec& spec, size_t index) {
  const LayerSpec& L = spec.layers[index];
  std::string key;
  for (double v :
       {L.lx, L.ly, L.wind_speed, L.fetch, L.gamma, L.sigma_a, L.sigma_b, L.phillips_amplitude, L.phillips_cutoff,
        L.phillips_exponent, L.wind_direction, L.depth, L.capillary_length, L.gravity, L.k_min, L.k_max})
    append(key, v);
  for (int64_t v : {L.nx, L.ny, int64_t(L.spectrum), int64_t(L.spreading), int64_t(L.dispersion), int64_t(index)})
    append(key, v);
  append(key, L.seed);
  // The lists with their lengths: without, the partials of one spec and the bands of another could spell
  // the same bytes, and one client's spectrum be served for another's spec.
  append(key, int64_t(L.partials.size()));
  for (const PartialSpectrum& q : L.partials)
    for (double v : {q.peak_frequency, q.significant_wave_height, q.a, q.b, q.c, q.n, q.m}) append(key, v);
  const auto bands = layer_bands(spec);
  append(key, int64_t(bands.size()));
  for (const auto& band : bands) append(key, band);
  return key;
}

std::string describe_outputs(unsigned outputs) { return std::to_string(outputs); }

// A layer's spectrum h0 on the device: kH0Planes floats a mode.
uint64_t spectrum_bytes(const LayerSpec& L) { return uint64_t(L.nx) * uint64_t(L.ny) * kH0Planes * sizeof(float); }

// The time t as two floats, t_hi + t_lo, for the kernels' phases in turns (common/sincos.h).
cl_float2 two_float_time(double t) {
  const float t_hi = float(t);
  return {{t_hi, float(t - double(t_hi))}};
}

// The drift's shift U_D t in periods of the layer's extent, reduced to [0, 1] in double (1 when float
// rounds it up): the kernels' phase of mode (n, m) is then n s.x + m s.y turns at any t (a rate k.U_D in
// float would lose it at large t).
cl_float2 drift_shift(const LayerSpec& L, double t) {
  auto periods = [t](double drift, double extent) {
    const double s = drift * t / extent;
    return float(s - std::floor(s));
  };
  return {{periods(L.drift_x, L.lx), periods(L.drift_y, L.ly)}};
}

}  // namespace

struct OceanEngine::Impl {
  Runtime& runtime;
  fft::Fft& fft;
  LimitGate gate;  // the grid limit of tile() and sample()
  H0Kernel h0_kernel;
  H0MirrorKernel h0_mirror;
  std::array<EvolveKernel, 4> evolve;              // displaced layout, [pairs - 1]
  std::array<EvolveKernel, 2> evolve_undisplaced;  // undisplaced layout, [pairs - 2]
  AccumulateKernel accumulate;
  FinalizeKernel finalize;
  PotentialKernel evolve_potential, evolve_current;

  LimitGate* budget;                              // the daemon's memory budget; none in some tests
  DeviceCache<std::string> spectra;               // h0 per layer (h0_key)
  std::map<std::string, double> slope_variances;  // eq 96 per spec (bounded)
  std::mutex slope_mutex;                         // guards slope_variances

  Impl(Runtime& r, fft::Fft& f, const Limits& limits, size_t max_cached_bytes, LimitGate* budget)
      : runtime(r),
        fft(f),
        gate(limits),
        h0_kernel(r, kProgram, "ocean_h0"),
        h0_mirror(r, kProgram, "ocean_h0_mirror"),
        evolve{EvolveKernel(r, kProgram, "ocean_evolve1"), EvolveKernel(r, kProgram, "ocean_evolve2"),
               EvolveKernel(r, kProgram, "ocean_evolve3"), EvolveKernel(r, kProgram, "ocean_evolve4")},
        evolve_undisplaced{EvolveKernel(r, kProgram, "ocean_evolve_undisplaced2"),
                           EvolveKernel(r, kProgram, "ocean_evolve_undisplaced3")},
        accumulate(r, kProgram, "ocean_accumulate"),
        finalize(r, kProgram, "ocean_finalize"),
        evolve_potential(r, kProgram, "ocean_evolve_potential"),
        evolve_current(r, kProgram, "ocean_evolve_current"),
        budget(budget),
        spectra(max_cached_bytes, budget, "an ocean layer's spectrum kept for the next tiles") {}

  // h0 of layer `index`, computed on a miss (and finished before it is cached: other queues may read it
  // at once), in slices of rows that `cancel` can stop between (Error(Cancelled): nothing is cached). Runs
  // under runtime.exclusive(). A handle, not a reference: another request may evict it. `reserved`, the
  // caller's reservation for the spectra it builds, counted those not kept when it was made: one kept
  // then and evicted since by another call is reserved anew before it is built (RESOURCE_EXHAUSTED where it
  // does not fit; the wait for room, at most LimitGate's, holds the device queue, but only in that race).
  cl::Buffer spectrum(const TileSpec& spec, size_t index, const Cancellation& cancel = {}, Slot* reserved = nullptr) {
    return spectra.get(
        h0_key(spec, index),
        [&] {
          const LayerSpec& L = spec.layers[index];
          const size_t bytes = size_t(spectrum_bytes(L));
          const std::string what = "the spectrum of layer " + std::to_string(index);
          if (reserved && budget) budget->top_up(*reserved, what, [&] { return bytes; });
          OceanLayer params = device_layer(L, int(index));
          auto bands = layer_bands(spec);
          const cl::Context& context = runtime.context();
          cl::Buffer layer(context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(params), &params);
          std::array<float, 4> none{};
          cl::Buffer band_buffer(context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR,
                                 std::max<size_t>(1, bands.size()) * sizeof(none),
                                 bands.empty() ? none.data() : bands.front().data());
          cl::Buffer h0(context, CL_MEM_READ_WRITE, bytes);
          const size_t nx = size_t(L.nx), ny = size_t(L.ny), rows = std::max<size_t>(1, kSpectrumSliceModes / nx);
          for (size_t row = 0; row < ny; row += rows) {
            const size_t count = std::min(rows, ny - row);
            write_frequencies(L, h0, row * nx, count * nx);
            h0_kernel.launch_region(cl::NDRange(0, row), cl::NDRange(nx, count), cl::NullRange, layer, band_buffer,
                                    cl_int(bands.size()), h0);
            runtime.queue().finish();  // each slice ends before `cancel` is looked at
            cancel.check(what);
          }
          h0_mirror.launch(cl::NDRange(L.nx, L.ny), cl::NullRange, h0, cl_int(L.nx), cl_int(L.ny));
          runtime.queue().finish();  // the parameter buffers go out of scope
          return DeviceCache<std::string>::Made{h0, bytes};
        },
        cancel, reserved);
  }

  // Modes first .. first + count - 1 of the planes H0_FREQUENCY_HI and _LO of h0 (ocean.cl), from the
  // host's double-precision dispersion, a block of modes at a time.
  void write_frequencies(const LayerSpec& L, const cl::Buffer& h0, size_t first, size_t count) {
    const size_t plane_bytes = size_t(L.nx) * size_t(L.ny) * sizeof(float);
    std::vector<float> hi(std::min(count, kFrequencyBlockModes)), lo(hi.size());
    for (size_t done = 0; done < count; done += hi.size()) {
      const size_t block = std::min(hi.size(), count - done), offset = (first + done) * sizeof(float);
      mode_frequencies(L, first + done, block, hi.data(), lo.data());
      runtime.queue().enqueueWriteBuffer(h0, CL_TRUE, kH0FrequencyPlane * plane_bytes + offset, block * sizeof(float),
                                         hi.data());
      runtime.queue().enqueueWriteBuffer(h0, CL_TRUE, (kH0FrequencyPlane + 1) * plane_bytes + offset,
                                         block * sizeof(float), lo.data());
    }
  }

  double slope_variance(const TileSpec& spec) {
    std::string key;
    for (size_t a = 0; a < spec.layers.size(); ++a) key += h0_key(spec, a);
    for (double v : {spec.pixel_scale, spec.slope_k_max, spec.lx, spec.ly, double(spec.nx), double(spec.ny)})
      append(key, v);
    {
      std::lock_guard<std::mutex> guard(slope_mutex);
      auto it = slope_variances.find(key);
      if (it != slope_variances.end()) return it->second;
    }
    double value = unresolved_slope_variance(spec);
    std::lock_guard<std::mutex> guard(slope_mutex);
    if (slope_variances.size() >= 256) slope_variances.clear();
    slope_variances[key] = value;
    return value;
  }

  // The layer's (h, phi) pair (evolve_potential) or (u, v) pair (evolve_current) at t on its own grid: the
  // kernel, then the inverse FFT.
  BufferLease layer_pair(const TileSpec& spec, size_t index, double t, PotentialKernel& kernel,
                         const Cancellation& cancel = {}, Slot* spectra_memory = nullptr) {
    const LayerSpec& L = spec.layers[index];
    const cl::Buffer h0 = spectrum(spec, index, cancel, spectra_memory);
    fft::PlanKey key{size_t(L.nx), size_t(L.ny), 1, fft::Transform::C2C, fft::Precision::F32};
    BufferLease fields = runtime.buffers().acquire(key.complex_bytes());
    const cl_float2 time = two_float_time(t);
    kernel.launch_rows(L.nx, L.ny, h0, cl_int(L.nx), cl_int(L.ny), cl_float(2 * SQUALL_PI / L.lx),
                       cl_float(2 * SQUALL_PI / L.ly), time.s[0], time.s[1], drift_shift(L, t), dispersion_of(L),
                       fields.buffer());
    fft.plan(key).enqueue(runtime.queue(), fft::Direction::Inverse, fields.buffer(), fields.buffer());
    return fields;
  }

  // How ocean_accumulate lays out the sums: as complex arrays (an inverse FFT's output), or as planes of the
  // real parts and of the imaginary parts.
  enum class Layout { Interleaved, Planes };

  // Adds one layer's `pairs` complex arrays onto the output grid's `pairs` channel pairs of `accum` (written
  // if `first`).
  void accumulate_layer(const cl::Buffer& fields, const LayerSpec& L, int pairs, const OutputGrid& grid, bool first,
                        Layout layout, const cl::Buffer& accum) {
    // Output point i sits at i * s layer cells, periodic: s is taken into the period here, in double, so that
    // i * s keeps its fraction of a cell in float however many periods apart the points are.
    const double sx = std::remainder((grid.lx / grid.nx) / (L.lx / L.nx), double(L.nx));
    const double sy = std::remainder((grid.ly / grid.ny) / (L.ly / L.ny), double(L.ny));
    cl_float2 scale{{float(sx), float(sy)}};
    accumulate.launch_rows(grid.nx, grid.ny, fields, cl_int(L.nx), cl_int(L.ny), cl_int(pairs), scale, cl_int(grid.nx),
                           cl_int(grid.ny), cl_int(first ? 1 : 0), cl_int(layout == Layout::Interleaved ? 1 : 0),
                           accum);
  }

  // The layer's real channels at t on its own grid: `layout.pairs` complex arrays (ocean.cl).
  BufferLease layer_fields(const TileSpec& spec, size_t index, double t, ChannelLayout layout,
                           const Cancellation& cancel, Slot* reserved) {
    const LayerSpec& L = spec.layers[index];
    const cl::Buffer& h0 = spectrum(spec, index, cancel, reserved);
    fft::PlanKey key{size_t(L.nx), size_t(L.ny), size_t(layout.pairs), fft::Transform::C2C, fft::Precision::F32};
    BufferLease fields = runtime.buffers().acquire(key.complex_bytes());
    const cl_float2 time = two_float_time(t);
    EvolveKernel& kernel = layout.displaced ? evolve.at(layout.pairs - 1) : evolve_undisplaced.at(layout.pairs - 2);
    kernel.launch_rows(L.nx, L.ny, h0, cl_int(L.nx), cl_int(L.ny), cl_float(2 * SQUALL_PI / L.lx),
                       cl_float(2 * SQUALL_PI / L.ly), time.s[0], time.s[1], drift_shift(L, t), fields.buffer());
    look_between_stages(size_t(L.nx) * size_t(L.ny), cancel, "the transform of layer " + std::to_string(index));
    fft.plan(key).enqueue(runtime.queue(), fft::Direction::Inverse, fields.buffer(), fields.buffer());
    return fields;
  }

  // After a stage over `cells` (kStageLookCells or fewer: returns at once), waits for it and throws
  // Error(Cancelled) "<next> cancelled ..." if `cancel` is requested.
  void look_between_stages(size_t cells, const Cancellation& cancel, const std::string& next) {
    if (cells <= kStageLookCells) return;
    runtime.queue().finish();
    cancel.check(next);
  }
};

OceanEngine::OceanEngine(Runtime& runtime, fft::Fft& fft, const Limits& limits, size_t max_cached_bytes,
                         LimitGate* budget)
    : impl_(std::make_unique<Impl>(runtime, fft, limits, max_cached_bytes, budget)) {}
OceanEngine::~OceanEngine() = default;

void OceanEngine::validate(const TileSpec& spec, const LimitGate& gate) const {
  validate_tile(spec, gate);
  check_transforms(spec);
}
void OceanEngine::validate(const TileSpec& spec) const { validate(spec, impl_->gate); }

void OceanEngine::check_transforms(const TileSpec& spec, const std::string& path) const {
  const std::string layers = path.empty() ? "layers" : path + ".layers";
  for (size_t i = 0; i < spec.layers.size(); ++i)
    for (const auto& [axis, n] : {std::pair{".nx", spec.layers[i].nx}, std::pair{".ny", spec.layers[i].ny}})
      impl_->fft.check_length(validate::at(layers, i) + axis, size_t(n));
}

void OceanEngine::surface_on_device(const TileSpec& spec, double t, const cl::Buffer& out, const Cancellation& cancel,
                                    Slot* spectra_memory) {
  validate::finite("t", t);
  OutputGrid grid = output_grid(spec);
  for (size_t a = 0; a < spec.layers.size(); ++a) {
    cancel.check("surface: before layer " + std::to_string(a));
    BufferLease fields = impl_->layer_pair(spec, a, t, impl_->evolve_potential, cancel, spectra_memory);
    impl_->accumulate_layer(fields.buffer(), spec.layers[a], 1, grid, a == 0, Impl::Layout::Planes, out);
  }
}

void validate_current(const TileSpec& spec, const LimitGate& gate, const std::string& path) {
  validate_tile(spec, gate, path);
  const std::string layers = path.empty() ? "layers" : path + ".layers";
  for (size_t i = 1; i < spec.layers.size(); ++i) {
    const LayerSpec &a = spec.layers[i], &first = spec.layers[0];
    const std::pair<const char*, std::pair<double, double>> drifts[] = {{"drift_x", {a.drift_x, first.drift_x}},
                                                                        {"drift_y", {a.drift_y, first.drift_y}}};
    for (const auto& [name, values] : drifts) {
      if (values.first != values.second)
        validate::reject(
            validate::at(layers, i) + "." + name, values.first,
            "equal to layers[0]'s " + validate::number(values.second) + " (one current carries the surface)");
    }
  }
}

SurfaceCurrent OceanEngine::surface_current(const TileSpec& spec, double t, Slot* spectra_memory) {
  validate::finite("t", t);
  const OutputGrid grid = output_grid(spec);
  const size_t cells = size_t(grid.nx) * size_t(grid.ny);
  SurfaceCurrent current;
  current.nx = grid.nx;
  current.ny = grid.ny;
  current.dx = grid.lx / grid.nx;
  current.dy = grid.ly / grid.ny;
  current.time = t;
  current.u.resize(cells);
  current.v.resize(cells);
  {
    auto lock = impl_->runtime.exclusive();
    BufferLease out = impl_->runtime.buffers().acquire(2 * cells * sizeof(float));
    for (size_t a = 0; a < spec.layers.size(); ++a) {
      BufferLease fields = impl_->layer_pair(spec, a, t, impl_->evolve_current, {}, spectra_memory);
      impl_->accumulate_layer(fields.buffer(), spec.layers[a], 1, grid, a == 0, Impl::Layout::Planes, out.buffer());
    }
    ReadBack read(impl_->runtime);
    read.add(out.buffer(), 0, cells * sizeof(float), current.u.data());
    read.add(out.buffer(), cells * sizeof(float), cells * sizeof(float), current.v.data());
    read.wait();
  }
  for (size_t n = 0; n < cells; ++n) {
    current.u[n] += float(spec.layers[0].drift_x);
    current.v[n] += float(spec.layers[0].drift_y);
  }
  return current;
}

size_t OceanEngine::cached_spectra() const { return impl_->spectra.entries(); }
size_t OceanEngine::spectra_built() const { return size_t(impl_->spectra.computed()); }

uint64_t OceanEngine::new_spectra_bytes(const TileSpec& spec) const {
  uint64_t bytes = 0;
  for (size_t a = 0; a < spec.layers.size(); ++a)
    if (!impl_->spectra.holds(h0_key(spec, a))) bytes += spectrum_bytes(spec.layers[a]);
  return bytes;
}
std::vector<cl::Buffer> OceanEngine::kept_spectra(const TileSpec& spec) {
  std::vector<cl::Buffer> kept;
  for (size_t a = 0; a < spec.layers.size(); ++a)
    if (cl::Buffer h0 = impl_->spectra.kept(h0_key(spec, a)); h0()) kept.push_back(h0);
  return kept;
}
size_t OceanEngine::cached_spectrum_bytes() const { return impl_->spectra.bytes(); }

namespace {

// The whitecap map the frame at t starts from (W of the stream's previous frame, Gilligan sec. 5.3.3; zero
// without a matching stream) and its decay factor exp(-dt / T).
std::vector<float> previous_whitecaps(const TileSpec& spec, double t, const OutputGrid& grid,
                                      const WhitecapState* whitecaps, float* decay) {
  *decay = 0;
  if (!whitecaps || !whitecaps->matches(grid.nx, grid.ny)) return std::vector<float>(size_t(grid.nx) * grid.ny, 0.0f);
  double dt = t - whitecaps->last_t();
  if (dt < 0)
    fail(Code::InvalidArgument, "t = " + validate::number(t) + " precedes the previous frame (t = " +
                                    validate::number(whitecaps->last_t()) + ") of this whitecap stream");
  *decay = float(std::exp(-dt / spec.whitecap_decay));
  return whitecaps->map();
}

// The planes `planes` names (kAllPlanes bits) of the finalize kernel's output (kOutputPlanes planes of
// `cells`, in TileFields' order) into their TileFields views.
void read_outputs(Runtime& runtime, BufferLease out, size_t cells, unsigned planes, TileFields& result) {
  std::vector<FloatRange> ranges;
  for (int i = 0; i < kPlaneCount; ++i)
    if (planes & (1u << i)) ranges.push_back({size_t(i) * cells, cells});
  std::vector<FloatView> views = read_views(runtime, std::move(out), ranges);
  auto view = views.begin();
  for (int i = 0; i < kPlaneCount; ++i)
    if (planes & (1u << i)) result.*kTilePlanes[i] = std::move(*view++);
}

}  // namespace

TileFields OceanEngine::tile(const TileSpec& spec, double t, unsigned outputs, WhitecapState* whitecaps,
                             const Cancellation& cancel, unsigned planes, Slot* spectra_memory) {
  validate(spec);
  if (outputs == 0 || (outputs & ~kAllOutputs))
    fail(Code::InvalidArgument, "outputs = " + describe_outputs(outputs) + " must be a non-empty set of Output flags");
  validate::finite("t", t);
  const OutputGrid grid = output_grid(spec);
  const size_t cells = size_t(grid.nx) * size_t(grid.ny);
  const ChannelLayout layout = channel_layout(outputs);
  TileFields result;
  result.nx = grid.nx, result.ny = grid.ny, result.t = t;
  result.dx = grid.lx / grid.nx, result.dy = grid.ly / grid.ny;
  float decay = 0;
  std::vector<float> previous;
  if (outputs & Whitecaps) previous = previous_whitecaps(spec, t, grid, whitecaps, &decay);

  size_t work = cells;  // the finalize's cells and each layer's transformed ones
  for (const LayerSpec& L : spec.layers) work += size_t(L.nx) * size_t(L.ny) * size_t(layout.pairs);
  auto lock = impl_->runtime.exclusive({"ocean.tile", work});
  Runtime& runtime = impl_->runtime;
  // The sums of the layers' channels, interleaved complex arrays on the output grid. A first layer on that
  // grid (the default) is its own sum: its inverse FFT's output, to which the other layers are added.
  const LayerSpec& first = spec.layers.front();
  const bool in_place = first.nx == grid.nx && first.ny == grid.ny && first.lx == grid.lx && first.ly == grid.ly;
  BufferLease sums;
  if (!in_place) sums = runtime.buffers().acquire(size_t(2 * layout.pairs) * cells * sizeof(float));
  for (size_t a = 0; a < spec.layers.size(); ++a) {
    if (cancel.requested()) {    // before each layer; the first, once a queue is held after the wait for it
      runtime.queue().finish();  // the layers enqueued so far end before their buffers go back
      cancel.check("tile: before layer " + std::to_string(a));
    }
    // Back to the pool before the next layer's, but for a first layer that is the sums.
    BufferLease layer = impl_->layer_fields(spec, a, t, layout, cancel, spectra_memory);
    if (a == 0 && in_place)
      sums = std::move(layer);
    else
      impl_->accumulate_layer(layer.buffer(), spec.layers[a], layout.pairs, grid, a == 0, Impl::Layout::Interleaved,
                              sums.buffer());
  }
  const LayerSpec& last = spec.layers.back();
  impl_->look_between_stages(std::max(cells, size_t(last.nx) * size_t(last.ny)), cancel, "tile: the finalize");
  BufferLease out = runtime.buffers().acquire(kOutputPlanes * cells * sizeof(float));
  BufferLease whitecap = runtime.buffers().acquire(cells * sizeof(float));
  if (outputs & Whitecaps)
    runtime.queue().enqueueWriteBuffer(whitecap.buffer(), CL_FALSE, 0, cells * sizeof(float), previous.data());
  impl_->finalize.launch_rows(cells, 1, sums.buffer(), cl_int(cells), cl_int(2 * layout.pairs),
                              cl_int(layout.displaced ? 1 : 0), cl_float(spec.choppiness), cl_int(outputs),
                              cl_float(spec.whitecap_threshold), decay, whitecap.buffer(), out.buffer());
  read_outputs(runtime, std::move(out), cells, planes_of(outputs) & (planes | plane::bit(plane::Whitecaps)), result);
  lock.unlock();

  if ((outputs & Whitecaps) && whitecaps) {
    whitecaps->mutable_map() = result.whitecaps.to_vector();
    whitecaps->set(grid.nx, grid.ny, t);
  }
  result.unresolved_slope_variance = impl_->slope_variance(spec);
  return result;
}

namespace {
// A coordinate of a grid of n cells over a period of `extent`, in [0, n): reduced by whole periods first
// (fmod is exact), so that a point however far from the origin lands in the grid.
double periodic_cell(double x, double extent, int n) {
  double r = std::fmod(x, extent);
  if (r < 0) r += extent;
  return std::clamp(r / (extent / n), 0.0, std::nextafter(double(n), 0.0));
}

// The channels sample() reads at a point: the 8 real channels of the layers' pairs (height, D, slopes,
// grad D), then the gradient of the bilinear D itself, which the inversion steps along.
constexpr int kSampled = 12;
constexpr int kBilinearGradD = 8;  // dDx/dx, dDx/dy, dDy/dx, dDy/dy, 1/m

// Bilinear periodic sample of the 8 real channels of one layer (host copy of its complex pairs), and the
// gradient of its bilinear Dx and Dy, added to out[kSampled].
void sample_channels(const std::vector<float>& fields, const LayerSpec& L, double x, double y, double out[kSampled]) {
  const size_t nx = size_t(L.nx), ny = size_t(L.ny), cells = nx * ny;
  const double u = periodic_cell(x, L.lx, L.nx), v = periodic_cell(y, L.ly, L.ny);
  size_t i0 = size_t(u), j0 = size_t(v);
  double fu = u - i0, fv = v - j0;
  size_t i1 = (i0 + 1) % nx, j1 = (j0 + 1) % ny;
  for (int c = 0; c < 8; ++c) {
    auto at = [&](size_t i, size_t j) { return double(fields[2 * ((c / 2) * cells + i + nx * j) + (c % 2)]); };
    out[c] += (1 - fv) * ((1 - fu) * at(i0, j0) + fu * at(i1, j0)) + fv * ((1 - fu) * at(i0, j1) + fu * at(i1, j1));
    if (c != 1 && c != 2) continue;
    const double along_u = (1 - fv) * (at(i1, j0) - at(i0, j0)) + fv * (at(i1, j1) - at(i0, j1));
    const double along_v = (1 - fu) * (at(i0, j1) - at(i0, j0)) + fu * (at(i1, j1) - at(i1, j0));
    out[kBilinearGradD + 2 * (c - 1)] += along_u * L.nx / L.lx;
    out[kBilinearGradD + 2 * (c - 1) + 1] += along_v * L.ny / L.ly;
  }
}
}  // namespace

namespace {
constexpr uint64_t kLayerBytesPerCell = 4 * 2 * sizeof(float);  // sample(): 4 complex channel pairs

// A source x0 of query x on the surface displaced by lambda D (eq 47), searched from `start`: a root of
// F(x0) = x0 + lambda D(x0) - x by Newton's method, with the Jacobian I + lambda grad D of the bilinear D
// the samples read, each step halved until |F| shrinks; where no Newton step does (the Jacobian singular
// or nearly, where the surface folds), the fixed-point step -F. The fixed-point iteration
// x0 = x - lambda D(x0) alone converges only where both eigenvalues of lambda grad D lie within (-1, 1):
// it diverged at troughs (J > 2) and crept at crests (J near 0). Stops once |F| <= tolerance or neither
// step shrinks it (*size: |F| there); leaves in c what channels_at read at x0.
template <typename Channels>
Vec2 newton_source(const Channels& channels_at, Vec2 x, Vec2 start, double lambda, double tolerance, double c[kSampled],
                   double* size) {
  Vec2 x0 = start;
  channels_at(x0.x, x0.y, c);
  auto residual = [&](Vec2 p, const double* at) {
    return Vec2{p.x + lambda * at[1] - x.x, p.y + lambda * at[2] - x.y};
  };
  Vec2 F = residual(x0, c);
  // x0 moves along `step`, halved until |F| shrinks (at most 14 times); false where it never does.
  auto advance = [&](Vec2 step) {
    for (double scale = 1; scale > 1e-4; scale /= 2) {
      const Vec2 trial{x0.x + scale * step.x, x0.y + scale * step.y};
      double at[kSampled];
      channels_at(trial.x, trial.y, at);
      const Vec2 G = residual(trial, at);
      if (!(std::hypot(G.x, G.y) < std::hypot(F.x, F.y))) continue;
      x0 = trial, F = G;
      std::copy(at, at + kSampled, c);
      return true;
    }
    return false;
  };
  for (int iteration = 0; iteration < 64 && std::hypot(F.x, F.y) > tolerance; ++iteration) {
    const double* g = c + kBilinearGradD;
    const double a = 1 + lambda * g[0], b = lambda * g[1], d = lambda * g[2], e = 1 + lambda * g[3];
    const double det = a * e - b * d;  // of [[a, b], [d, e]]
    const bool newton = det != 0 && advance({(b * F.y - e * F.x) / det, (d * F.x - a * F.y) / det});
    if (!newton && !advance({-F.x, -F.y})) break;
  }
  *size = std::hypot(F.x, F.y);
  return x0;
}

// The source x0 of query x (newton_source from x). Past a fold the search from x can stall at a local
// minimum of |F| beside the fold, short of every source (0.3 to 2% of the points of a sea 1.3 to 1.6 times
// as choppy as its first fold): it starts again from x - lambda D(x), then from rings about x out to
// `reach`, the largest |lambda D| (every source lies that near), and keeps the first root, else the least |F|.
// The tolerance is at least what F's rounding in double allows at x. *searches: how many were made.
template <typename Channels>
Vec2 displaced_source(const Channels& channels_at, Vec2 x, double lambda, double tolerance, double reach,
                      double c[kSampled], int* searches) {
  tolerance = std::max(tolerance, 8 * DBL_EPSILON * (std::abs(x.x) + std::abs(x.y) + reach));
  double size = 0;
  Vec2 best = newton_source(channels_at, x, x, lambda, tolerance, c, &size);
  *searches = 1;
  if (size <= tolerance || !(reach > 0)) return best;
  constexpr int kRings = 6, kAngles = 16;
  double at[kSampled];
  channels_at(x.x, x.y, at);
  std::array<Vec2, 1 + kRings * kAngles> starts;
  starts[0] = {x.x - lambda * at[1], x.y - lambda * at[2]};
  for (int ring = 1; ring <= kRings; ++ring)
    for (int k = 0; k < kAngles; ++k) {
      const double r = reach * ring / kRings, angle = (k + 0.5 * (ring % 2)) * 2 * M_PI / kAngles;
      starts[size_t(1 + (ring - 1) * kAngles + k)] = {x.x + r * std::cos(angle), x.y + r * std::sin(angle)};
    }
  for (const Vec2& start : starts) {
    double again = 0;
    const Vec2 x0 = newton_source(channels_at, x, start, lambda, tolerance, at, &again);
    ++*searches;
    if (again >= size) continue;
    best = x0, size = again;
    std::copy(at, at + kSampled, c);
    if (size <= tolerance) break;
  }
  return best;
}

// The largest |D| of a layer's bilinear field (host copy of its complex pairs, as sample_channels reads
// them): at a node, as a bilinear value is a weighted mean of its cell's nodes.
double largest_displacement(const std::vector<float>& fields, const LayerSpec& L) {
  const size_t cells = size_t(L.nx) * size_t(L.ny);
  double largest = 0;
  for (size_t n = 0; n < cells; ++n)  // channel 1 (Dx) the imaginary part of pair 0, 2 (Dy) the real of pair 1
    largest = std::max(largest, std::hypot(double(fields[2 * n + 1]), double(fields[2 * (cells + n)])));
  return largest;
}

// 1e-6 of the finest layer's cell, m: where displaced_source stops.
double source_tolerance(const TileSpec& spec) {
  double cell = INFINITY;
  for (const LayerSpec& L : spec.layers) cell = std::min({cell, L.lx / L.nx, L.ly / L.ny});
  return 1e-6 * cell;
}

uint64_t largest_layer_cells(const TileSpec& spec) {
  uint64_t cells = 0;
  for (const LayerSpec& L : spec.layers) cells = std::max(cells, uint64_t(L.nx) * uint64_t(L.ny));
  return cells;
}
}  // namespace

uint64_t surface_device_bytes(const TileSpec& spec) { return largest_layer_cells(spec) * sizeof(cl_float2); }

uint64_t tile_device_bytes(const TileSpec& spec, unsigned outputs) {
  const OutputGrid grid = output_grid(spec);
  const uint64_t cells = uint64_t(grid.nx) * uint64_t(grid.ny);
  const uint64_t pair_bytes = uint64_t(channel_layout(outputs).pairs) * 2 * sizeof(float);
  const uint64_t planes = (kOutputPlanes + 1) * sizeof(float);  // the output planes and the whitecaps
  // On the output grid its planes and the sums (2 floats a pair: the first layer's transform, or
  // ocean_accumulate's buffer); a layer's pairs.
  return cells * (planes + pair_bytes) + largest_layer_cells(spec) * pair_bytes;
}

uint64_t sample_bytes(const TileSpec& spec) {
  uint64_t host = 0;
  for (const LayerSpec& L : spec.layers) host += uint64_t(L.nx) * uint64_t(L.ny) * kLayerBytesPerCell;
  return host + largest_layer_cells(spec) * kLayerBytesPerCell;
}

std::vector<SurfaceSample> OceanEngine::sample(const TileSpec& spec, double t, const std::vector<Vec2>& points,
                                               bool invert_displacement, const Cancellation& cancel,
                                               Slot* spectra_memory) {
  validate(spec);
  validate::finite("t", t);
  for (size_t i = 0; i < points.size(); ++i) {
    if (std::isfinite(points[i].x) && std::isfinite(points[i].y)) continue;  // names a point only when refusing it
    validate::finite(validate::at("points", i) + ".x", points[i].x);
    validate::finite(validate::at("points", i) + ".y", points[i].y);
  }
  std::vector<std::vector<float>> layers(spec.layers.size());
  {
    auto lock = impl_->runtime.exclusive();
    for (size_t a = 0; a < spec.layers.size(); ++a) {  // a layer's buffer goes back before the next is taken
      cancel.check("sample: before layer " + std::to_string(a));
      const LayerSpec& L = spec.layers[a];
      // Every channel, as sample_channels reads them.
      BufferLease fields = impl_->layer_fields(spec, a, t, {4, true}, cancel, spectra_memory);
      layers[a].resize(size_t(L.nx) * size_t(L.ny) * 8);
      read_back(impl_->runtime, fields.buffer(), layers[a].size() * sizeof(float), layers[a].data());
    }
  }
  const double lambda = spec.choppiness;
  auto channels_at = [&](double x, double y, double c[kSampled]) {
    std::fill(c, c + kSampled, 0.0);
    for (size_t a = 0; a < spec.layers.size(); ++a) sample_channels(layers[a], spec.layers[a], x, y, c);
  };
  std::vector<SurfaceSample> samples(points.size());
  const double tolerance = source_tolerance(spec);
  double reach = 0;  // of the displacement: |x - x0| at most
  for (size_t a = 0; invert_displacement && a < spec.layers.size(); ++a)
    reach += std::abs(lambda) * largest_displacement(layers[a], spec.layers[a]);
  uint64_t work = 0, next_check = 0;  // points read and searches made: a stalled inversion counts each
  for (size_t i = 0; i < points.size(); ++i) {
    if (work >= next_check) {
      cancel.check("sample: at points[" + std::to_string(i) + "]");
      next_check = work + kSamplesPerCheck;
    }
    double c[kSampled];
    SurfaceSample& s = samples[i];
    s.source = points[i];
    int searches = 1;
    if (invert_displacement)
      s.source = displaced_source(channels_at, points[i], lambda, tolerance, reach, c, &searches);
    else
      channels_at(s.source.x, s.source.y, c);
    work += uint64_t(searches);
    s.height = c[0];
    s.displacement_x = lambda * c[1];
    s.displacement_y = lambda * c[2];
    double Jxx = 1 + lambda * c[5], Jyy = 1 + lambda * c[6], Jxy = lambda * c[7];
    double tx[3] = {Jxx, Jxy, c[3]}, ty[3] = {Jxy, Jyy, c[4]};  // eq 94
    double n[3] = {tx[1] * ty[2] - tx[2] * ty[1], tx[2] * ty[0] - tx[0] * ty[2], tx[0] * ty[1] - tx[1] * ty[0]};
    double norm = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    s.normal_x = n[0] / norm;
    s.normal_y = n[1] / norm;
    s.normal_z = n[2] / norm;
  }
  return samples;
}

}  // namespace squall::ocean
