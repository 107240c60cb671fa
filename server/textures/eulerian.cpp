#include "textures/eulerian.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "runtime/host_transfer.h"
#include "textures/counter_rng.h"
#include "textures/state_codec.h"

namespace squall::textures {
namespace {

constexpr uint32_t kStateVersion = 1;
constexpr double kTwoPi = 6.283185307179586;

// Layers and phases as the method sets them.
struct Schedule {
  std::vector<double> latencies;  // s per layer; infinite: never regenerated
  int phases = 1;
  PhaseWeight weight = PhaseWeight::Cosine;
};

Schedule schedule_of(const AdvectSpec& spec) {
  const EulerianParams& e = spec.eulerian;
  switch (spec.method) {
    case Method::TwoPhaseFlowMap: return {{e.latencies.front()}, 2, PhaseWeight::Triangle};
    case Method::Naive: return {{std::numeric_limits<double>::infinity()}, 1, PhaseWeight::Cosine};
    default: return {e.latencies, int(e.phases), e.weight};  // validated: 2..SQUALL_EULERIAN_MAX_PHASES
  }
}

// The noise bands the vorticity cascade turns (ADV03 sec. 4): those of a multi-layer request with c_w > 0.
int cascade_bands_of(const AdvectSpec& spec) {
  const bool on = spec.method == Method::EulerianMultilayer && spec.texture.kind == SQUALL_TEXTURE_NOISE &&
                  spec.eulerian.cascade.c_w > 0;
  return on ? spec.texture.bands : 0;
}

class Eulerian final : public Advection {
 public:
  Eulerian(Runtime& runtime, TextureKernels& kernels, const AdvectSpec& spec,
           std::shared_ptr<const DeviceInputs> inputs, std::string_view state, const Cancellation& cancel)
      : runtime_(runtime),
        kernels_(kernels),
        params_(spec.eulerian),
        schedule_(schedule_of(spec)),
        scale_(spec.texture.scale),
        t0_(spec.t0),
        dt_(spec.dt),
        substeps_(spec.substeps),
        inputs_(std::move(inputs)),
        nx_(params_.grid_nx),
        ny_(params_.grid_ny),
        cascade_bands_(cascade_bands_of(spec)),
        offset_rng_(spec.seed, RngPurpose::RegenerationOffset),
        random_offset_(params_.random_offset && spec.method != Method::Naive),
        cancel_(cancel) {
    const size_t bytes = state_floats() * sizeof(float);
    state_ = cl::Buffer(runtime_.context(), CL_MEM_READ_WRITE, bytes);
    scratch_ = cl::Buffer(runtime_.context(), CL_MEM_READ_WRITE, bytes);
    const size_t cascade_bytes = std::max<size_t>(cascade_floats(), 2) * sizeof(float);  // one float2 when off
    cascade_ = cl::Buffer(runtime_.context(), CL_MEM_READ_WRITE, cascade_bytes);
    cascade_scratch_ = cl::Buffer(runtime_.context(), CL_MEM_READ_WRITE, cascade_bytes);
    for (size_t i = 0; i < schedule_.latencies.size(); ++i)
      for (int j = 0; j < schedule_.phases; ++j)
        phase_start_.push_back(t0_ - j * schedule_.latencies[i] / schedule_.phases);
    first_start_ = phase_start_;
    if (state.empty()) {
      start_fresh();
    } else {
      restore(state);
    }
    offsets_ = cl::Buffer(runtime_.context(), CL_MEM_READ_ONLY, slots() * sizeof(cl_float2));
    upload_offsets();
  }

