// Every FFT backend against FFTW in double precision on random input: relative L2 error <= 1e-6 in
// single precision, for square, rectangular, non-power-of-two and odd sizes, every transform kind,
// batched. The fftw backend (host FFTW on a CPU device's mapped buffers) runs only on CPU devices.
#include <fftw3.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <filesystem>
#include <future>
#include <random>
#include <thread>

#include "common/error.h"
#include "fft/fft.h"
#include "support/expect_error.h"
#include "support/fftw_wisdom.h"
#include "support/process.h"
#include "support/test_runtime.h"

namespace squall {
namespace {

using fft::Direction;
using fft::PlanKey;
using fft::Precision;
using fft::Transform;
using cd = std::complex<double>;

struct Case {
  std::string backend;
  size_t nx, ny;
};

std::string case_name(const testing::TestParamInfo<Case>& info) {
  return info.param.backend + "_" + std::to_string(info.param.nx) + "x" + std::to_string(info.param.ny);
}

std::vector<float> random_floats(size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1, 1);
  std::vector<float> v(n);
  for (auto& x : v) x = u(rng);
  return v;
}

// FFTW reference, double precision, same conventions (row-major, x fastest, unscaled).
std::vector<cd> reference_c2c(const std::vector<float>& interleaved, size_t nx, size_t ny, int sign) {
  std::vector<cd> data(nx * ny);
  for (size_t i = 0; i < data.size(); ++i) data[i] = cd(interleaved[2 * i], interleaved[2 * i + 1]);
  auto* p = reinterpret_cast<fftw_complex*>(data.data());
  fftw_plan plan = fftw_plan_dft_2d(int(ny), int(nx), p, p, sign, FFTW_ESTIMATE);
  fftw_execute(plan);
  fftw_destroy_plan(plan);
  return data;
}

std::vector<cd> reference_r2c(const std::vector<float>& real, size_t nx, size_t ny) {
  std::vector<double> in(real.begin(), real.end());
  std::vector<cd> out((nx / 2 + 1) * ny);
  fftw_plan plan =
      fftw_plan_dft_r2c_2d(int(ny), int(nx), in.data(), reinterpret_cast<fftw_complex*>(out.data()), FFTW_ESTIMATE);
  fftw_execute(plan);
  fftw_destroy_plan(plan);
  return out;
}

template <typename T>
double relative_l2(const std::vector<float>& got, const std::vector<T>& want) {
  double err = 0, norm = 0;
  for (size_t i = 0; i < want.size(); ++i) {
    if constexpr (std::is_same_v<T, cd>) {
      cd g(got[2 * i], got[2 * i + 1]);
      err += std::norm(g - want[i]);
      norm += std::norm(want[i]);
    } else {
      err += (got[i] - want[i]) * (got[i] - want[i]);
      norm += want[i] * want[i];
    }
  }
  return std::sqrt(err / norm);
}

class FftAccuracy : public testing::TestWithParam<Case> {
 protected:
  void SetUp() override {
    if (GetParam().backend == "fftw" && test::runtime().device_info().type != "cpu")
      GTEST_SKIP() << "the fftw backend runs on CPU devices only";
  }
  fft::Plan& plan(Transform t, size_t batch = 1) {
    const Case& c = GetParam();
    return test::fft(c.backend).plan(PlanKey{c.nx, c.ny, batch, t, Precision::F32});
  }
  void enqueue(fft::Plan& p, Direction d, const cl::Buffer& in, const cl::Buffer& out) {
    auto lock = test::runtime().exclusive();
    p.enqueue(test::runtime().queue(), d, in, out);
    test::runtime().queue().finish();
  }
};

constexpr double kTolerance = 1e-6;

TEST_P(FftAccuracy, ComplexForwardAndInverseMatchFftw) {
  const auto [backend, nx, ny] = GetParam();
  for (Direction d : {Direction::Forward, Direction::Inverse}) {
    auto input = random_floats(2 * nx * ny, 1);
    cl::Buffer in = test::upload(input), out(test::runtime().context(), CL_MEM_READ_WRITE, input.size() * 4);
    enqueue(plan(Transform::C2C), d, in, out);
    auto want = reference_c2c(input, nx, ny, d == Direction::Forward ? FFTW_FORWARD : FFTW_BACKWARD);
    EXPECT_LE(relative_l2(test::read<float>(out, input.size()), want), kTolerance);
    EXPECT_EQ(test::read<float>(in, input.size()), input) << "out-of-place must leave its input alone";
  }
}

TEST_P(FftAccuracy, ComplexInPlaceMatchesFftw) {
  const auto [backend, nx, ny] = GetParam();
  auto input = random_floats(2 * nx * ny, 2);
  cl::Buffer data = test::upload(input);
  enqueue(plan(Transform::C2C), Direction::Forward, data, data);
  EXPECT_LE(relative_l2(test::read<float>(data, input.size()), reference_c2c(input, nx, ny, FFTW_FORWARD)), kTolerance);
}

TEST_P(FftAccuracy, RealToComplexMatchesFftw) {
  const auto [backend, nx, ny] = GetParam();
  auto input = random_floats(nx * ny, 3);
  auto want = reference_r2c(input, nx, ny);
  cl::Buffer in = test::upload(input), out(test::runtime().context(), CL_MEM_READ_WRITE, want.size() * 8);
  enqueue(plan(Transform::R2C), Direction::Forward, in, out);
  EXPECT_LE(relative_l2(test::read<float>(out, 2 * want.size()), want), kTolerance);
}

TEST_P(FftAccuracy, ComplexToRealInvertsRealToComplex) {
  const auto [backend, nx, ny] = GetParam();
  auto signal = random_floats(nx * ny, 4);
  auto half = reference_r2c(signal, nx, ny);  // an exactly Hermitian half spectrum
  std::vector<float> spectrum;
  for (const cd& c : half) spectrum.push_back(float(c.real())), spectrum.push_back(float(c.imag()));
  cl::Buffer in = test::upload(spectrum), out(test::runtime().context(), CL_MEM_READ_WRITE, nx * ny * 4);
  enqueue(plan(Transform::C2R), Direction::Inverse, in, out);
  std::vector<double> want(signal.begin(), signal.end());
  for (auto& w : want) w *= double(nx * ny);  // unscaled inverse
  EXPECT_LE(relative_l2(test::read<float>(out, nx * ny), want), kTolerance);
}

// The output buffer made before the input: a runtime that orders a command's buffers by their creation
// (PoCL's native kernels do) must still read the input and write the output.
TEST_P(FftAccuracy, OutOfPlaceWithItsOutputMadeBeforeItsInput) {
  const auto [backend, nx, ny] = GetParam();
  auto real = random_floats(nx * ny, 6), complex = random_floats(2 * nx * ny, 7);
  cl::Buffer half(test::runtime().context(), CL_MEM_READ_WRITE, (nx / 2 + 1) * ny * 8);
  cl::Buffer full(test::runtime().context(), CL_MEM_READ_WRITE, complex.size() * 4);
  cl::Buffer real_in = test::upload(real), complex_in = test::upload(complex);
  enqueue(plan(Transform::R2C), Direction::Forward, real_in, half);
  enqueue(plan(Transform::C2C), Direction::Forward, complex_in, full);
  auto want = reference_r2c(real, nx, ny);
  EXPECT_LE(relative_l2(test::read<float>(half, 2 * want.size()), want), kTolerance);
  EXPECT_LE(relative_l2(test::read<float>(full, complex.size()), reference_c2c(complex, nx, ny, FFTW_FORWARD)),
            kTolerance);
  EXPECT_EQ(test::read<float>(real_in, real.size()), real) << "out-of-place must leave its input alone";
}

// The buffers engines transform come from the runtime's pool; on a CPU device they are made over host
// memory of their own (unless made as a GPU's are), which the fftw backend transforms in one native
// kernel, out of place too (the output made before the input).
TEST_P(FftAccuracy, OutOfPlaceOnPoolBuffersMatchesFftw) {
  const auto [backend, nx, ny] = GetParam();
  auto real = random_floats(nx * ny, 11);
  BufferLease half = test::runtime().buffers().acquire((nx / 2 + 1) * ny * 8);
  BufferLease in = test::runtime().buffers().acquire(real.size() * 4);
  if (backend == "fftw" && test::host_buffers_on_cpu()) {  // so that this takes the one-kernel path
    ASSERT_TRUE(test::runtime().computes_in_host_storage());
    ASSERT_NE(host_storage(in.buffer()), nullptr);
    ASSERT_NE(host_storage(half.buffer()), nullptr);
  }
  test::runtime().queue().enqueueWriteBuffer(in.buffer(), CL_TRUE, 0, real.size() * 4, real.data());
  enqueue(plan(Transform::R2C), Direction::Forward, in.buffer(), half.buffer());
  auto want = reference_r2c(real, nx, ny);
  EXPECT_LE(relative_l2(test::read<float>(half.buffer(), 2 * want.size()), want), kTolerance);
  EXPECT_EQ(test::read<float>(in.buffer(), real.size()), real) << "out-of-place must leave its input alone";
}

// A transform gives the same bits alone and with another request holding a device queue (the fftw backend
// picks its plans by size, not by what runs beside it), and agrees with FFTW either way.
TEST_P(FftAccuracy, TransformsAloneAndBesideAnotherRequestAreBitIdentical) {
  const auto [backend, nx, ny] = GetParam();
  if (backend != "fftw") GTEST_SKIP() << "the other backends run the same kernels whatever runs beside them";
  const auto complex = random_floats(2 * nx * ny, 8), real = random_floats(nx * ny, 9);
  // The inverse C2C of `complex` and the R2C of `real` on a lease of their own, read back.
  auto transforms = [&](size_t* queues_held) {
    cl::Buffer data = test::upload(complex), real_in = test::upload(real);
    cl::Buffer half(test::runtime().context(), CL_MEM_READ_WRITE, (nx / 2 + 1) * ny * 8);
    {
      auto lease = test::runtime().exclusive();
      *queues_held = test::runtime().queues_held();
      plan(Transform::C2C).enqueue(test::runtime().queue(), Direction::Inverse, data, data);
      plan(Transform::R2C).enqueue(test::runtime().queue(), Direction::Forward, real_in, half);
    }
    return std::pair{test::read<float>(data, complex.size()), test::read<float>(half, (nx / 2 + 1) * ny * 2)};
  };
  size_t alone = 0, beside = 0;
  const auto by_itself = transforms(&alone);
  std::promise<void> held, done;
  std::thread other([&] {
    auto lease = test::runtime().exclusive();
    held.set_value();
    done.get_future().wait();
  });
  held.get_future().wait();
  std::pair<std::vector<float>, std::vector<float>> with_other;
  try {
    with_other = transforms(&beside);
  } catch (...) {  // the other lease ends first: its thread would otherwise outlive the test
    done.set_value();
    other.join();
    throw;
  }
  done.set_value();
  other.join();
  EXPECT_EQ(alone, 1u);
  EXPECT_EQ(beside, 2u);
  EXPECT_EQ(with_other.first, by_itself.first) << "the C2C depends on the requests beside it";
  EXPECT_EQ(with_other.second, by_itself.second) << "the R2C depends on the requests beside it";
  EXPECT_LE(relative_l2(with_other.first, reference_c2c(complex, nx, ny, FFTW_BACKWARD)), kTolerance);
  EXPECT_LE(relative_l2(with_other.second, reference_r2c(real, nx, ny)), kTolerance);
}

TEST_P(FftAccuracy, BatchedTransformsAreIndependent) {
  const auto [backend, nx, ny] = GetParam();
  const size_t batch = 3, n = 2 * nx * ny;
  auto input = random_floats(batch * n, 5);
  cl::Buffer data = test::upload(input);
  enqueue(plan(Transform::C2C, batch), Direction::Forward, data, data);
  auto got = test::read<float>(data, input.size());
  for (size_t b = 0; b < batch; ++b) {
    std::vector<float> one(input.begin() + b * n, input.begin() + (b + 1) * n);
    std::vector<float> got_one(got.begin() + b * n, got.begin() + (b + 1) * n);
    EXPECT_LE(relative_l2(got_one, reference_c2c(one, nx, ny, FFTW_FORWARD)), kTolerance) << "batch " << b;
  }
}

const std::
    vector<Case>
        kCases =
            {
                {"vkfft", 64, 64}, {"vkfft", 256, 256}, {"vkfft", 512, 256}, {"vkfft", 1400, 600},
                {"clfft", 64, 64}, {"clfft", 256, 256}, {"clfft", 512, 256}, {"clfft", 1400, 600},
                {"fftw", 64, 64},  {"fftw", 256, 256},  {"fftw", 512, 256},  {"fftw", 1400, 600},
                {"fftw", 105, 77}, {"fftw", 1031, 64},  // odd, and a prime that clFFT cannot factor
};
INSTANTIATE_TEST_SUITE_P(Backends, FftAccuracy, testing::ValuesIn(kCases), case_name);

TEST(FftPlans, AreBakedOncePerKey) {
  fft::Fft& f = test::fft("vkfft");
  size_t before = f.cached_plans();
  PlanKey key{96, 48, 1, Transform::C2C, Precision::F32};
  fft::Plan& a = f.plan(key);
  fft::Plan& b = f.plan(key);
  EXPECT_EQ(&a, &b);
  EXPECT_EQ(f.cached_plans(), before + 1);
  key.transform = Transform::R2C;
  EXPECT_NE(&f.plan(key), &a);
  EXPECT_EQ(f.cached_plans(), before + 2);
}

bool offers_fftw() {
  const auto names = fft::available_backends(test::runtime());
  return std::find(names.begin(), names.end(), "fftw") != names.end();
}

// The backend that the plan-cache tests bake with, counting its bakes: fftw on a CPU device (its plans are
// measured when first run), vkfft elsewhere.
class CountedBakes : public fft::Backend {
 public:
  explicit CountedBakes(int& bakes)
      : inner_(fft::make_backend(test::runtime(), offers_fftw() ? "fftw" : "vkfft")), bakes_(bakes) {}
  std::string name() const override { return inner_->name(); }
  std::unique_ptr<fft::Plan> bake(const PlanKey& key) override {
    ++bakes_;
    return inner_->bake(key);
  }

