// VkFFT through its OpenCL backend (VKFFT_BACKEND 3). VkFFT generates and compiles its kernels when a
// plan is initialized, so a plan is baked once per key and kept by squall::fft::Fft.
#define VKFFT_BACKEND 3
#include <vkFFT.h>

#include "common/error.h"
#include "fft/fft.h"
#include "runtime/runtime.h"

namespace squall::fft {
namespace {

class VkfftPlan : public Plan {
 public:
  VkfftPlan(Runtime& runtime, const PlanKey& key) : Plan(key), runtime_(runtime) {
    device_ = runtime.device()();
    context_ = runtime.context()();
    platform_ = runtime.platform()();
    buffer_bytes_ = key.complex_bytes();
    input_bytes_ = key.real_bytes();

    VkFFTConfiguration config = {};
    config.FFTdim = 2;
    config.size[0] = key.nx;
    config.size[1] = key.ny;
    config.numberBatches = key.batch;
    config.device = &device_;
    config.context = &context_;
    config.platform = &platform_;
    config.bufferSize = &buffer_bytes_;
    config.doublePrecision = key.precision == Precision::F64;
    // VkFFT's default twiddles (on-the-fly sincos) meet the 1e-6 relative L2 bound of tests/fft on PoCL;
    // useLUT = 1 (tables computed in double) passes too and timed the same (bench/fft_bench).
    if (key.transform != Transform::C2C) {
      // Real data lives unpadded in inputBuffer; the half spectrum in buffer. The inverse returns to
      // inputBuffer, so one plan serves R2C (forward) and C2R (inverse).
      config.performR2C = 1;
      config.isInputFormatted = 1;
      config.inverseReturnToInputBuffer = 1;
      config.inputBufferSize = &input_bytes_;
      config.inputBufferStride[0] = key.nx;
      config.inputBufferStride[1] = key.nx * key.ny;
      config.bufferStride[0] = key.nx / 2 + 1;
      config.bufferStride[1] = (key.nx / 2 + 1) * key.ny;
    }
    VkFFTResult result = initializeVkFFT(&app_, config);
    if (result != VKFFT_SUCCESS)
      fail(result == VKFFT_ERROR_UNSUPPORTED_FFT_LENGTH || result == VKFFT_ERROR_UNSUPPORTED_FFT_LENGTH_R2C ||
                   result == VKFFT_ERROR_UNSUPPORTED_RADIX
               ? Code::InvalidArgument
               : Code::Internal,
           "vkfft cannot plan " + describe(key) + " (VkFFTResult " + std::to_string(int(result)) + ")");
  }

  ~VkfftPlan() override { deleteVkFFT(&app_); }

  void enqueue(const cl::CommandQueue& queue, Direction direction, const cl::Buffer& in,
               const cl::Buffer& out) override {
    check_direction(direction);
    cl_command_queue q = queue();
    cl_mem spectrum, real;
    if (key().transform == Transform::C2C) {
      if (in() != out()) queue.enqueueCopyBuffer(in, out, 0, 0, key().complex_bytes());
      spectrum = out();
      real = out();
    } else {
      spectrum = key().transform == Transform::R2C ? out() : in();
      real = key().transform == Transform::R2C ? in() : out();
    }
    VkFFTLaunchParams params = {};
    params.commandQueue = &q;
    params.buffer = &spectrum;
    params.inputBuffer = &real;
    VkFFTResult result = VkFFTAppend(&app_, direction == Direction::Forward ? -1 : 1, &params);
    if (result != VKFFT_SUCCESS)
      fail(Code::Internal,
           "vkfft " + describe(key()) + " failed to launch (VkFFTResult " + std::to_string(int(result)) + ")");
  }

 private:
  Runtime& runtime_;
  VkFFTApplication app_ = {};
  cl_device_id device_;
  cl_context context_;
  cl_platform_id platform_;
  uint64_t buffer_bytes_;
  uint64_t input_bytes_;
};

class VkfftBackend : public Backend {
 public:
  explicit VkfftBackend(Runtime& runtime) : runtime_(runtime) {}
  std::string name() const override { return "vkfft"; }
  std::unique_ptr<Plan> bake(const PlanKey& key) override { return std::make_unique<VkfftPlan>(runtime_, key); }

 private:
  Runtime& runtime_;
};

}  // namespace

std::unique_ptr<Backend> make_vkfft(Runtime& runtime) { return std::make_unique<VkfftBackend>(runtime); }

}  // namespace squall::fft
