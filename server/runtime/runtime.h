// squall::Runtime: one OpenCL device, its context and in-order queues (QueueSlots), and every program of
// kernels/ compiled once. It lives as long as the daemon (or the test binary); requests only enqueue work.
#pragma once

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "runtime/buffer_pool.h"
#include "runtime/device.h"
#include "runtime/kernel_sources.h"
#include "runtime/opencl.h"
#include "runtime/queue_slots.h"

namespace squall {

struct RuntimeOptions {
  std::string device = "auto";  // --device: auto | cpu | gpu | substring of platform or device name
  std::string kernel_dir;       // --kernel-dir: read kernels from here instead of the embedded copy
  size_t max_idle_buffer_bytes = 512ull << 20;
  // Build only the programs whose path starts with one of these (e.g. "ocean/"); empty: all of them.
  // The daemon builds all; a test binary builds what it tests, so one capability's kernel under
  // development cannot stop another's tests.
  std::vector<std::string> program_prefixes;
  // Queue with CL_QUEUE_PROFILING_ENABLE; every Kernel<...>::launch waits for its kernel and adds its
  // device time to kernel_timings(). Off: launches do not wait. SQUALL_PROFILE_KERNELS=1 also turns it on.
  bool profile_kernels = false;
  // --device-queues: in-order command queues on the device, each serving one request at a time (1..16;
  // 1 serializes requests). Even a 2-core CPU device gains from more than one: one request's host work
  // (FFTW, copies) overlaps another's kernels (bench/load_bench.py: a quarter more calls/s at 8 clients
  // than one queue). From 3 on, while much shorter work is about, longer work holds long_limit() of them
  // at most (about half: 2 of 3 or 4) and the rest are kept for the shorter. Three, not four: on a
  // 2-core CPU device, two long requests at once (one per PoCL worker) and one queue for short work gave
  // the long requests a lower p99 at 8 clients than two queues for short work did (docs/performance.md).
  size_t queues = 3;
  // On a CPU device the pool's buffers are made over host memory of their own, in which the device
  // computes: reads and writes of them are copies with no command (computes_in_host_storage()). false
  // makes them as a discrete device's are, so that the read and write commands and pinned blocks that a
  // GPU's calls take also run, and are tested, on PoCL (SQUALL_TEST_BUFFERS=device in the test binaries);
  // the fftw backend then runs its native kernels over buffers of no host storage.
  bool host_buffers_on_cpu = true;
};

// Device time of one kernel in profile mode, summed over its launches.
struct KernelTiming {
  std::string program;  // e.g. "ewave/step.cl"
  std::string kernel;   // e.g. "ewave_prepare"
  uint64_t launches = 0;
  uint64_t device_ns = 0;  // sum of CL_PROFILING_COMMAND_END - CL_PROFILING_COMMAND_START
};

struct ProgramBuild {
  std::string program;               // e.g. "runtime/selftest.cl"
  std::vector<std::string> kernels;  // kernel function names
  double seconds = 0;                // clBuildProgram wall time
};

// Sets POCL_CACHE_DIR (unless the environment already does) to `dir`, or when that is empty to
// $XDG_CACHE_HOME/squall/pocl or $HOME/.cache/squall/pocl, and creates it. PoCL reads the variable
// when the ICD loads, so call this before any other OpenCL call. Returns the directory in force.
std::string configure_kernel_cache(const std::string& dir = "");

class Runtime {
 public:
  // Selects the device and creates the context and queue; throws Error(InvalidArgument) when no
  // device matches. Programs are not built yet: call build_programs().
  explicit Runtime(const RuntimeOptions& options);

  // Compiles every program. A failure throws Error(Internal) whose message holds the device's build log.
  void build_programs();
  bool built() const { return built_; }
  const std::vector<ProgramBuild>& builds() const { return builds_; }

  const DeviceInfo& device_info() const { return found_.info; }
  const cl::Device& device() const { return found_.device; }
  const cl::Platform& platform() const { return found_.platform; }
  const cl::Context& context() const { return context_; }
  // The calling thread's queue: the one its lease (exclusive()) holds; outside a lease the first.
  const cl::CommandQueue& queue() const { return queues_->queue(current_queue_slot()); }
  size_t queue_count() const { return queues_->count(); }
  BufferPool& buffers() { return *buffers_; }
  // Whether the device computes in the host memory its pool's buffers are made over (host_storage()), as
  // PoCL's CPU devices do; an OpenCL may instead keep a copy of such a buffer on the device. Probed once,
  // at construction, by a copy on the device. Only where it is so do the host copies of host_transfer.h
  // and the fftw backend's transforms reach that memory (computed_host_storage()).
  bool computes_in_host_storage() const { return computes_in_host_storage_; }

  // A new kernel object of a built program. cl::Kernel arguments are per object, so each caller
  // (a request, a session) owns its own.
  cl::Kernel kernel(const std::string& program, const std::string& name) const;

  // Device work of one request runs under a lease of one of the device's queues: the thread's queue()
  // until the lease ends, which waits for the queue's work. With one queue, requests take turns; with
  // more, up to that many run at once (their kernel objects and FFT plans are per queue, and a buffer
  // handed back goes to another queue only once its queue has finished). The waits are counted
  // (device_wait()). `kind` lets a request much shorter than those waiting go first, and keeps queues
  // for it from longer kinds of work (QueueSlots).
  QueueLease exclusive(const WorkKind& kind = {}) { return queues_->acquire(kind); }

  // How often the lock was taken, and the seconds callers waited for it, since start-up: the queueing
  // of requests behind each other (squalld's metrics).
  struct DeviceWait {
    uint64_t acquisitions = 0;
    double seconds = 0;
    size_t waiting = 0;  // callers waiting for a queue now
  };
  DeviceWait device_wait() const { return {queues_->acquisitions(), queues_->wait_seconds(), queues_->waiting()}; }
  // Per call site of exclusive() (WorkKind::site): leases ended, seconds waited for a queue and held.
  std::map<std::string, QueueSlots::SiteTimes> device_site_times() const { return queues_->site_times(); }
  // The queues leased now (exclusive()): 1 when the caller's request is the only one on the device.
  size_t queues_held() const { return queues_->held(); }

  // Profile mode (RuntimeOptions::profile_kernels): the per-kernel table, sorted by program and kernel.
  bool profiling() const { return profiling_; }
  void record_kernel_time(const std::string& program, const std::string& kernel, uint64_t device_ns);
  std::vector<KernelTiming> kernel_timings() const;

 private:
  bool selected(const std::string& program) const;

  bool profiling_;
  bool computes_in_host_storage_ = false;

  FoundDevice found_;
  cl::Context context_;
  KernelSources sources_;
  std::vector<std::string> program_prefixes_;
  std::map<std::string, cl::Program> programs_;
  std::vector<ProgramBuild> builds_;
  std::unique_ptr<BufferPool> buffers_;
  std::unique_ptr<QueueSlots> queues_;
  bool built_ = false;
  mutable std::mutex timings_mutex_;
  std::map<std::pair<std::string, std::string>, KernelTiming> timings_;
};

// The profile table as text, one kernel a line: program, kernel, launches, total ms, mean us, share of
// the total device time; slowest first.
std::string format_kernel_timings(const std::vector<KernelTiming>& timings);

}  // namespace squall
