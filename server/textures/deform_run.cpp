// A running content-aware deformation (G. Guingo, F. Larue, B. Sauvage, N. Lutz, J.-M. Dischler, M.-P. Cani,
// "Content-aware texture deformation with dynamic control", Computers & Graphics 91, 2020): per frame one
// deform_step (sec. 3.3 eq. 5, sec. 5, App. B), then the colour (eqs. 13-14) and the planes asked for.
#include "textures/deform_run.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

#include "runtime/slices.h"
#include "textures/deform_control.h"
#include "textures/deform_validate.h"

namespace squall::textures {
namespace {

constexpr int kStackStepsPerUnit = 32;  // midpoint steps per unit of reference time of the stack's W*_h
// The per-texel kernels run in work-groups of kTexelGroup texels (one size: PoCL compiles a kernel for each
// work-group size), in slices of such groups; the first slice kFirstSliceGroups of them.
constexpr size_t kTexelGroup = 64, kFirstSliceGroups = 1024;

size_t chunks(size_t n) { return (n + kDeformChunk - 1) / kDeformChunk; }

class DeformRun final : public Deformation {
 public:
  DeformRun(Runtime& runtime, std::shared_ptr<DeformKernels> kernels, std::shared_ptr<const FlowField> flow,
            const DeformSpec& spec, const Cancellation& cancel)
      : runtime_(runtime),
        k_(std::move(kernels)),
        flow_(std::move(flow)),
        w_(spec.width),
        h_(spec.height),
        n_(size_t(w_) * h_),
        channels_(spec.channels),
        levels_(spec.stack_levels),
        substeps_(spec.substeps),
        dt_(spec.dt),
        control_(spec),
        cancel_(cancel) {
    allocate();
    upload_control(spec.control);
    const size_t level0 = size_t(levels_) * channels_ * n_ * sizeof(float);
    QueueLease lease = runtime_.exclusive();
    runtime_.queue().enqueueWriteBuffer(images_, CL_TRUE, level0, spec.pixels.size() * sizeof(float),
                                        spec.pixels.data());
    if (levels_ > 0)
      each_texel(lease, "textures.deform_stack", [&](const cl::NDRange& first, const cl::NDRange& count) {
        k_->stack_build.launch_region(first, count, cl::NDRange(kTexelGroup), flow_->buffer, cl_int(w_), cl_int(h_),
                                      cl_int(channels_), cl_int(levels_), cl_int(kStackStepsPerUnit), images_);
      });
  }

  DeformFrame next(const DeformPlanes& planes) override {
    if (started_) step(control_.advance(++index_));
    started_ = true;
    return frame(planes);
  }

  void steer(const DeformControl& control, const std::string& path) override {
    const std::string prefix = path.empty() ? "" : path + ".";
    validate_control(control, w_, h_, prefix, "deformation");
    if (control.kind == DeformControlKind::Anisotropic)
      validate_anisotropic_step(control_.next_deformation(control.deformation_start), prefix + "deformation",
                                "the next frame");
    upload_control(control);
    control_.steer(control);
  }

  const FlowSolve& flow() const override { return flow_->solve; }

  uint64_t device_bytes() const override { return flow_->bytes() + held_bytes_; }

 private:
  // launch(first, count) over every texel, in slices of work-groups run under `lease`, asking the
  // cancellation between them: a 4096^2 step of 100 substeps, or a stack's build, holds a CPU device for
  // seconds. The last slice's ids run past the texels, which the kernels skip.
  void each_texel(QueueLease& lease, const char* site,
                  const std::function<void(const cl::NDRange&, const cl::NDRange&)>& launch) {
    const size_t groups = (n_ + kTexelGroup - 1) / kTexelGroup;
    const SlicePlan plan{groups, kTexelGroup, [](size_t) { return 1.0; }, double(kFirstSliceGroups),
                         WorkKind{site, n_}};
    run_sliced(runtime_, lease, plan, cancel_, "the deformation",
               [&](size_t first, size_t count) { launch(cl::NDRange(first), cl::NDRange(count)); });
  }

  cl::Buffer buffer(size_t bytes) {
    held_bytes_ += bytes;
    return cl::Buffer(runtime_.context(), CL_MEM_READ_WRITE, bytes);
  }