 private:
  std::unique_ptr<fft::Backend> inner_;
  int& bakes_;
};

PlanKey cache_test_key(size_t i) { return PlanKey{8, 2 * (i + 1), 1, Transform::C2C, Precision::F32}; }

// Transforms random data with `plan` on the calling thread's queue: its relative L2 error against FFTW.
double forward_error(fft::Plan& plan) {
  const PlanKey& key = plan.key();
  const auto values = random_floats(2 * key.nx * key.ny, 12);
  cl::Buffer data = test::upload(values);
  plan.enqueue(test::runtime().queue(), Direction::Forward, data, data);
  return relative_l2(test::read<float>(data, values.size()), reference_c2c(values, key.nx, key.ny, FFTW_FORWARD));
}

// Requests of ever new grid sizes do not keep plans for good: past its limit, a queue keeps the plans
// taken most recently, and a plan freed is baked again, and right, when it is next asked for.
TEST(FftPlanCache, AQueueKeepsItsMostRecentlyUsedPlansUpToTheLimit) {
  int bakes = 0;
  fft::Fft f(std::make_unique<CountedBakes>(bakes));
  const size_t limit = fft::Fft::kMaxPlansPerQueue, extra = 4;
  auto take = [&](size_t i) {
    auto lease = test::runtime().exclusive();
    EXPECT_EQ(lease.slot(), 0u) << "alone, a lease takes the first queue";
    return forward_error(f.plan(cache_test_key(i)));
  };
  for (size_t i = 0; i < limit + extra; ++i) EXPECT_LE(take(i), kTolerance) << describe(cache_test_key(i));
  EXPECT_EQ(bakes, int(limit + extra));
  EXPECT_EQ(f.cached_plans(), limit);
  take(extra);  // the oldest plan kept, now the most recently used
  EXPECT_EQ(bakes, int(limit + extra)) << "a plan among the most recently used was freed";
  EXPECT_LE(take(0), kTolerance);  // baked again: frees the least recently used, extra + 1
  EXPECT_EQ(bakes, int(limit + extra) + 1);
  take(extra);
  EXPECT_EQ(bakes, int(limit + extra) + 1) << "the oldest plan was freed, not the least recently used";
  take(extra + 1);
  EXPECT_EQ(bakes, int(limit + extra) + 2) << "the least recently used plan was kept";
  EXPECT_EQ(f.cached_plans(), limit);
  EXPECT_EQ(f.baked(), uint64_t(bakes));
}

// A lease's plans stay while it lasts, however many it takes, and the queue's next lease frees the extra.
TEST(FftPlanCache, PlansTakenByTheLeaseHoldingTheQueueAreNotFreed) {
  int bakes = 0;
  fft::Fft f(std::make_unique<CountedBakes>(bakes));
  const size_t limit = fft::Fft::kMaxPlansPerQueue, extra = 4;
  {
    auto lease = test::runtime().exclusive();
    fft::Plan& first = f.plan(cache_test_key(0));
    for (size_t i = 1; i <= limit + extra; ++i) f.plan(cache_test_key(i));
    EXPECT_EQ(f.cached_plans(), limit + extra + 1);
    EXPECT_LE(forward_error(first), kTolerance);
    EXPECT_EQ(&f.plan(cache_test_key(0)), &first);
  }
  auto lease = test::runtime().exclusive();
  f.plan(cache_test_key(limit + extra + 1));
  EXPECT_EQ(f.cached_plans(), limit);
  EXPECT_EQ(bakes, int(limit + extra) + 2);
}

TEST(FftPlans, UnsupportedSizeIsAClearError) {
  // clFFT cannot factor 1031 (a prime)
  test::expect_error(Code::InvalidArgument, "1031", [] {
    test::fft("clfft").plan(PlanKey{1031, 64, 1, Transform::C2C, Precision::F32});
  });
  EXPECT_THROW(test::fft("vkfft").plan(PlanKey{0, 64}), Error);
}

TEST(FftPlans, DoublePrecisionMatchesFftwClosely) {
  if (!test::runtime().device_info().double_precision) GTEST_SKIP() << "device has no fp64";
  const size_t nx = 128, ny = 96;
  for (const std::string& backend : fft::available_backends(test::runtime())) {
    auto input = random_floats(2 * nx * ny, 6);
    std::vector<double> in_d(input.begin(), input.end());
    cl::Buffer data = test::upload(in_d);
    {
      auto lock = test::runtime().exclusive();
      test::fft(backend)
          .plan(PlanKey{nx, ny, 1, Transform::C2C, Precision::F64})
          .enqueue(test::runtime().queue(), Direction::Forward, data, data);
    }
    auto got = test::read<double>(data, in_d.size());
    auto want = reference_c2c(input, nx, ny, FFTW_FORWARD);
    double err = 0, norm = 0;
    for (size_t i = 0; i < want.size(); ++i) {
      err += std::norm(cd(got[2 * i], got[2 * i + 1]) - want[i]);
      norm += std::norm(want[i]);
    }
    EXPECT_LE(std::sqrt(err / norm), 1e-12) << backend;
  }
}

TEST(FftPlans, FftwIsOfferedOnCpuDevicesOnly) {
  auto names = fft::available_backends(test::runtime());
  bool cpu = test::runtime().device_info().type == "cpu";
  EXPECT_EQ(std::count(names.begin(), names.end(), "fftw"), cpu ? 1 : 0);
  if (!cpu) test::expect_error(Code::InvalidArgument, "CPU devices only", [] { fft::make_fftw(test::runtime()); });
}

// A prepared transform measures nothing when it first runs: FFTW's wisdom is the same after that run as
// before it, and the result is FFTW's.
TEST(FftPlans, FftwPreparedTransformPlansNothingWhenItRuns) {
  if (test::runtime().device_info().type != "cpu") GTEST_SKIP() << "the fftw backend runs on CPU devices only";
  const PlanKey key{72, 56, 2, Transform::R2C, Precision::F32};  // a size no other test plans
  auto real = random_floats(key.nx * key.ny * key.batch, 10);
  cl::Buffer in = test::upload(real), out(test::runtime().context(), CL_MEM_READ_WRITE, key.complex_bytes());
  std::string prepared, ran;
  {
    auto lock = test::runtime().exclusive();
    fft::Plan& plan = test::fft("fftw").prepare(key, Direction::Forward, false);
    prepared = test::fftwf_wisdom();
    plan.enqueue(test::runtime().queue(), Direction::Forward, in, out);
    test::runtime().queue().finish();
    ran = test::fftwf_wisdom();
  }
  EXPECT_FALSE(prepared.empty());
  EXPECT_EQ(ran, prepared) << "the first run of a prepared transform made a plan";
  real.resize(key.nx * key.ny);  // the first of the batch
  auto want = reference_r2c(real, key.nx, key.ny);
  EXPECT_LE(relative_l2(test::read<float>(out, 2 * want.size()), want), kTolerance);
}

// Wisdom files carry what one backend measured to the next process: after FFTW forgets its wisdom (as a
// new process starts with none), a backend made on the same directory prepares the transform without
// measuring, while one made without the directory measures it again.
TEST(FftPlans, FftwWisdomFilesSpareTheNextProcessItsMeasurements) {
  if (test::runtime().device_info().type != "cpu") GTEST_SKIP() << "the fftw backend runs on CPU devices only";
  const PlanKey key{88, 52, 1, Transform::C2C, Precision::F32};  // a size no other test plans
  // This process's own: the test binary runs twice at once under ctest (fft_test_device_buffers).
  const std::filesystem::path dir = test::temp_dir("fftw-wisdom");
  fft::FftwOptions options;
  options.wisdom_dir = dir.string();
  auto prepare = [&](const fft::FftwOptions& o) {
    fft::Fft fft(fft::make_fftw(test::runtime(), o));
    auto lock = test::runtime().exclusive();
    fft.prepare(key, Direction::Forward, false);
  };
  prepare(options);
  size_t files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) files += entry.file_size() > 0;
  EXPECT_EQ(files, 1u) << "one file of single-precision wisdom, and no temporary file left";

