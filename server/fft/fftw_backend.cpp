// FFTW on the host for CPU devices (M. Frigo and S. G. Johnson, "The Design and Implementation of
// FFTW3", Proc. IEEE 93(2), 2005). A CPU device's buffers live in host memory: the plan maps them
// (PoCL maps without copying; the pool allocates them with CL_MEM_ALLOC_HOST_PTR on CPU devices),
// runs FFTW's new-array execute on the mapped pointers, and unmaps. The blocking map waits for the
// kernels queued before; the unmap is queued, so kernels after it see the result.
#include <fftw3.h>

#include <algorithm>
#include <mutex>

#include "common/error.h"
#include "fft/fft.h"
#include "runtime/runtime.h"

namespace squall::fft {
namespace {

// FFTW's planner is not reentrant: every plan creation and destruction holds this.
std::mutex& planner_mutex() {
  static std::mutex m;
  return m;
}

// fftwf_* (F32) and fftw_* (F64) under one name.
template <Precision P>
struct Fftw;

template <>
struct Fftw<Precision::F32> {
  using Real = float;
  using Complex = fftwf_complex;
  using PlanT = fftwf_plan;
  static void threads(int n) {
    static const bool initialized = fftwf_init_threads() != 0;
    if (initialized) fftwf_plan_with_nthreads(n);
  }
  static void* alloc(size_t bytes) { return fftwf_malloc(bytes); }
  static void free(void* p) { fftwf_free(p); }
  static void destroy(PlanT p) { fftwf_destroy_plan(p); }
  static PlanT c2c(const int* n, int batch, void* in, void* out, int dist, int sign, unsigned flags) {
    return fftwf_plan_many_dft(2, n, batch, (Complex*)in, nullptr, 1, dist, (Complex*)out, nullptr, 1, dist, sign,
                               flags);
  }
  static PlanT r2c(const int* n, int batch, void* in, void* out, int real_dist, int complex_dist, unsigned flags) {
    return fftwf_plan_many_dft_r2c(2, n, batch, (Real*)in, nullptr, 1, real_dist, (Complex*)out, nullptr, 1,
                                   complex_dist, flags);
  }
  static PlanT c2r(const int* n, int batch, void* in, void* out, int complex_dist, int real_dist, unsigned flags) {
    return fftwf_plan_many_dft_c2r(2, n, batch, (Complex*)in, nullptr, 1, complex_dist, (Real*)out, nullptr, 1,
                                   real_dist, flags);
  }
  static void execute(PlanT p, Transform t, void* in, void* out) {
    if (t == Transform::C2C) fftwf_execute_dft(p, (Complex*)in, (Complex*)out);
    if (t == Transform::R2C) fftwf_execute_dft_r2c(p, (Real*)in, (Complex*)out);
    if (t == Transform::C2R) fftwf_execute_dft_c2r(p, (Complex*)in, (Real*)out);
  }
  static int alignment(void* p) { return fftwf_alignment_of((Real*)p); }
};

template <>
struct Fftw<Precision::F64> {
  using Real = double;
  using Complex = fftw_complex;
  using PlanT = fftw_plan;
  static void threads(int n) {
    static const bool initialized = fftw_init_threads() != 0;
    if (initialized) fftw_plan_with_nthreads(n);
  }
  static void* alloc(size_t bytes) { return fftw_malloc(bytes); }
  static void free(void* p) { fftw_free(p); }
  static void destroy(PlanT p) { fftw_destroy_plan(p); }
  static PlanT c2c(const int* n, int batch, void* in, void* out, int dist, int sign, unsigned flags) {
    return fftw_plan_many_dft(2, n, batch, (Complex*)in, nullptr, 1, dist, (Complex*)out, nullptr, 1, dist, sign,
                              flags);
  }
  static PlanT r2c(const int* n, int batch, void* in, void* out, int real_dist, int complex_dist, unsigned flags) {
    return fftw_plan_many_dft_r2c(2, n, batch, (Real*)in, nullptr, 1, real_dist, (Complex*)out, nullptr, 1,
                                  complex_dist, flags);
  }
  static PlanT c2r(const int* n, int batch, void* in, void* out, int complex_dist, int real_dist, unsigned flags) {
    return fftw_plan_many_dft_c2r(2, n, batch, (Complex*)in, nullptr, 1, complex_dist, (Real*)out, nullptr, 1,
                                  real_dist, flags);
  }
  static void execute(PlanT p, Transform t, void* in, void* out) {
    if (t == Transform::C2C) fftw_execute_dft(p, (Complex*)in, (Complex*)out);
    if (t == Transform::R2C) fftw_execute_dft_r2c(p, (Real*)in, (Complex*)out);
    if (t == Transform::C2R) fftw_execute_dft_c2r(p, (Complex*)in, (Real*)out);
  }
  static int alignment(void* p) { return fftw_alignment_of((Real*)p); }
};

// A cached transform: one FFTW plan per direction, placement (in place or not) and alignment, each made
// on first use on scratch arrays (FFTW_MEASURE overwrites its arrays). Mapped buffers are normally
// SIMD-aligned (PoCL aligns them to 128 bytes) and run the aligned plan; any other pointer runs a plan
// made with FFTW_UNALIGNED.
template <Precision P>
class FftwPlan : public Plan {
  using F = Fftw<P>;