  // The state, zero: w = 0, t* = 0, and with the stack w* = 0, h = 0.
  void allocate() {
    images_ = buffer(size_t(2 * levels_ + 1) * channels_ * n_ * sizeof(float));
    warp_ = buffer(n_ * sizeof(cl_float2));
    reference_ = buffer(n_ * sizeof(float));
    stats_ = buffer(chunks(n_) * sizeof(cl_float4));
    out_ = buffer(size_t(channels_) * n_ * sizeof(float));
    residual_ = levels_ > 0 ? buffer(n_ * sizeof(cl_float2)) : k_->none;
    level_ = levels_ > 0 ? buffer(n_ * sizeof(cl_int)) : k_->none;
    auto lock = runtime_.exclusive();
    for (const cl::Buffer* b : {&warp_, &reference_, &residual_, &level_})
      if (b->get() != k_->none.get()) runtime_.queue().enqueueFillBuffer(*b, cl_uchar(0), 0, b->getInfo<CL_MEM_SIZE>());
  }

  // The map and the strokes of a control on the device (kept until the next steer).
  void upload_control(const DeformControl& control) {
    std::vector<cl_float4> strokes;
    for (const BrushStroke& s : control.strokes)
      strokes.push_back({{float(s.center_x), float(s.center_y), float(s.radius), float(s.strength)}});
    auto lock = runtime_.exclusive();
    if (control.kind == DeformControlKind::Map) {
      if (map_.get() == k_->none.get()) map_ = buffer(n_ * sizeof(float));
      runtime_.queue().enqueueWriteBuffer(map_, CL_TRUE, 0, n_ * sizeof(float), control.d_mu_map.data());
    }
    stroke_count_ = int(strokes.size());
    if (strokes.empty()) return;
    const size_t bytes = strokes.size() * sizeof(cl_float4);
    if (strokes_.get() == k_->none.get() || strokes_.getInfo<CL_MEM_SIZE>() < bytes) {
      if (strokes_.get() != k_->none.get()) held_bytes_ -= strokes_.getInfo<CL_MEM_SIZE>();
      strokes_ = buffer(bytes);
    }
    runtime_.queue().enqueueWriteBuffer(strokes_, CL_TRUE, 0, bytes, strokes.data());
  }

  void step(const StepControl& c) {
    const Tensor2& t = c.t_minus_identity;
    const cl_float4 tensor{{float(t.xx), float(t.xy), float(t.yx), float(t.yy)}};
    QueueLease lease;
    each_texel(lease, "textures.deform_step", [&](const cl::NDRange& first, const cl::NDRange& count) {
      k_->step.launch_region(first, count, cl::NDRange(kTexelGroup), flow_->buffer, cl_int(w_), cl_int(h_), warp_,
                             reference_, cl_int(substeps_), cl_int(c.kind), cl_float(c.d_mu), cl_float(c.kappa), tensor,
                             map_, strokes_, cl_int(stroke_count_), cl_int(levels_), residual_, level_);
    });
  }

  DeformFrame frame(const DeformPlanes& planes) {
    DeformFrame f;
    f.index = index_;
    f.time = index_ * dt_;
    f.width = w_;
    f.height = h_;
    auto lock = runtime_.exclusive();
    stats(f);
    if (planes.color) color(f.planes);
    if (planes.warp) append_pairs(warp_, f.planes);
    if (planes.reference) append(reference_, f.planes);
    if (planes.level) append_levels(f.planes);
    if (planes.flow) deinterleave(flow_->v, f.planes);
    return f;
  }

  // Max |w|, max |w*| and the range of t* (the caller holds the device).
  void stats(DeformFrame& f) {
    const size_t count = chunks(n_);
    k_->stats.launch(cl::NDRange(count), cl::NullRange, warp_, residual_, reference_, cl_int(n_), cl_int(levels_),
                     stats_);
    std::vector<cl_float4> partial(count);
    runtime_.queue().enqueueReadBuffer(stats_, CL_TRUE, 0, count * sizeof(cl_float4), partial.data());
    f.min_reference = std::numeric_limits<double>::infinity();
    f.max_reference = -f.min_reference;
    for (const cl_float4& p : partial) {
      f.max_warp = std::max(f.max_warp, double(p.s[0]));
      f.max_residual = std::max(f.max_residual, double(p.s[1]));
      f.min_reference = std::min(f.min_reference, double(p.s[2]));
      f.max_reference = std::max(f.max_reference, double(p.s[3]));
    }
  }

  void color(std::vector<float>& planes) {
    k_->color.launch(cl::NDRange(n_), cl::NullRange, images_, cl_int(channels_), cl_int(w_), cl_int(h_), warp_,
                     cl_int(levels_), residual_, level_, out_);
    const size_t at = planes.size();
    planes.resize(at + size_t(channels_) * n_);
    runtime_.queue().enqueueReadBuffer(out_, CL_TRUE, 0, size_t(channels_) * n_ * sizeof(float), &planes[at]);
  }