  fftwf_forget_wisdom();
  const std::string none = test::fftwf_wisdom();  // FFTW's header alone
  prepare(fft::FftwOptions{});
  EXPECT_NE(test::fftwf_wisdom(), none) << "with no wisdom, preparing measures";

  fftwf_forget_wisdom();
  fft::Fft loaded(fft::make_fftw(test::runtime(), options));
  const std::string before = test::fftwf_wisdom();
  EXPECT_NE(before, none) << "the backend loaded no wisdom";
  {
    auto lock = test::runtime().exclusive();
    loaded.prepare(key, Direction::Forward, false);
  }
  EXPECT_EQ(test::fftwf_wisdom(), before) << "a transform in the loaded wisdom was measured again";
  std::filesystem::remove_all(dir);
}

// Wisdom grows with each transform measured: past its cap FFTW forgets it but for the file, which is not
// written again, so the wisdom kept, in memory and on disk, stays within the cap however many sizes
// clients ask for, and the file never loses what it held.
TEST(FftPlans, FftwWisdomStaysWithinItsCap) {
  if (test::runtime().device_info().type != "cpu") GTEST_SKIP() << "the fftw backend runs on CPU devices only";
  const std::filesystem::path dir = test::temp_dir("fftw-wisdom-cap");  // this process's own, as above
  fft::FftwOptions options;
  options.wisdom_dir = dir.string();
  options.max_wisdom_bytes = 8 << 10;  // about 1.4 KB a size here: reached after five or six
  fftwf_forget_wisdom();
  fft::Fft fft(fft::make_fftw(test::runtime(), options));
  size_t file = 0;
  for (size_t ny = 20; ny < 60; ny += 4) {  // sizes no other test plans
    {
      auto lock = test::runtime().exclusive();
      fft.prepare(PlanKey{36, ny, 1, Transform::C2C, Precision::F32}, Direction::Forward, false);
    }
    EXPECT_LE(test::fftwf_wisdom().size(), options.max_wisdom_bytes) << "36x" << ny;
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
      EXPECT_LE(entry.file_size(), options.max_wisdom_bytes) << entry.path();
      EXPECT_GE(entry.file_size(), file) << "the file lost wisdom it held, at 36x" << ny;
      file = entry.file_size();
    }
  }
  EXPECT_GT(file, options.max_wisdom_bytes / 2) << "the sizes planned never neared the cap: the test shows nothing";
  std::filesystem::remove_all(dir);
}

