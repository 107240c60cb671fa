// The FFT layer: batched 2D transforms on device buffers, behind one small interface with three backends
// (VkFFT's OpenCL backend and clFFT on any device; FFTW on the host for CPU devices).
//
// Conventions, the same for every backend (and FFTW's):
// - Row-major, x fastest: element (i, j) of batch b sits at i + nx * (j + ny * b).
// - Complex values are interleaved (re, im) pairs of the plan's precision (float2 or double2).
// - Forward uses exp(-i 2 pi k x / n), inverse exp(+i 2 pi k x / n); neither is scaled, so
//   inverse(forward(a)) = nx * ny * a.
// - R2C (forward only) maps nx * ny reals to (nx / 2 + 1) * ny complex values; C2R (inverse only) maps
//   them back and may overwrite its input, as FFTW's c2r does.
// - A plan is baked per key and device queue and cached (Fft); executing it allocates nothing.
#pragma once

#include <compare>
#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "runtime/opencl.h"

namespace squall {
class Runtime;
}

namespace squall::fft {

enum class Transform { C2C, R2C, C2R };
enum class Precision { F32, F64 };
enum class Direction { Forward, Inverse };

struct PlanKey {
  size_t nx = 0, ny = 0;
  size_t batch = 1;
  Transform transform = Transform::C2C;
  Precision precision = Precision::F32;
  auto operator<=>(const PlanKey&) const = default;

  size_t real_bytes() const;     // one real array of the whole batch
  size_t complex_bytes() const;  // the complex array: nx (C2C) or nx/2+1 (R2C, C2R) per row
  size_t input_bytes() const;    // what a forward transform reads
  size_t output_bytes() const;   // what a forward transform writes
};

std::string describe(const PlanKey& key);  // "512x512 C2C f32 x1"

class Plan {
 public:
  explicit Plan(const PlanKey& key) : key_(key) {}
  virtual ~Plan() = default;
  const PlanKey& key() const { return key_; }

  // Enqueues one transform. C2C: in == out transforms in place, otherwise in is left unchanged.
  // R2C: Forward, in real, out complex. C2R: Inverse, in complex, out real. The caller serializes
  // calls that share a queue (Runtime::exclusive()).
  virtual void enqueue(const cl::CommandQueue& queue, Direction direction, const cl::Buffer& in,
                       const cl::Buffer& out) = 0;

  // Makes now whatever running `direction` in place (in == out) or not still needs, so that the first
  // such enqueue costs no more than the next ones: FFTW measures its plans, clFFT bakes its in-place
  // plan. VkFFT's plan is complete when baked.
  virtual void prepare(Direction direction, bool /*in_place*/) { check_direction(direction); }

  // After the queue has run the transforms enqueued under one lease: Error(Internal) if one of them did not
  // run (its output is then NaN), reported to that caller, once. The other backends run in the device's own
  // commands, whose failures the queue's wait reports.
  virtual void check_ran() {}

 protected:
  void check_direction(Direction direction) const;  // R2C must be Forward, C2R Inverse

