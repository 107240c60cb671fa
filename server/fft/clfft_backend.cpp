// clFFT, an OpenCL FFT library (J. Tessendorf, "Gilligan: A Prototype Framework for Simulating and
// Rendering Maritime Environments" (2017), sec. 4, plans its GPU FFTs with CUDA's library). Its kernels
// are generated and compiled when a plan is baked (clfftBakePlan); in-place and out-of-place are distinct
// clFFT plans, so each squall plan keeps both, baked on first use of each.
#include <clFFT.h>

#include <memory>
#include <mutex>

#include "common/error.h"
#include "fft/fft.h"
#include "runtime/runtime.h"

namespace squall::fft {
namespace {

void check(clfftStatus status, const std::string& what) {
  if (status != CLFFT_SUCCESS)
    fail(Code::Internal, "clfft: " + what + " failed (status " + std::to_string(status) + ")");
}

// clFFT factors each length into radices 2, 3, 5, 7, 11 and 13 only.
constexpr char kClfftLengths[] = "products of 2, 3, 5, 7, 11 and 13";
bool clfft_supports(size_t n) {
  for (size_t r : {2, 3, 5, 7, 11, 13})
    while (n % r == 0) n /= r;
  return n == 1;
}

// clFFT's global state: set up by the first backend, torn down when the last backend and its plans
// are gone (tearing down at exit instead would run before static plan caches are destroyed).
struct Library {
  Library() {
    clfftSetupData setup;
    check(clfftInitSetupData(&setup), "clfftInitSetupData");
    check(clfftSetup(&setup), "clfftSetup");
  }
  ~Library() { clfftTeardown(); }
};

std::shared_ptr<Library> library() {
  static std::mutex mutex;
  static std::weak_ptr<Library> current;
  std::lock_guard<std::mutex> lock(mutex);
  auto held = current.lock();
  if (!held) current = held = std::make_shared<Library>();
  return held;
}

// clFFT shares one cl_kernel between the plans of one size (its FFTRepo) and sets its arguments at each
// enqueue: plans of two device queues must not enqueue at once, nor one be destroyed while another enqueues.
std::mutex& repo_mutex() {
  static std::mutex mutex;
  return mutex;
}

class ClfftPlan : public Plan {
 public:
  ClfftPlan(Runtime& runtime, const PlanKey& key) : Plan(key), runtime_(runtime), library_(library()) {
    for (size_t n : {key.nx, key.ny})
      if (!clfft_supports(n))
        fail(Code::InvalidArgument, "clfft cannot plan " + describe(key) + ": " + std::to_string(n) +
                                        " is not one of its lengths, " + kClfftLengths);
    // Bake the out-of-place plan now so that unsupported combinations fail here, not per request.
    handle(false);
  }

  ~ClfftPlan() override {
    std::lock_guard<std::mutex> lock(repo_mutex());
    for (int i = 0; i < 2; ++i)
      if (baked_[i]) clfftDestroyPlan(&handles_[i]);
  }

  // The in-place plan is baked on first use; out of place is baked already.
  void prepare(Direction direction, bool in_place) override {
    check_direction(direction);
    handle(in_place && key().transform == Transform::C2C);
  }

  void enqueue(const cl::CommandQueue& queue, Direction direction, const cl::Buffer& in,
               const cl::Buffer& out) override {
    check_direction(direction);
    // An in-place R2C/C2R needs padded rows, which this layer does not use: such calls run out of place.
    bool in_place = in() == out() && key().transform == Transform::C2C;
    clfftPlanHandle plan = handle(in_place);
    cl_command_queue q = queue();
    cl_mem input = in(), output = out();
    std::lock_guard<std::mutex> lock(repo_mutex());
    check(clfftEnqueueTransform(plan, direction == Direction::Forward ? CLFFT_FORWARD : CLFFT_BACKWARD, 1, &q, 0,
                                nullptr, nullptr, &input, in_place ? nullptr : &output, nullptr),
          "clfftEnqueueTransform " + describe(key()));
  }

