#include "textures/eulerian.h"

#include <chrono>
#include <cmath>
#include <limits>

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
    default: return {e.latencies, e.phases, e.weight};
  }
}

class Eulerian final : public Advection {
 public:
  Eulerian(Runtime& runtime, TextureKernels& kernels, const AdvectSpec& spec,
           std::shared_ptr<const DeviceInputs> inputs, const std::string& state)
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
        ny_(params_.grid_ny) {
    const size_t bytes = state_floats() * sizeof(float);
    state_ = cl::Buffer(runtime_.context(), CL_MEM_READ_WRITE, bytes);
    scratch_ = cl::Buffer(runtime_.context(), CL_MEM_READ_WRITE, bytes);
    for (size_t i = 0; i < schedule_.latencies.size(); ++i)
      for (int j = 0; j < schedule_.phases; ++j)
        phase_start_.push_back(t0_ - j * schedule_.latencies[i] / schedule_.phases);
    if (state.empty()) {
      std::vector<float> fresh(state_floats());
      for (int s = 0; s < slots(); ++s) fresh_slot(fresh, s);
      upload_state(fresh);
    } else {
      restore(state);
    }
  }

  TextureFrame next() override {
    std::vector<std::pair<std::string, double>> stages;
    auto start = std::chrono::steady_clock::now();
    if (started_) {
      for (int s = 0; s < substeps_; ++s) advance(t0_ + index_ * dt_ + s * dt_ / substeps_, dt_ / substeps_);
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

  std::string checkpoint() const override {
    std::vector<float> values(state_floats());
    {
      auto lock = runtime_.exclusive();
      runtime_.queue().enqueueReadBuffer(state_, CL_TRUE, 0, values.size() * sizeof(float), values.data());
    }
    StateWriter out;
    out.put(kStateVersion);
    out.put(uint8_t(started_));
    out.put(int64_t(index_));
    out.put_vector(phase_start_);
    out.put_vector(values);
    return out.take();
  }

 private:
  int slots() const { return int(schedule_.latencies.size()) * schedule_.phases; }
  size_t state_floats() const { return size_t(slots()) * nx_ * ny_ * 4; }
  double latency(int slot) const { return schedule_.latencies[slot / schedule_.phases]; }

  // u = S x, d = 0 at every node of slot s.
  void fresh_slot(std::vector<float>& values, int s) const {
    OutputGrid out = inputs_->output(1);
    double hx = out.pixel_x * out.width / (nx_ - 1), hy = out.pixel_y * out.height / (ny_ - 1);
    for (int j = 0; j < ny_; ++j) {
      for (int i = 0; i < nx_; ++i) {
        float* q = &values[4 * ((size_t(s) * ny_ + j) * nx_ + i)];
        q[0] = float(scale_ * (out.x0 + i * hx));
        q[1] = float(scale_ * (out.y0 + j * hy));
        q[2] = q[3] = 0;
      }
    }
  }

  void upload_state(const std::vector<float>& values) {
    auto lock = runtime_.exclusive();
    runtime_.queue().enqueueWriteBuffer(state_, CL_TRUE, 0, values.size() * sizeof(float), values.data());
  }

  void restore(const std::string& state) {
    StateReader in(state);
    if (in.get<uint32_t>() != kStateVersion) fail(Code::InvalidArgument, "resume_state has an unknown version");
    started_ = in.get<uint8_t>() != 0;
    index_ = int(in.get<int64_t>());
    phase_start_ = in.get_vector<double>();
    std::vector<float> values = in.get_vector<float>();
    if (!in.done() || values.size() != state_floats() || phase_start_.size() != size_t(slots()))
      fail(Code::InvalidArgument, "resume_state does not match this request's layers, phases or grid");
    upload_state(values);
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
      while (t + h - phase_start_[s] >= latency(s) * (1 - 1e-9)) {
        phase_start_[s] += latency(s);
        reset |= cl_int(1) << s;
      }
    }
    auto lock = runtime_.exclusive();
    kernels_.eulerian_advect.launch(cl::NDRange(nx_, ny_), cl::NullRange, state_, scratch_, cl_int(nx_), cl_int(ny_),
                                    inputs_->output(1), cl_int(slots()), inputs_->velocity(t), inputs_->grid(),
                                    cl_float(t), cl_float(h), cl_float(scale_), reset);
    std::swap(state_, scratch_);
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
          cl_int(int(params_.blend)), texture, inputs_->image(), inputs_->velocity(t), inputs_->mask());
      runtime_.queue().enqueueReadBuffer(planes.buffer(), CL_TRUE, 0, frame.planes.size() * sizeof(float),
                                         frame.planes.data());
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
  cl::Buffer state_, scratch_;  // float4 per slot and node: u.x, u.y, d, 0
  // The state a checkpoint holds (with state_'s contents):
  bool started_ = false;
  int index_ = 0;
  std::vector<double> phase_start_;  // t0^i_j per slot: the time of its last regeneration
};

}  // namespace

std::unique_ptr<Advection> make_eulerian(Runtime& runtime, TextureKernels& kernels, const AdvectSpec& spec,
                                         std::shared_ptr<const DeviceInputs> inputs, const std::string& state) {
  return std::make_unique<Eulerian>(runtime, kernels, spec, std::move(inputs), state);
}

}  // namespace squall::textures
