// FFTW on the host for CPU devices (M. Frigo and S. G. Johnson, "The Design and Implementation of
// FFTW3", Proc. IEEE 93(2), 2005). A CPU device's buffers live in host memory: a transform is queued as a
// native kernel (clEnqueueNativeKernel), a host function that the device's worker thread calls in queue
// order with the buffers' addresses, and that runs FFTW's new-array execute on them. The caller does not
// wait: the kernels queued after it see its result, as after any kernel.
#include <fftw3.h>

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>

#include "common/error.h"
#include "common/log.h"
#include "fft/fft.h"
#include "runtime/host_transfer.h"
#include "runtime/runtime.h"

namespace squall::fft {
namespace {

constexpr double kSlowPlanSeconds = 1;  // a plan that took this long is logged (Info)

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
  static bool init_threads() {
    static const bool initialized = fftwf_init_threads() != 0;
    return initialized;
  }
  static void threads(int n) {
    if (init_threads()) fftwf_plan_with_nthreads(n);
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
  static constexpr const char* kWisdomSuffix = ".f32";
  static bool import_wisdom(const std::string& path) { return fftwf_import_wisdom_from_filename(path.c_str()); }
  static char* export_wisdom() { return fftwf_export_wisdom_to_string(); }  // free() it
  static void forget_wisdom() { fftwf_forget_wisdom(); }
};

template <>
struct Fftw<Precision::F64> {
  using Real = double;
  using Complex = fftw_complex;
  using PlanT = fftw_plan;
  static bool init_threads() {
    static const bool initialized = fftw_init_threads() != 0;
    return initialized;
  }
  static void threads(int n) {
    if (init_threads()) fftw_plan_with_nthreads(n);
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
  static constexpr const char* kWisdomSuffix = ".f64";
  static bool import_wisdom(const std::string& path) { return fftw_import_wisdom_from_filename(path.c_str()); }
  static char* export_wisdom() { return fftw_export_wisdom_to_string(); }  // free() it
  static void forget_wisdom() { fftw_forget_wisdom(); }
};

// Where FFTW's wisdom is kept: the stem of its files ("" for none), and the most bytes of it kept.
struct WisdomPlace {
  std::string stem;
  size_t max_bytes = 0;
};

// FFTW's wisdom of one precision in a file, "<stem>.f32" or "<stem>.f64": loaded when the backend is
// made, written after each measured plan. A write goes to a file of its own, then is renamed over the
// old one, so that another process (a second daemon on the same cache) reads a whole file or none.
// Wisdom grows with each new transform: past max_bytes FFTW forgets it (the plans made stay) and reloads
// the file, which is left as it was, so that clients asking for ever new sizes fill neither memory nor
// disk, and the transforms in the file are still planned without measuring.
template <Precision P>
class WisdomFile {
  using F = Fftw<P>;

 public:
  explicit WisdomFile(const WisdomPlace& place)
      : path_(place.stem.empty() ? "" : place.stem + F::kWisdomSuffix), max_bytes_(place.max_bytes) {}

  // Wisdom names the solvers it used, and the threaded ones exist once FFTW's threads are initialized:
  // wisdom written after that is read only after it too.
  void load() const {  // under planner_mutex()
    if (path_.empty() || !std::filesystem::exists(path_)) return;
    F::init_threads();
    if (F::import_wisdom(path_))
      log(LogLevel::Info, "fftw: loaded the wisdom in ", path_);
    else
      log(LogLevel::Warn, "fftw: ignored the wisdom in ", path_, ", which FFTW cannot read");
  }

  void save() const {  // under planner_mutex()
    const std::unique_ptr<char, decltype(&std::free)> text(F::export_wisdom(), &std::free);
    const std::string_view wisdom = text ? std::string_view(text.get()) : std::string_view();
    if (wisdom.size() > max_bytes_) {
      F::forget_wisdom();
      if (!path_.empty() && std::filesystem::exists(path_)) F::import_wisdom(path_);  // written under the cap
      static bool warned = false;  // under planner_mutex(); once per precision
      if (!std::exchange(warned, true))
        log(LogLevel::Warn, "fftw: its wisdom reached ", wisdom.size(), " bytes, past ", max_bytes_,
            ": forgotten but for ", path_.empty() ? "none" : path_ + ", kept as it was", " (logged once)");
      return;
    }
    if (path_.empty() || wisdom.empty()) return;
    const std::string part = path_ + ".part" + std::to_string(getpid());
    std::error_code ec;
    {
      std::ofstream out(part, std::ios::binary | std::ios::trunc);
      out << wisdom;
      if (!out.flush()) ec = std::make_error_code(std::errc::io_error);
    }
    if (!ec) std::filesystem::rename(part, path_, ec);
    if (ec) {
      std::filesystem::remove(part, ec);
      log(LogLevel::Warn, "fftw: cannot write wisdom to ", path_, "; plans are measured again by the next process");
    }
  }