 private:
  clfftPlanHandle handle(bool in_place) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!baked_[in_place]) {
      handles_[in_place] = bake(in_place);
      baked_[in_place] = true;
    }
    return handles_[in_place];
  }

  clfftPlanHandle bake(bool in_place) {
    const PlanKey& k = key();
    clfftPlanHandle h;
    size_t lengths[2] = {k.nx, k.ny};
    check(clfftCreateDefaultPlan(&h, runtime_.context()(), CLFFT_2D, lengths), "clfftCreateDefaultPlan");
    check(clfftSetPlanPrecision(h, k.precision == Precision::F32 ? CLFFT_SINGLE : CLFFT_DOUBLE), "precision");
    check(clfftSetPlanBatchSize(h, k.batch), "batch size");
    check(clfftSetPlanScale(h, CLFFT_BACKWARD, 1.0f), "backward scale");  // unscaled, as FFTW
    size_t complex_row = k.transform == Transform::C2C ? k.nx : k.nx / 2 + 1;
    size_t real_strides[2] = {1, k.nx}, complex_strides[2] = {1, complex_row};
    size_t real_dist = k.nx * k.ny, complex_dist = complex_row * k.ny;
    switch (k.transform) {
      case Transform::C2C:
        check(clfftSetLayout(h, CLFFT_COMPLEX_INTERLEAVED, CLFFT_COMPLEX_INTERLEAVED), "layout");
        check(clfftSetPlanInStride(h, CLFFT_2D, complex_strides), "in stride");
        check(clfftSetPlanOutStride(h, CLFFT_2D, complex_strides), "out stride");
        check(clfftSetPlanDistance(h, complex_dist, complex_dist), "distance");
        break;
      case Transform::R2C:
        check(clfftSetLayout(h, CLFFT_REAL, CLFFT_HERMITIAN_INTERLEAVED), "layout");
        check(clfftSetPlanInStride(h, CLFFT_2D, real_strides), "in stride");
        check(clfftSetPlanOutStride(h, CLFFT_2D, complex_strides), "out stride");
        check(clfftSetPlanDistance(h, real_dist, complex_dist), "distance");
        break;
      case Transform::C2R:
        check(clfftSetLayout(h, CLFFT_HERMITIAN_INTERLEAVED, CLFFT_REAL), "layout");
        check(clfftSetPlanInStride(h, CLFFT_2D, complex_strides), "in stride");
        check(clfftSetPlanOutStride(h, CLFFT_2D, real_strides), "out stride");
        check(clfftSetPlanDistance(h, complex_dist, real_dist), "distance");
        break;
    }
    check(clfftSetResultLocation(h, in_place ? CLFFT_INPLACE : CLFFT_OUTOFPLACE), "placeness");
    cl_command_queue q = runtime_.queue()();
    check(clfftBakePlan(h, 1, &q, nullptr, nullptr), "clfftBakePlan " + describe(k));
    return h;
  }

  Runtime& runtime_;
  std::shared_ptr<Library> library_;
  std::mutex mutex_;
  clfftPlanHandle handles_[2] = {};  // [out of place, in place]
  bool baked_[2] = {false, false};
};

class ClfftBackend : public Backend {
 public:
  explicit ClfftBackend(Runtime& runtime) : runtime_(runtime), library_(library()) {}
  std::string name() const override { return "clfft"; }
  bool transforms(size_t n) const override { return clfft_supports(n); }
  std::string lengths() const override { return kClfftLengths; }
  std::unique_ptr<Plan> bake(const PlanKey& key) override { return std::make_unique<ClfftPlan>(runtime_, key); }

 private:
  Runtime& runtime_;
  std::shared_ptr<Library> library_;
};

}  // namespace

std::unique_ptr<Backend> make_clfft(Runtime& runtime) { return std::make_unique<ClfftBackend>(runtime); }

}  // namespace squall::fft