// Host memory at an address FFTW's SIMD code does not assume (4 bytes past an aligned one), given to
// the device as CL_MEM_USE_HOST_PTR: the fftw backend takes its unaligned plan and gets the same result.
TEST(FftPlans, FftwTransformsUnalignedHostMemory) {
  if (test::runtime().device_info().type != "cpu") GTEST_SKIP() << "the fftw backend runs on CPU devices only";
  const size_t nx = 96, ny = 40;
  auto input = random_floats(2 * nx * ny, 7);
  float* aligned = fftwf_alloc_real(input.size() + 1);
  float* unaligned = aligned + 1;
  ASSERT_NE(fftwf_alignment_of(unaligned), 0);
  std::copy(input.begin(), input.end(), unaligned);
  cl::Buffer data(test::runtime().context(), CL_MEM_READ_WRITE | CL_MEM_USE_HOST_PTR, input.size() * 4, unaligned);
  {
    auto lock = test::runtime().exclusive();
    test::fft("fftw")
        .plan(PlanKey{nx, ny, 1, Transform::C2C, Precision::F32})
        .enqueue(test::runtime().queue(), Direction::Forward, data, data);
    test::runtime().queue().finish();
  }
  EXPECT_LE(relative_l2(test::read<float>(data, input.size()), reference_c2c(input, nx, ny, FFTW_FORWARD)), kTolerance);
  data = cl::Buffer();
  fftwf_free(aligned);
}

}  // namespace
}  // namespace squall
