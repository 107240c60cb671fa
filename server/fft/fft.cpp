#include "fft/fft.h"

#include <algorithm>
#include <chrono>
#include <iterator>
#include <sstream>
#include <vector>

#include "common/error.h"
#include "runtime/queue_slots.h"
#include "runtime/runtime.h"

namespace squall::fft {

size_t PlanKey::real_bytes() const {
  return nx * ny * batch * (precision == Precision::F32 ? sizeof(float) : sizeof(double));
}

size_t PlanKey::complex_bytes() const {
  size_t row = transform == Transform::C2C ? nx : nx / 2 + 1;
  return row * ny * batch * 2 * (precision == Precision::F32 ? sizeof(float) : sizeof(double));
}

size_t PlanKey::input_bytes() const { return transform == Transform::R2C ? real_bytes() : complex_bytes(); }
size_t PlanKey::output_bytes() const { return transform == Transform::C2R ? real_bytes() : complex_bytes(); }

std::string describe(const PlanKey& key) {
  static const char* kTransforms[] = {"C2C", "R2C", "C2R"};
  std::ostringstream os;
  os << key.nx << "x" << key.ny << " " << kTransforms[int(key.transform)] << " "
     << (key.precision == Precision::F32 ? "f32" : "f64") << " x" << key.batch;
  return os.str();
}

void Plan::check_direction(Direction direction) const {
  if (key_.transform == Transform::R2C && direction != Direction::Forward)
    fail(Code::Internal, "an R2C plan runs forward only (" + describe(key_) + ")");
  if (key_.transform == Transform::C2R && direction != Direction::Inverse)
    fail(Code::Internal, "a C2R plan runs inverse only (" + describe(key_) + ")");
}

std::unique_ptr<Backend> make_backend(Runtime& runtime, const std::string& name, const FftwOptions& fftw) {
  if (name == "vkfft") return make_vkfft(runtime);
  if (name == "clfft") return make_clfft(runtime);
  if (name == "fftw") return make_fftw(runtime, fftw);
  fail(Code::InvalidArgument, "--fft " + name + " is not a backend; use vkfft, clfft, fftw (CPU devices) or auto");
}

std::vector<std::string> available_backends(const Runtime& runtime) {
  std::vector<std::string> names = {"vkfft", "clfft"};
  if (runtime.device_info().type == "cpu" && runs_native_kernels(runtime)) names.push_back("fftw");
  return names;
}

void Fft::check_length(const std::string& field, size_t n) const {
  if (!transforms(n))
    fail(Code::InvalidArgument, field + " = " + std::to_string(n) + ": the " + name() + " FFT backend transforms " +
                                    lengths() + " only (pick such a size, or run squalld with --fft vkfft)");
}

Plan& Fft::plan(const PlanKey& key) { return take({current_queue_slot(), key}, false); }

Plan& Fft::prepare(const PlanKey& key, Direction direction, bool in_place) {
  const SlotKey slot_key{current_queue_slot(), key};
  const bool pin = held_queue_slot() < 0;  // under a lease the plan is kept while the lease lasts
  Plan& p = take(slot_key, pin);
  try {
    p.prepare(direction, in_place);
  } catch (...) {
    if (pin) unpin(slot_key);
    throw;
  }
  if (pin) unpin(slot_key);
  return p;
}

size_t Fft::cached_plans() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return plans_.size();
}

uint64_t Fft::baked() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return baked_;
}