 private:
  std::string path_;
  size_t max_bytes_;
};

// A cached transform: one FFTW plan per direction, placement (in place or not), alignment and thread
// count, each made on first use on scratch arrays (FFTW_MEASURE overwrites its arrays). Device buffers
// are normally SIMD-aligned (the buffer pool aligns them to kHostAlignment) and run the aligned plans,
// made when the transform is prepared or first enqueued (a planning error reaches the caller); any other
// address runs a plan made with FFTW_UNALIGNED when it first meets one.
//
// Threads: a transform of at least kThreadedCells cells runs on `threads` threads, a smaller one on one,
// whatever runs beside it: FFTW's plans for different thread counts round differently, and a result must
// not depend on the load. bench/fft_bench (the EPYC container, 2 cores): two threads take 0.53 of one
// thread's time from 512^2 on (6% more CPU time in all), but 0.89 at 256^2 (1.8 times the CPU time, which
// other requests would have used).
template <Precision P>
class FftwPlan : public Plan {
  using F = Fftw<P>;

 public:
  static constexpr size_t kThreadedCells = size_t(512) * 512;

  FftwPlan(const PlanKey& key, const Runtime& runtime, int threads, unsigned planner, const WisdomPlace& wisdom)
      : Plan(key),
        runtime_(runtime),
        threads_(key.nx * key.ny >= kThreadedCells ? threads : 1),
        planner_(planner),
        wisdom_(wisdom) {}

  ~FftwPlan() override {
    std::lock_guard<std::mutex> lock(planner_mutex());
    for (auto& p : plans_)
      if (p.load()) F::destroy(p.load());
  }

  // The aligned plan: a planning error reaches the caller.
  // Also reports, once, a transform of this plan that did not run and that its caller did not check
  // (check_ran()): to the next caller preparing it, before that caller's own commands change anything.
  void prepare(Direction direction, bool in_place) override {
    report_failure("an earlier ");
    check_direction(direction);
    if (in_place && key().transform != Transform::C2C)
      fail(Code::Internal, "fftw: " + describe(key()) + " needs two buffers");
    plan(direction, in_place, false);
  }

  void check_ran() override { report_failure(""); }

  void enqueue(const cl::CommandQueue& queue, Direction direction, const cl::Buffer& in,
               const cl::Buffer& out) override {
    const bool in_place = in() == out();
    prepare(direction, in_place);  // the plan made again where it was not
    // PoCL 3.1 hands a native kernel the addresses of its buffers in the order they were created
    // (pocl_create_command_full sorts them), not in the order of mem_list: a kernel of two buffers cannot
    // tell input from output by them. A pool buffer on a device that computes in its host storage (the
    // runtime's probe) is transformed at that memory, so one kernel does; it is given the buffers only
    // so that the runtime keeps them until it has run. Out of place on other buffers, it takes two
    // kernels of one buffer each: the first notes the output's address in a cell that the second, which
    // transforms, reads and deletes.
    void* in_storage = computed_host_storage(runtime_, in);
    void* out_storage = in_place ? in_storage : computed_host_storage(runtime_, out);
    if (in_storage && out_storage) {
      enqueue_native(queue, &FftwPlan::transform,
                     {{in(), out()}, in_storage, out_storage, nullptr, in_place, this, direction}, in_place ? 1 : 2);
    } else if (in_place) {
      enqueue_native(queue, &FftwPlan::transform, {{in()}, nullptr, nullptr, nullptr, true, this, direction}, 1);
    } else {
      auto cell = std::make_unique<void*>(nullptr);
      enqueue_native(queue, &FftwPlan::note_output, {{out()}, nullptr, nullptr, cell.get(), false, this, direction}, 1);
      void** output = cell.release();  // note_output writes it; transform reads and deletes it
      enqueue_native(queue, &FftwPlan::transform, {{in()}, nullptr, nullptr, output, false, this, direction}, 1);
    }
  }