 public:
  FftwPlan(const PlanKey& key, int threads, unsigned planner) : Plan(key), threads_(threads), planner_(planner) {}

  ~FftwPlan() override {
    std::lock_guard<std::mutex> lock(planner_mutex());
    for (auto& p : plans_)
      if (p) F::destroy(p);
  }

  void enqueue(const cl::CommandQueue& queue, Direction direction, const cl::Buffer& in,
               const cl::Buffer& out) override {
    check_direction(direction);
    const PlanKey& k = key();
    const bool in_place = in() == out();
    if (in_place && k.transform != Transform::C2C) fail(Code::Internal, "fftw: " + describe(k) + " needs two buffers");
    // input_bytes: what this key's transform reads (complex for C2R), in either direction. One wait: the
    // output's map is enqueued first without waiting, and the in-order queue completes it before the
    // input's blocking map returns (its event's wait then returns at once, or reports its error).
    cl::Event output_mapped;
    void* dst = in_place ? nullptr
                         : queue.enqueueMapBuffer(out, CL_FALSE, CL_MAP_WRITE_INVALIDATE_REGION, 0, k.output_bytes(),
                                                  nullptr, &output_mapped);
    void* src = queue.enqueueMapBuffer(in, CL_TRUE, CL_MAP_READ | CL_MAP_WRITE, 0, k.input_bytes());
    if (in_place)
      dst = src;
    else
      output_mapped.wait();
    const bool unaligned = F::alignment(src) != 0 || F::alignment(dst) != 0;
    F::execute(plan(direction, in_place, unaligned), k.transform, src, dst);
    if (!in_place) queue.enqueueUnmapMemObject(out, dst);
    queue.enqueueUnmapMemObject(in, src);
  }

 private:
  typename F::PlanT plan(Direction direction, bool in_place, bool unaligned) {
    auto& slot = plans_[4 * int(unaligned) + 2 * int(direction) + int(in_place)];
    std::lock_guard<std::mutex> lock(planner_mutex());
    if (!slot) slot = make(direction, in_place, unaligned);
    return slot;
  }

  typename F::PlanT make(Direction direction, bool in_place, bool unaligned) {
    const PlanKey& k = key();
    const int n[2] = {int(k.ny), int(k.nx)};  // row-major, x fastest: FFTW's last dimension
    const int real = int(k.nx * k.ny), complex = int((k.transform == Transform::C2C ? k.nx : k.nx / 2 + 1) * k.ny);
    void* a = F::alloc(std::max(k.real_bytes(), k.complex_bytes()));
    void* b = in_place ? a : F::alloc(std::max(k.real_bytes(), k.complex_bytes()));
    F::threads(threads_);
    const unsigned flags = planner_ | (unaligned ? FFTW_UNALIGNED : 0);
    typename F::PlanT p;
    if (k.transform == Transform::C2C)
      p = F::c2c(n, int(k.batch), a, b, real, direction == Direction::Forward ? FFTW_FORWARD : FFTW_BACKWARD, flags);
    else if (k.transform == Transform::R2C)
      p = F::r2c(n, int(k.batch), a, b, real, complex, flags);
    else
      p = F::c2r(n, int(k.batch), a, b, complex, real, flags);
    if (b != a) F::free(b);
    F::free(a);
    if (!p) fail(Code::InvalidArgument, "fftw cannot plan " + describe(k));
    return p;
  }

  int threads_;
  unsigned planner_;
  typename F::PlanT plans_[8] = {};  // [4 * unaligned + 2 * direction + in_place]
};

class FftwBackend : public Backend {
 public:
  FftwBackend(int threads, unsigned planner) : threads_(threads), planner_(planner) {}
  std::string name() const override { return "fftw"; }

  // FFTW plans any size; each (direction, placement, alignment) is planned on its first use and kept.
  std::unique_ptr<Plan> bake(const PlanKey& key) override {
    if (key.precision == Precision::F32) return std::make_unique<FftwPlan<Precision::F32>>(key, threads_, planner_);
    return std::make_unique<FftwPlan<Precision::F64>>(key, threads_, planner_);
  }

 private:
  int threads_;
  unsigned planner_;
};

}  // namespace

std::unique_ptr<Backend> make_fftw(Runtime& runtime, const FftwOptions& options) {
  const DeviceInfo& device = runtime.device_info();
  if (device.type != "cpu")
    fail(Code::InvalidArgument, "--fft fftw runs on CPU devices only (the device is " + device.type + ": " +
                                    device.name + "); use vkfft or clfft");
  static const bool thread_safe = (fftw_make_planner_thread_safe(), fftwf_make_planner_thread_safe(), true);
  (void)thread_safe;  // other FFTW users in the process (the references of tests and benchmarks) plan too
  int threads = options.threads > 0 ? options.threads : int(std::max(1u, device.compute_units));
  return std::make_unique<FftwBackend>(threads, options.measure ? FFTW_MEASURE : FFTW_ESTIMATE);
}

}  // namespace squall::fft