  TextureFrame next() override {
    std::vector<std::pair<std::string, double>> stages;
    auto start = std::chrono::steady_clock::now();
    if (started_) {
      for (int s = 0; s < substeps_; ++s) {
        cancel_.check("the advection");
        advance(t0_ + index_ * dt_ + s * dt_ / substeps_, dt_ / substeps_);
      }
      ++index_;
    }
    started_ = true;
    double advect_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    stages.emplace_back("advect", advect_ms);
    start = std::chrono::steady_clock::now();
    TextureFrame frame = render(t0_ + index_ * dt_);
    stages.emplace_back("reconstruct",
                        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    frame.stats.stage_ms = std::move(stages);
    return frame;
  }

  void steer(std::shared_ptr<const DeviceInputs> inputs, double dt, int substeps) override {
    inputs_ = std::move(inputs);
    t0_ += index_ * (dt_ - dt);  // keeps the frame time t0_ + index_ dt_
    dt_ = dt;
    substeps_ = substeps;
  }

  const DeviceInputs& inputs() const override { return *inputs_; }
  double time() const override { return t0_ + index_ * dt_; }

  // Version, started, index, phase starts, the slots' node state (state_floats()), then with the cascade its
  // (w_k, theta_k) per band and node (cascade_floats()).
  std::string checkpoint() const override {
    std::vector<float> values(state_floats());
    {
      auto lock = runtime_.exclusive();
      runtime_.queue().enqueueReadBuffer(state_, CL_TRUE, 0, values.size() * sizeof(float), values.data());
    }
    StateWriter out;
    out.put(kStateVersion);
    out.put(started_);
    out.put(int64_t(index_));
    out.put_vector(phase_start_);
    out.put_vector(values);
    if (cascade_bands_ > 0) out.put_vector(download_cascade());
    return out.take();
  }

 private:
  int slots() const { return int(schedule_.latencies.size()) * schedule_.phases; }
  size_t state_floats() const { return size_t(slots()) * nx_ * ny_ * 4; }
  size_t cascade_floats() const { return size_t(cascade_bands_) * nx_ * ny_ * 2; }
  double latency(int slot) const { return schedule_.latencies[slot / schedule_.phases]; }

  // The offset o of slot s's current phase: 0, or with random_offset uniform in [0, 1)^2 periods, a pure
  // function of (seed, slot, regeneration count) so that a resumed run draws the same.
  cl_float2 offset(int s) const {
    if (!random_offset_) return cl_float2{{0.0f, 0.0f}};
    const uint64_t generation = uint64_t(std::llround((phase_start_[s] - first_start_[s]) / latency(s)));
    const uint64_t counter = (uint64_t(s) << 48) + 2 * generation;
    return cl_float2{{float(offset_rng_.uniform(counter)), float(offset_rng_.uniform(counter + 1))}};
  }

  // Every slot's offset into offsets_ (at the start, and after a regeneration when they are random).
  void upload_offsets() {
    std::vector<cl_float2> o;
    for (int s = 0; s < slots(); ++s) o.push_back(offset(s));
    auto lock = runtime_.exclusive();
    runtime_.queue().enqueueWriteBuffer(offsets_, CL_TRUE, 0, o.size() * sizeof(cl_float2), o.data());
  }

  // Every slot at u = S x + o, d = 0, one slot at a time (one of 4096^2 nodes is 256 MiB on the host), and
  // the cascade at w_k = theta_k = 0.
  void start_fresh() {
    std::vector<float> slot(size_t(nx_) * ny_ * 4);
    for (int s = 0; s < slots(); ++s) {
      fresh_slot(slot, s);
      auto lock = runtime_.exclusive();
      runtime_.queue().enqueueWriteBuffer(state_, CL_TRUE, size_t(s) * slot.size() * sizeof(float),
                                          slot.size() * sizeof(float), slot.data());
    }
    if (cascade_floats() == 0) return;
    auto lock = runtime_.exclusive();
    runtime_.queue().enqueueFillBuffer(cascade_, cl_float(0), 0, cascade_floats() * sizeof(float));
    runtime_.queue().finish();
  }

  // u = S x + o, d = 0 at every node of slot s, into `values` (one slot's).
  void fresh_slot(std::vector<float>& values, int s) const {
    OutputGrid out = inputs_->output(1);
    double hx = out.pixel_x * out.width / (nx_ - 1), hy = out.pixel_y * out.height / (ny_ - 1);
    const cl_float2 o = offset(s);
    for (int j = 0; j < ny_; ++j) {
      if (j % 256 == 0) cancel_.check("the advection's start");  // a slot of 4096^2 nodes takes about 1 s
      for (int i = 0; i < nx_; ++i) {
        float* q = &values[4 * (size_t(j) * nx_ + i)];
        q[0] = float(scale_ * (out.x0 + i * hx)) + o.s[0];
        q[1] = float(scale_ * (out.y0 + j * hy)) + o.s[1];
        q[2] = q[3] = 0;
      }
    }
  }

  void upload_state(const std::vector<float>& values) {
    auto lock = runtime_.exclusive();
    runtime_.queue().enqueueWriteBuffer(state_, CL_TRUE, 0, values.size() * sizeof(float), values.data());
  }

  void upload_cascade(const std::vector<float>& values) {
    if (values.empty()) return;
    auto lock = runtime_.exclusive();
    runtime_.queue().enqueueWriteBuffer(cascade_, CL_TRUE, 0, values.size() * sizeof(float), values.data());
  }

  std::vector<float> download_cascade() const {
    std::vector<float> values(cascade_floats());
    auto lock = runtime_.exclusive();
    runtime_.queue().enqueueReadBuffer(cascade_, CL_TRUE, 0, values.size() * sizeof(float), values.data());
    return values;
  }

  void restore(std::string_view state) {
    StateReader in(state);
    if (in.get<uint32_t>("the version") != kStateVersion)
      fail(Code::InvalidArgument, "resume_state has an unknown version");
    started_ = in.get<bool>("started");
    index_ = in.frame_index(kMaxTextureFrames);
    phase_start_ = in.get_vector<double>("the phase starts");
    std::vector<float> values = in.get_finite_vector<float>("the node state", kMaxStateValue);
    std::vector<float> cascade = cascade_bands_ > 0 ? in.get_finite_vector<float>("the cascade") : std::vector<float>();
    if (!in.done() || values.size() != state_floats() || phase_start_.size() != size_t(slots()) ||
        cascade.size() != cascade_floats())
      fail(Code::InvalidArgument, "resume_state does not match this request's layers, phases, grid or cascade");
    // A slot that regenerates did so last within one latency before the frame's time (advance()); two are
    // allowed for rounding. Far from it, the phase weights would not be finite.
    for (int s = 0; s < slots(); ++s)
      if (std::isfinite(latency(s)) && !(std::abs(phase_start_[s] - time()) <= 2 * latency(s)))
        fail(Code::InvalidArgument, "resume_state holds the regeneration time " + validate::number(phase_start_[s]) +
                                        " s for slot " + std::to_string(s) +
                                        ", more than two latencies from its frame's time " + validate::number(time()) +
                                        " s: not a checkpoint of this request");
    upload_state(values);
    upload_cascade(cascade);
  }

  // The phase weight alpha^i_j of slot s at time t (ADV03 sec. 2.2; triangle for the flow map).
  double alpha(int s, double t) const {
    if (std::isinf(latency(s))) return 1;
    double age = (t - phase_start_[s]) / latency(s);
    age -= std::floor(age);
    if (schedule_.weight == PhaseWeight::Triangle) return 1 - std::abs(2 * age - 1);
    return (1 - std::cos(kTwoPi * age)) / schedule_.phases;
  }

  // One step [t, t + h]: slots whose phase ends by t + h are regenerated there.
  void advance(double t, double h) {
    cl_int reset = 0;
    for (int s = 0; s < slots(); ++s) {
      if (std::isinf(latency(s))) continue;
      // The whole latencies ended by t + h, at once: a loop over them may never end when a latency is
      // tiny against h or below the rounding of the phase start.
      const double ended = std::floor((t + h - phase_start_[s]) / latency(s) + 1e-9);
      if (ended >= 1) {
        phase_start_[s] += ended * latency(s);
        reset |= cl_int(1) << s;
      }
    }
    if (reset != 0 && random_offset_) upload_offsets();
    auto lock = runtime_.exclusive();
    kernels_.eulerian_advect.launch(cl::NDRange(nx_, ny_), cl::NullRange, state_, scratch_, cl_int(nx_), cl_int(ny_),
                                    inputs_->output(1), cl_int(slots()), inputs_->velocity(t, h), inputs_->grid(),
                                    cl_float(h), cl_float(scale_), reset, offsets_);
    std::swap(state_, scratch_);
    if (cascade_bands_ > 0) advance_cascade(t, h);
  }

  // The vorticity cascade's step [t, t + h] (ADV03 sec. 4); the caller holds runtime_.exclusive().
  void advance_cascade(double t, double h) {
    const VorticityCascade& c = params_.cascade;
    kernels_.eulerian_cascade.launch(cl::NDRange(nx_, ny_), cl::NullRange, cascade_, cascade_scratch_, cl_int(nx_),
                                     cl_int(ny_), inputs_->output(1), cl_int(cascade_bands_), cl_float(c.c_w),
                                     cl_float(c.tau), cl_float(c.tau_ratio), inputs_->velocity(t, h), inputs_->grid(),
                                     cl_float(h));
    std::swap(cascade_, cascade_scratch_);
  }

  TextureFrame render(double t) {
    OutputGrid out = inputs_->output(1);
    TextureSource texture = inputs_->texture(t);
    TextureFrame frame = empty_frame(index_, t, out, texture);
    std::vector<float> weights;
    for (int s = 0; s < slots(); ++s) weights.push_back(float(alpha(s, t)));
    BufferLease planes = runtime_.buffers().acquire(frame.planes.size() * sizeof(float));  // reused frame to frame
    cl::Buffer alphas(runtime_.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, weights.size() * sizeof(float),
                      weights.data());
    {
      auto lock = runtime_.exclusive();
      kernels_.eulerian_render.launch(
          cl::NDRange(out.width, out.height), cl::NullRange, planes.buffer(), out, state_, cl_int(nx_), cl_int(ny_),
          cl_int(schedule_.latencies.size()), cl_int(schedule_.phases), alphas,
          cl_int(params_.deformation == DeformationSum::Paper ? 1 : 0), cl_float(params_.d_star),
          cl_int(int(params_.blend)), texture, inputs_->image(), inputs_->scalar(), inputs_->lut(),
          inputs_->velocity(t, 0), inputs_->mask(), cascade_, cl_int(cascade_bands_));
      read_back(runtime_, planes.buffer(), frame.planes.size() * sizeof(float), frame.planes.data());
    }
    frame.stats = frame_stats(frame);
    return frame;
  }

  Runtime& runtime_;
  TextureKernels& kernels_;
  EulerianParams params_;
  Schedule schedule_;
  double scale_, t0_, dt_;
  int substeps_;
  std::shared_ptr<const DeviceInputs> inputs_;
  int nx_, ny_;
  int cascade_bands_;      // noise bands of the vorticity cascade; 0: off
  CounterRng offset_rng_;  // the regeneration offsets (random_offset_)
  bool random_offset_;
  Cancellation cancel_;                   // whether the caller still wants the advection
  cl::Buffer state_, scratch_;            // float4 per slot and node: u.x, u.y, d, 0
  cl::Buffer cascade_, cascade_scratch_;  // float2 per band and node (band-major): w_k, theta_k
  cl::Buffer offsets_;                    // float2 per slot: the offset o of its current phase
  // The state a checkpoint holds (with state_'s and cascade_'s contents):
  bool started_ = false;
  int index_ = 0;
  std::vector<double> phase_start_;  // t0^i_j per slot: the time of its last regeneration
  std::vector<double> first_start_;  // t0^i_j per slot at frame 0 (the regeneration count's origin)
};

}  // namespace

std::unique_ptr<Advection> make_eulerian(Runtime& runtime, TextureKernels& kernels, const AdvectSpec& spec,
                                         std::shared_ptr<const DeviceInputs> inputs, std::string_view state,
                                         const Cancellation& cancel) {
  return std::make_unique<Eulerian>(runtime, kernels, spec, std::move(inputs), state, cancel);
}

}  // namespace squall::textures