  void append(const cl::Buffer& b, std::vector<float>& planes) {
    const size_t at = planes.size();
    planes.resize(at + n_);
    runtime_.queue().enqueueReadBuffer(b, CL_TRUE, 0, n_ * sizeof(float), &planes[at]);
  }

  void append_pairs(const cl::Buffer& b, std::vector<float>& planes) {
    std::vector<float> pairs(2 * n_);
    runtime_.queue().enqueueReadBuffer(b, CL_TRUE, 0, pairs.size() * sizeof(float), pairs.data());
    deinterleave(pairs, planes);
  }

  void append_levels(std::vector<float>& planes) {
    std::vector<cl_int> h(n_, 0);
    if (levels_ > 0) runtime_.queue().enqueueReadBuffer(level_, CL_TRUE, 0, n_ * sizeof(cl_int), h.data());
    planes.insert(planes.end(), h.begin(), h.end());
  }

  void deinterleave(const std::vector<float>& pairs, std::vector<float>& planes) const {
    const size_t at = planes.size();
    planes.resize(at + 2 * n_);
    for (size_t t = 0; t < n_; ++t) {
      planes[at + t] = pairs[2 * t];
      planes[at + n_ + t] = pairs[2 * t + 1];
    }
  }

  Runtime& runtime_;
  std::shared_ptr<DeformKernels> k_;
  std::shared_ptr<const FlowField> flow_;
  const int w_, h_;
  const size_t n_;
  const int channels_, levels_, substeps_;
  const double dt_;
  ControlState control_;
  Cancellation cancel_;  // whether the caller still wants the deformation
  int index_ = 0;
  bool started_ = false;
  int stroke_count_ = 0;
  uint64_t held_bytes_ = 0;  // every buffer below but `none`
  // Device state (layouts in deform.cl): images (2L + 1) x channels x W H floats, level h at h + L;
  // warp, residual float2 per texel; reference float; level int; map float (MAP); strokes float4
  // (cx, cy, radius, strength); stats float4 per chunk; out channels x W H floats.
  cl::Buffer images_, warp_, reference_, residual_, level_, stats_, out_;
  cl::Buffer map_ = k_->none, strokes_ = k_->none;
};

}  // namespace

uint64_t DeformEngine::working_bytes(const DeformSpec& spec) {
  const uint64_t n = uint64_t(spec.width) * uint64_t(spec.height), channels = uint64_t(spec.channels);
  const uint64_t levels = uint64_t(std::max<int64_t>(0, spec.stack_levels)), stacked = levels > 0 ? 1 : 0;
  // DeformRun::allocate(): the images, warp, reference, output, and with a stack the residual and levels.
  const uint64_t state = 4 * (2 * levels + 1) * channels * n + 8 * n + 4 * n + 4 * channels * n + stacked * 12 * n +
                         16 * chunks(size_t(n));
  const uint64_t frame = 4 * channels * n + 12 * n;  // the output, warp and reference read back
  // v on the host and the device, and a kept solve's key (the rigidity and the chart), which the flow cache
  // takes from the stream's reservation with the flow
  const uint64_t flow = 2 * 8 * n + 4 * n + uint64_t(spec.chart.size());
  const uint64_t map = spec.control.d_mu_map.empty() ? 0 : map_bytes(spec);
  return state + frame + flow + map + solve_bytes(spec);
}

uint64_t DeformEngine::solve_bytes(const DeformSpec& spec) {
  const uint64_t n = uint64_t(spec.width) * uint64_t(spec.height);
  // x, s, p, x_best; r, q; b (double); the free texels on the host and the device; x zeroed from the host
  return 8 * (4 * 2 * n + 2 * n + n) + 2 * n + 8 * 2 * n;
}

uint64_t DeformEngine::map_bytes(const DeformSpec& spec) {
  const uint64_t n = uint64_t(spec.width) * uint64_t(spec.height);
  return 4 * n + (spec.control.kind == DeformControlKind::Map ? 4 * n : 0);  // the control's copy; the device's
}

std::unique_ptr<Deformation> make_deformation(Runtime& runtime, std::shared_ptr<DeformKernels> kernels,
                                              std::shared_ptr<const FlowField> flow, const DeformSpec& spec,
                                              const Cancellation& cancel) {
  return std::make_unique<DeformRun>(runtime, std::move(kernels), std::move(flow), spec, cancel);
}

}  // namespace squall::textures