 private:
  PlanKey key_;
};

class Backend {
 public:
  virtual ~Backend() = default;
  virtual std::string name() const = 0;
  // Whether it transforms a length of n along an axis, and the lengths it does, in words.
  virtual bool transforms(size_t /*n*/) const { return true; }
  virtual std::string lengths() const { return "any length"; }
  // Bakes a plan; throws Error(InvalidArgument) naming the size when the backend cannot do it.
  virtual std::unique_ptr<Plan> bake(const PlanKey& key) = 0;
};

struct FftwOptions {
  int threads = 0;      // FFTW's threads per transform of 512^2 cells or more (smaller ones run on one, under
                        // any load); 0: the device's compute units
  bool measure = true;  // FFTW_MEASURE (plans take longer to make, run faster); false: FFTW_ESTIMATE
  // A directory for FFTW's wisdom (what its planner measured), or "": none. The backend loads the files
  // there made on a device of the same name, and writes them again after each plan it measures, so a
  // transform is measured once per machine rather than once per process. The daemon uses its kernel cache.
  std::string wisdom_dir;
  // Wisdom past this many bytes (of one precision; 1-2 KB per transform size measured) is forgotten but for
  // the file, which is not written again, so clients asking for ever new sizes fill neither memory nor disk.
  size_t max_wisdom_bytes = size_t(4) << 20;
};

std::unique_ptr<Backend> make_vkfft(Runtime& runtime);
std::unique_ptr<Backend> make_clfft(Runtime& runtime);
// Throws Error(InvalidArgument) unless the runtime's device is a CPU (its buffers are host memory) that runs native
// kernels (each transform is one).
std::unique_ptr<Backend> make_fftw(Runtime& runtime, const FftwOptions& options = {});
bool runs_native_kernels(const Runtime& runtime);  // CL_EXEC_NATIVE_KERNEL: what the fftw backend needs
// "vkfft", "clfft" or "fftw" (CPU devices only); throws Error(InvalidArgument) for any other name.
std::unique_ptr<Backend> make_backend(Runtime& runtime, const std::string& name, const FftwOptions& fftw = {});
// The backends make_backend accepts on this runtime's device: fftw only on a CPU device that runs native kernels.
std::vector<std::string> available_backends(const Runtime& runtime);

// A backend with its plan cache: the object engines hold. Destroy it before main returns (not from a
// static destructor): clFFT frees its plans through statics of its own that exit handlers destroy first.
class Fft {
 public:
  // Plans kept per device queue. Past it, taking a plan under a lease frees the least recently used of its
  // queue's plans that neither this lease took nor a prepare() outside a lease is making, so that requests
  // of ever new grid sizes do not add plans (and device memory) for good. Those plans' commands have run:
  // the queue was finished when their lease ended.
  static constexpr size_t kMaxPlansPerQueue = 32;

  explicit Fft(std::unique_ptr<Backend> backend) : backend_(std::move(backend)) {}
  const std::string name() const { return backend_->name(); }
  bool transforms(size_t n) const { return backend_->transforms(n); }  // Backend::transforms
  std::string lengths() const { return backend_->lengths(); }          // Backend::lengths
  // INVALID_ARGUMENT naming `field` (its value n) where the backend cannot transform length n: a request's
  // grid refused before any of its work is done, not when its plan is baked.
  void check_length(const std::string& field, size_t n) const;

  // The cached plan for key on the calling thread's device queue, baked on first use (a plan's scratch
  // memory serves one queue). Thread-safe; other lookups go on while a plan is baked. Under a lease
  // (Runtime::exclusive()) the plan stays until the lease ends; outside one (start-up, tests), until a
  // lease of queue 0 takes kMaxPlansPerQueue others.
  Plan& plan(const PlanKey& key);
  // plan(key), prepared to run `direction` in place or not: what a session does when it is created, so
  // that its first step measures nothing. FFTW keeps what its planner measured (its wisdom), so the same
  // transform prepared for one queue is planned for another from that wisdom, without measuring.
  Plan& prepare(const PlanKey& key, Direction direction, bool in_place);
  size_t cached_plans() const;  // over all queues
  uint64_t baked() const;       // plans baked so far: rising while cached_plans() stays, they are freed too soon

 private:
  using SlotKey = std::pair<size_t, PlanKey>;  // queue slot, key
  struct Cached {
    std::unique_ptr<Plan> plan;
    uint64_t lease = 0;  // held_lease_serial() of the last lease that took it; 0: none (only outside leases)
    uint64_t used = 0;   // when it was last taken, in lookups_
    int pins = 0;        // prepare() calls outside a lease making it now
  };
  Plan& take(const SlotKey& key, bool pin);                          // bakes on a miss
  Plan& use(Cached& cached, bool pin);                               // under mutex_
  std::vector<std::unique_ptr<Plan>> evict_past_limit(size_t slot);  // under mutex_; the plans to free
  void unpin(const SlotKey& key);

  std::unique_ptr<Backend> backend_;
  std::mutex bake_mutex_;  // plans are made and freed one at a time
  mutable std::mutex mutex_;
  std::map<SlotKey, Cached> plans_;
  uint64_t lookups_ = 0;
  uint64_t baked_ = 0;
};

// Times one complex nx x ny transform of each available backend on the runtime's device (median of a
// few runs) and returns the name of the fastest, with a line explaining the choice in *why.
std::string fastest_backend(Runtime& runtime, size_t nx, size_t ny, std::string* why, const FftwOptions& fftw = {});

// The backend a --fft flag names: "auto" is the fastest at 512 x 512 (fastest_backend), any other name
// itself. *why says how it was chosen.
std::string chosen_backend(Runtime& runtime, const std::string& flag, std::string* why, const FftwOptions& fftw = {});

}  // namespace squall::fft