Plan& Fft::take(const SlotKey& key, bool pin) {
  const PlanKey& k = key.second;
  if (k.nx < 1 || k.ny < 1 || k.batch < 1) fail(Code::InvalidArgument, "fft: empty transform " + describe(k));
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (auto it = plans_.find(key); it != plans_.end()) return use(it->second, pin);
  }
  std::unique_ptr<Plan> baked;
  {
    std::lock_guard<std::mutex> bake(bake_mutex_);  // compiling kernels may take seconds on PoCL
    baked = backend_->bake(k);
  }
  std::vector<std::unique_ptr<Plan>> freed;
  Plan* plan = nullptr;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++baked_;
    auto [it, added] = plans_.try_emplace(key);
    if (added) it->second.plan = std::move(baked);
    plan = &use(it->second, pin);  // a plan this lease took is not freed
    if (held_queue_slot() >= 0) freed = evict_past_limit(key.first);
    if (baked) freed.push_back(std::move(baked));  // one made meanwhile (queue 0, outside a lease) is kept
  }
  if (!freed.empty()) {  // freed as they are made, one at a time, and with no lookup waiting for FFTW's planner
    std::lock_guard<std::mutex> bake(bake_mutex_);
    freed.clear();
  }
  return *plan;
}

Plan& Fft::use(Cached& cached, bool pin) {
  if (const uint64_t lease = held_lease_serial()) cached.lease = lease;  // outside a lease: pinned or a test
  cached.used = ++lookups_;
  if (pin) ++cached.pins;
  return *cached.plan;
}

// Only the lease holding `slot` calls it, so none of the slot's earlier leases has commands left.
std::vector<std::unique_ptr<Plan>> Fft::evict_past_limit(size_t slot) {
  std::vector<std::unique_ptr<Plan>> evicted;
  for (;;) {
    const auto first = plans_.lower_bound({slot, PlanKey{}}), end = plans_.lower_bound({slot + 1, PlanKey{}});
    if (size_t(std::distance(first, end)) <= kMaxPlansPerQueue) return evicted;
    auto oldest = end;
    for (auto it = first; it != end; ++it)
      if (it->second.lease != held_lease_serial() && it->second.pins == 0 &&
          (oldest == end || it->second.used < oldest->second.used))
        oldest = it;
    if (oldest == end) return evicted;  // all in use: a later lease frees them
    evicted.push_back(std::move(oldest->second.plan));
    plans_.erase(oldest);
  }
}

void Fft::unpin(const SlotKey& key) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (auto it = plans_.find(key); it != plans_.end()) --it->second.pins;
}

namespace {

double median_seconds(Runtime& runtime, Plan& plan, const cl::Buffer& data, int runs) {
  std::vector<double> times;
  plan.enqueue(runtime.queue(), Direction::Forward, data, data);  // warm-up
  runtime.queue().finish();
  for (int r = 0; r < runs; ++r) {
    auto start = std::chrono::steady_clock::now();
    plan.enqueue(runtime.queue(), Direction::Forward, data, data);
    runtime.queue().finish();
    times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  std::nth_element(times.begin(), times.begin() + runs / 2, times.end());
  return times[runs / 2];
}

}  // namespace

std::string fastest_backend(Runtime& runtime, size_t nx, size_t ny, std::string* why, const FftwOptions& fftw) {
  PlanKey key{nx, ny, 1, Transform::C2C, Precision::F32};
  auto lease = runtime.buffers().acquire(key.complex_bytes());
  float zero = 0;
  runtime.queue().enqueueFillBuffer(lease.buffer(), zero, 0, key.complex_bytes());
  std::string best;
  double best_time = 0;
  std::ostringstream os;
  for (const std::string& name : available_backends(runtime)) {
    auto backend = make_backend(runtime, name, fftw);
    auto plan = backend->bake(key);
    double t = median_seconds(runtime, *plan, lease.buffer(), 7);
    os << name << " " << t * 1e3 << " ms, ";
    if (best.empty() || t < best_time) best = name, best_time = t;
  }
  if (why) *why = "measured at start-up, one " + describe(key) + ": " + os.str() + "picked " + best;
  return best;
}

std::string chosen_backend(Runtime& runtime, const std::string& flag, std::string* why, const FftwOptions& fftw) {
  if (flag == "auto") return fastest_backend(runtime, 512, 512, why, fftw);
  if (why) *why = "flag --fft " + flag;
  return flag;
}

}  // namespace squall::fft