 private:
  // A native kernel's argument block, copied by clEnqueueNativeKernel.
  struct Call {
    void* buffers[2];  // cl_mem handles when enqueued, their addresses in the runtime's order when run
    void* in;          // the input's host storage, or null: the input is buffers[0]
    void* out;         // the output's host storage, or null: *output, or the input in place
    void** output;     // out of place on buffers of unknown storage: the output's address, noted by note_output
    bool in_place;     // the same buffer in and out (as enqueued: not two buffers over one memory)
    FftwPlan* self;    // kept by the Fft until its queue has run the commands of the lease that took it
    Direction direction;
  };

  // Throws on failure (the cell of a note_output enqueued before is then leaked, not freed under it).
  void enqueue_native(const cl::CommandQueue& queue, void(CL_CALLBACK* function)(void*), Call call,
                      cl_uint buffers) const {
    const cl_mem mem[2] = {static_cast<cl_mem>(call.buffers[0]), static_cast<cl_mem>(call.buffers[1])};
    const void* locations[2] = {&call.buffers[0], &call.buffers[1]};
    const cl_int status =
        clEnqueueNativeKernel(queue(), function, &call, sizeof(call), buffers, mem, locations, 0, nullptr, nullptr);
    if (status != CL_SUCCESS)
      fail(Code::Internal,
           "fftw: clEnqueueNativeKernel of " + describe(key()) + " failed (" + std::to_string(status) + ")");
  }

  static void CL_CALLBACK note_output(void* arguments) {
    const Call& c = *static_cast<const Call*>(arguments);
    *c.output = c.buffers[0];
  }

  static void CL_CALLBACK transform(void* arguments) {
    const Call& c = *static_cast<const Call*>(arguments);
    const std::unique_ptr<void*> output(c.output);
    void* in = c.in ? c.in : c.buffers[0];
    void* out = c.in_place ? in : c.out ? c.out : *output;
    const bool unaligned = F::alignment(in) != 0 || F::alignment(out) != 0;
    try {
      F::execute(c.self->plan(c.direction, c.in_place, unaligned), c.self->key().transform, in, out);
    } catch (const std::exception& e) {  // not thrown across the OpenCL runtime
      c.self->failed(e.what(), out);
    }
  }

  // Error(Internal) for a transform that did not run, once.
  void report_failure(const std::string& which) {
    std::lock_guard<std::mutex> lock(failure_mutex_);
    if (std::string what = std::exchange(failure_, {}); !what.empty())
      fail(Code::Internal, "fftw: " + which + describe(key()) + " did not run: " + what);
  }

  // A transform that could not run (an unaligned plan that FFTW would not make) leaves NaN in its
  // output, is logged, and is reported by check_ran() or the next prepare() of this plan (once).
  void failed(const std::string& what, void* out) {
    using Real = typename F::Real;
    const PlanKey& k = key();
    const size_t bytes = k.transform == Transform::C2R ? k.real_bytes() : k.complex_bytes();
    std::fill_n(static_cast<Real*>(out), bytes / sizeof(Real), std::numeric_limits<Real>::quiet_NaN());
    log(LogLevel::Error, "fftw: ", describe(k), " not run: ", what);
    std::lock_guard<std::mutex> lock(failure_mutex_);
    failure_ = what;
  }

  // A plan made is read without the planner's lock, which a worker thread running a transform would
  // otherwise wait for while another thread plans.
  typename F::PlanT plan(Direction direction, bool in_place, bool unaligned) {
    auto& slot = plans_[4 * int(unaligned) + 2 * int(direction) + int(in_place)];
    if (typename F::PlanT made = slot.load(std::memory_order_acquire)) return made;
    std::lock_guard<std::mutex> lock(planner_mutex());
    if (!slot.load()) {
      const bool measured = !(planner_ & FFTW_ESTIMATE);  // FFTW_MEASURE is 0: not a bit to test
      // Measuring a large transform that the wisdom does not hold takes seconds, which no cancellation
      // cuts short: said in the log, so that a slow first call of a size is explained.
      if (measured) log(LogLevel::Debug, "fftw: planning ", describe(key()));
      const auto start = std::chrono::steady_clock::now();
      slot.store(make(direction, in_place, unaligned), std::memory_order_release);
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      if (seconds >= kSlowPlanSeconds) log(LogLevel::Info, "fftw: planned ", describe(key()), " in ", seconds, " s");
      if (measured) wisdom_.save();
    }
    return slot.load();
  }

