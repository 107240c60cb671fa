#include "textures/texture_engine.h"

#include <cmath>

#include "runtime/host_transfer.h"
#include "textures/eulerian.h"
#include "textures/lagrangian.h"

namespace squall::textures {
namespace {

constexpr int kStatsResolution = 256;  // texels per period when the stats of a procedural texture are measured

void render_window(Runtime& runtime, TextureKernels& kernels, TextureFrame& frame, const OutputGrid& out, double scale,
                   const TextureSource& texture, const DeviceInputs& inputs) {
  const size_t bytes = frame.planes.size() * sizeof(float);
  auto lock = runtime.exclusive();
  BufferLease planes = runtime.buffers().acquire(bytes);
  kernels.texture_window.launch(cl::NDRange(out.width, out.height), cl::NullRange, planes.buffer(), out,
                                cl_float(scale), texture, inputs.image(), inputs.scalar(), inputs.lut());
  read_back(runtime, planes.buffer(), bytes, frame.planes.data());
}

}  // namespace

TextureEngine::TextureEngine(Runtime& runtime, const LimitGate& gate)
    : runtime_(runtime), gate_(gate), kernels_(runtime) {}

std::unique_ptr<Advection> TextureEngine::start(const AdvectSpec& spec, std::string_view resume_state,
                                                const Cancellation& cancel) {
  auto inputs = std::make_shared<const DeviceInputs>(runtime_, spec, reference_stats(spec.texture));
  if (spec.method == Method::LagrangianGrids) return make_lagrangian(runtime_, kernels_, spec, inputs, resume_state, cancel);
  return make_eulerian(runtime_, kernels_, spec, inputs, resume_state, cancel);
}

uint64_t TextureEngine::state_bytes(const AdvectSpec& spec) {
  if (spec.method == Method::LagrangianGrids) {
    const uint64_t vertices = uint64_t(spec.lagrangian.grid_res) * uint64_t(spec.lagrangian.grid_res);
    constexpr uint64_t kBytesPerVertex = 40;  // host: position, u, weight; device: position, u, weight
    constexpr uint64_t kBytesPerTileEntry = 2 * sizeof(cl_int);  // a frame's tile lists, on the host and the device
    return uint64_t(lagrangian_grid_bound(spec)) * vertices * kBytesPerVertex +
           lagrangian_tile_bound(spec.lagrangian, spec.output) * kBytesPerTileEntry;
  }
  return 3 * (eulerian_slot_bytes(spec) + eulerian_cascade_bytes(spec));
}

uint64_t TextureEngine::input_bytes(const AdvectSpec& spec) {
  const TextureSpec& t = spec.texture;
  const uint64_t texture = 2 * sizeof(float) * (t.pixels.size() + t.lut.table.size() + t.lut.field.values.size());
  uint64_t grid = spec.velocity.mask.size();
  for (const VelocityFrame& f : spec.velocity.frames) grid += sizeof(float) * (f.u.size() + f.v.size());
  return texture + kVelocityCopies * grid;
}

namespace {

uint64_t eulerian_nodes(const AdvectSpec& spec) {
  if (spec.method == Method::LagrangianGrids) return 0;
  return uint64_t(spec.eulerian.grid_nx) * uint64_t(spec.eulerian.grid_ny);
}

}  // namespace

uint64_t TextureEngine::eulerian_slot_bytes(const AdvectSpec& spec) {
  const EulerianParams& e = spec.eulerian;
  const uint64_t slots = spec.method == Method::Naive             ? 1
                         : spec.method == Method::TwoPhaseFlowMap ? 2
                                                                  : uint64_t(e.latencies.size()) * uint64_t(e.phases);
  return eulerian_nodes(spec) * slots * 4 * sizeof(float);
}

uint64_t TextureEngine::eulerian_cascade_bytes(const AdvectSpec& spec) {
  const bool cascade = spec.method == Method::EulerianMultilayer && spec.eulerian.cascade.c_w > 0;
  return cascade ? eulerian_nodes(spec) * uint64_t(spec.texture.bands) * 2 * sizeof(float) : 0;
}

void TextureEngine::steer(Advection& advection, const AdvectSpec& spec) {
  advection.steer(advection.inputs().steered(runtime_, spec, advection.time()), spec.dt, spec.substeps);
}

TextureFrame TextureEngine::window(const AdvectSpec& spec) { return window(spec, reference_stats(spec.texture)); }

TextureFrame TextureEngine::window(const AdvectSpec& spec, const ReferenceStats& stats) {
  DeviceInputs inputs(runtime_, spec, stats);
  OutputGrid out = inputs.output(1);
  TextureSource texture = inputs.texture(spec.t0);
  TextureFrame frame = empty_frame(0, spec.t0, out, texture);
  render_window(runtime_, kernels_, frame, out, spec.texture.scale, texture, inputs);
  frame.stats = frame_stats(frame);
  return frame;
}

ReferenceStats TextureEngine::reference_stats(const TextureSpec& texture) {
  if (texture.kind == SQUALL_TEXTURE_IMAGE) return image_stats(texture);
  AdvectSpec one_period;
  one_period.texture = texture;
  one_period.texture.scale = 1;
  one_period.output = {kStatsResolution, kStatsResolution, 0, 0, 1, 1};
  TextureFrame frame = window(one_period, ReferenceStats{});  // rendering R itself blends nothing: no Rhat needed
  ReferenceStats stats;
  const size_t n = size_t(frame.width) * frame.height;
  for (int c = 0; c < frame.raw_planes; ++c) {
    const float* plane = frame.plane(frame.final_planes + c);
    double sum = 0, sum2 = 0;
    for (size_t k = 0; k < n; ++k) {
      sum += plane[k];
      sum2 += double(plane[k]) * plane[k];
    }
    stats.mean.push_back(sum / n);
    stats.variance.push_back(std::max(0.0, sum2 / n - (sum / n) * (sum / n)));
  }
  return stats;
}

}  // namespace squall::textures