  typename F::PlanT make(Direction direction, bool in_place, bool unaligned) {
    const PlanKey& k = key();
    // FFTW's advanced interface counts in int: one transform's elements, and the batch.
    if (k.nx * k.ny > size_t(std::numeric_limits<int>::max()) || k.batch > size_t(std::numeric_limits<int>::max()))
      fail(Code::InvalidArgument, "fftw cannot plan " + describe(k) + ": more elements than FFTW counts");
    const int n[2] = {int(k.ny), int(k.nx)};  // row-major, x fastest: FFTW's last dimension
    const int real = int(k.nx * k.ny), complex = int((k.transform == Transform::C2C ? k.nx : k.nx / 2 + 1) * k.ny);
    const size_t scratch = std::max(k.real_bytes(), k.complex_bytes());
    void* a = F::alloc(scratch);
    void* b = in_place ? a : F::alloc(scratch);
    if (!a || !b) {  // the measuring planner writes its scratch arrays
      if (b && b != a) F::free(b);
      if (a) F::free(a);
      fail(Code::ResourceExhausted, "fftw: no memory for the scratch arrays of " + describe(k));
    }
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

  const Runtime& runtime_;
  const int threads_;  // FFTW's threads for this transform's size
  unsigned planner_;
  WisdomFile<P> wisdom_;
  std::mutex failure_mutex_;
  std::string failure_;                           // why a transform did not run; empty while all ran
  std::atomic<typename F::PlanT> plans_[8] = {};  // [4 * unaligned + 2 * direction + in_place]
};

class FftwBackend : public Backend {
 public:
  FftwBackend(const Runtime& runtime, int threads, unsigned planner, const WisdomPlace& wisdom)
      : runtime_(runtime), threads_(threads), planner_(planner), wisdom_(wisdom) {
    std::lock_guard<std::mutex> lock(planner_mutex());
    WisdomFile<Precision::F32>(wisdom_).load();
    WisdomFile<Precision::F64>(wisdom_).load();
  }
  std::string name() const override { return "fftw"; }

  // FFTW plans any size; each (direction, placement, alignment) is planned on its first use and kept.
  std::unique_ptr<Plan> bake(const PlanKey& key) override {
    if (key.precision == Precision::F32)
      return std::make_unique<FftwPlan<Precision::F32>>(key, runtime_, threads_, planner_, wisdom_);
    return std::make_unique<FftwPlan<Precision::F64>>(key, runtime_, threads_, planner_, wisdom_);
  }

 private:
  const Runtime& runtime_;
  int threads_;
  unsigned planner_;
  WisdomPlace wisdom_;
};

// "<dir>/fftw-wisdom-<device name>", the name reduced to [A-Za-z0-9._-]: plans measured on one CPU are
// not loaded on another. "" for no directory.
std::string wisdom_stem(const std::string& dir, const std::string& device) {
  if (dir.empty()) return "";
  std::string name = device;
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '-') c = '_';
  return dir + "/fftw-wisdom-" + name;
}

}  // namespace

bool runs_native_kernels(const Runtime& runtime) {
  return runtime.device().getInfo<CL_DEVICE_EXECUTION_CAPABILITIES>() & CL_EXEC_NATIVE_KERNEL;
}

std::unique_ptr<Backend> make_fftw(Runtime& runtime, const FftwOptions& options) {
  const DeviceInfo& device = runtime.device_info();
  if (device.type != "cpu")
    fail(Code::InvalidArgument, "--fft fftw runs on CPU devices only (the device is " + device.type + ": " +
                                    device.name + "); use vkfft or clfft");
  if (!runs_native_kernels(runtime))
    fail(Code::InvalidArgument,
         "--fft fftw needs a device that runs native kernels, and " + device.name + " does not; use vkfft or clfft");
  static const bool thread_safe = (fftw_make_planner_thread_safe(), fftwf_make_planner_thread_safe(), true);
  (void)thread_safe;  // other FFTW users in the process (the references of tests and benchmarks) plan too
  int threads = options.threads > 0 ? options.threads : int(std::max(1u, device.compute_units));
  std::error_code ec;  // a directory that cannot be made: its writes fail, and each is logged
  if (!options.wisdom_dir.empty()) std::filesystem::create_directories(options.wisdom_dir, ec);
  return std::make_unique<FftwBackend>(
      runtime, threads, options.measure ? FFTW_MEASURE : FFTW_ESTIMATE,
      WisdomPlace{wisdom_stem(options.wisdom_dir, device.name), options.max_wisdom_bytes});
}

}  // namespace squall::fft
