// The OpenCL runtime on the test device (PoCL in CI): discovery, selection, program builds, kernels,
// buffer reuse, include splicing and the kernel cache.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>

#include "common/error.h"
#include "common/limits.h"
#include "runtime/buffer_pool.h"
#include "runtime/device_cache.h"
#include "runtime/host_transfer.h"
#include "runtime/kernel.h"
#include "runtime/runtime.h"
#include "support/expect_error.h"
#include "support/process.h"
#include "support/test_runtime.h"

namespace squall {
namespace {

void write(const std::string& path, const std::string& text) {
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  std::ofstream(path) << text;
}

TEST(Device, FindsAtLeastOneDevice) {
  auto devices = find_devices();
  ASSERT_FALSE(devices.empty());
  for (const auto& d : devices) {
    EXPECT_FALSE(d.info.name.empty());
    EXPECT_GT(d.info.compute_units, 0u);
    EXPECT_GT(d.info.global_memory_bytes, 0u);
  }
}

TEST(Device, SelectsByTypeAndSubstring) {
  auto any = select_device("auto");
  EXPECT_TRUE(any.info.type == "gpu" || any.info.type == "cpu");
  // Every device can be found again by a substring of its own name, in other letter case.
  for (const auto& d : find_devices()) {
    std::string spec = d.info.name.substr(0, 6);
    for (auto& c : spec) c = static_cast<char>(std::toupper(c));
    EXPECT_EQ(select_device(spec).info.name.substr(0, 6), d.info.name.substr(0, 6));
  }
}

TEST(Device, UnknownSpecNamesTheFlagAndListsDevices) {
  std::string message = test::expect_error(Code::InvalidArgument, "--device no-such-device-xyz",
                                           [] { select_device("no-such-device-xyz"); });
  EXPECT_NE(message.find(find_devices()[0].info.name), std::string::npos) << message;
}

TEST(Runtime, BuildsEveryEmbeddedProgramOnce) {
  Runtime& rt = test::runtime();
  ASSERT_TRUE(rt.built());
  KernelSources embedded;
  ASSERT_EQ(rt.builds().size(), embedded.programs().size());
  bool found = false;
  for (const auto& b : rt.builds()) {
    EXPECT_GE(b.seconds, 0.0);
    if (b.program == "runtime/selftest.cl") {
      found = true;
      EXPECT_NE(std::find(b.kernels.begin(), b.kernels.end(), "axpy"), b.kernels.end());
      EXPECT_NE(std::find(b.kernels.begin(), b.kernels.end(), "fill"), b.kernels.end());
    }
  }
  EXPECT_TRUE(found);
}

TEST(Runtime, AxpyKernelComputesExactly) {
  Runtime& rt = test::runtime();
  const uint32_t n = 1000;  // not a multiple of the work-group size: the bounds check matters
  std::vector<float> x(n), y(n);
  for (uint32_t i = 0; i < n; ++i) x[i] = float(i), y[i] = 0.5f * float(i) + 1;
  cl::Buffer bx = test::upload(x), by = test::upload(y);
  auto lock = rt.exclusive();
  Kernel<cl_float, cl::Buffer, cl::Buffer, cl_int> axpy(rt, "runtime/selftest.cl", "axpy");
  axpy.launch(cl::NDRange(round_up(n, 64)), cl::NDRange(64), 2.0f, bx, by, cl_int(n));
  auto out = test::read<float>(by, n);
  for (uint32_t i = 0; i < n; ++i) ASSERT_EQ(out[i], 2.0f * float(i) + 0.5f * float(i) + 1) << i;
}

// launch_rows runs each work-item of the grid once and none past it, for widths below, at and above a
// row group and between multiples of it (a second launch at an offset).
TEST(Kernel, LaunchRowsRunsEachCellOfTheGridOnce) {
  Runtime& rt = test::runtime();
  auto lock = rt.exclusive();
  Kernel<cl::Buffer, cl_int> count_ids(rt, "runtime/selftest.cl", "count_ids");
  for (auto [nx, ny] : {std::pair<size_t, size_t>{1, 1}, {100, 3}, {kRowGroup, 2}, {300, 5}, {2 * kRowGroup + 7, 1}}) {
    const size_t cells = nx * ny, guard = kRowGroup;  // counts past the grid would land in the guard cells
    cl::Buffer out = test::upload(std::vector<float>(cells + guard, 0.0f));
    count_ids.launch_rows(nx, ny, out, cl_int(nx));
    auto counts = test::read<float>(out, cells + guard);
    for (size_t c = 0; c < cells + guard; ++c)
      ASSERT_EQ(counts[c], c < cells ? 1.0f : 0.0f) << nx << " x " << ny << ", cell " << c;
  }
}

TEST(Kernel, AGroupLargerThanTheDeviceAllowsIsLeftToTheDevice) {
  Runtime& rt = test::runtime();
  auto lock = rt.exclusive();
  Kernel<cl::Buffer, cl_float, cl_int> fill(rt, "runtime/selftest.cl", "fill");
  const size_t limit =
      rt.kernel("runtime/selftest.cl", "fill").getWorkGroupInfo<CL_KERNEL_WORK_GROUP_SIZE>(rt.device());
  const size_t group = 2 * limit, n = 3 * group;  // one group over the limit (CL_INVALID_WORK_GROUP_SIZE as such)
  cl::Buffer out(rt.context(), CL_MEM_READ_WRITE, n * sizeof(float));
  fill.launch(cl::NDRange(n), cl::NDRange(group), out, 2.5f, cl_int(n));
  auto values = test::read<float>(out, n);
  for (size_t i = 0; i < n; ++i) ASSERT_EQ(values[i], 2.5f) << i;
}

// A launch with other argument types does not compile; these are the conditions its static_asserts test.
static_assert(KernelArgsMatch<std::tuple<float, cl::Buffer, const cl::Buffer&, int>,
                              std::tuple<cl_float, cl::Buffer, cl::Buffer, cl_int>>::value);
static_assert(!KernelArgsMatch<std::tuple<float, cl::Buffer, cl::Buffer, unsigned>,
                               std::tuple<cl_float, cl::Buffer, cl::Buffer, cl_int>>::value);  // uint for int
static_assert(!KernelArgsMatch<std::tuple<double>, std::tuple<cl_float>>::value);
static_assert(!KernelArgsMatch<std::tuple<float>, std::tuple<cl_float, cl_int>>::value);  // too few

// The message of the Error(Internal) that creating Kernel<Args...>(axpy) throws, or "" when it does not.
template <typename... Args>
std::string axpy_declared_as() {
  try {
    Kernel<Args...> k(test::runtime(), "runtime/selftest.cl", "axpy");
    return "";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Code::Internal);
    return e.what();
  }
}

TEST(Kernel, WrongArgumentCountThrowsAtCreation) {
  std::string msg = axpy_declared_as<cl_float, cl::Buffer, cl::Buffer>();
  EXPECT_NE(msg.find("kernel axpy of runtime/selftest.cl takes 4 arguments; the host declares 3"), std::string::npos)
      << msg;
}

TEST(Kernel, WrongArgumentTypeThrowsAtCreationNamingTheArgument) {
  std::string msg = axpy_declared_as<cl_float, cl_float, cl::Buffer, cl_int>();  // a float for a buffer
  EXPECT_NE(msg.find("kernel axpy of runtime/selftest.cl: argument 1 (x) is __global float*"), std::string::npos)
      << msg;
  msg = axpy_declared_as<cl_float, cl::Buffer, cl::Buffer, cl_uint>();  // uint for the int count
  EXPECT_NE(msg.find("argument 3 (n) is int on the device; the host declares uint"), std::string::npos) << msg;
  msg = axpy_declared_as<cl::Buffer, cl::Buffer, cl::Buffer, cl_int>();  // a buffer for the float
  EXPECT_NE(msg.find("argument 0 (a) is float"), std::string::npos) << msg;
  EXPECT_EQ((axpy_declared_as<cl_float, cl::Buffer, cl::Buffer, cl_int>()), "");  // the right declaration
}

TEST(Kernel, ProfileModeRecordsDeviceTimePerKernel) {
  RuntimeOptions options;
  options.program_prefixes = {"runtime/"};
  options.profile_kernels = true;
  Runtime rt(options);
  rt.build_programs();
  ASSERT_TRUE(rt.profiling());
  const cl_int n = 1 << 20;
  cl::Buffer out(rt.context(), CL_MEM_READ_WRITE, n * sizeof(float));
  Kernel<cl::Buffer, cl_float, cl_int> fill(rt, "runtime/selftest.cl", "fill");
  for (int i = 0; i < 2; ++i) fill.launch(cl::NDRange(n), cl::NullRange, out, 3.0f, n);
  std::vector<KernelTiming> timings = rt.kernel_timings();
  ASSERT_EQ(timings.size(), 1u);
  EXPECT_EQ(timings[0].program, "runtime/selftest.cl");
  EXPECT_EQ(timings[0].kernel, "fill");
  EXPECT_EQ(timings[0].launches, 2u);
  EXPECT_GT(timings[0].device_ns, 0u);
}

TEST(Kernel, WithoutProfileModeNothingIsRecorded) {
  Runtime& rt = test::runtime();
  if (rt.profiling()) GTEST_SKIP() << "SQUALL_PROFILE_KERNELS=1 is set";
  cl::Buffer out(rt.context(), CL_MEM_READ_WRITE, 64 * sizeof(float));
  auto lock = rt.exclusive();
  Kernel<cl::Buffer, cl_float, cl_int> fill(rt, "runtime/selftest.cl", "fill");
  fill.launch(cl::NDRange(64), cl::NullRange, out, 1.0f, cl_int(64));
  rt.queue().finish();
  EXPECT_TRUE(rt.kernel_timings().empty());
}

TEST(Runtime, UnknownKernelIsAnError) {
  EXPECT_THROW(test::runtime().kernel("runtime/none.cl", "axpy"), Error);
  EXPECT_THROW(test::runtime().kernel("runtime/selftest.cl", "no_such_kernel"), cl::Error);
}

TEST(BufferPool, ReusesBuffersOfTheSameSize) {
  BufferPool pool(test::runtime().context(), 1 << 20);
  cl_mem first;
  {
    auto a = pool.acquire(4096);
    first = a.buffer()();
  }
  EXPECT_EQ(pool.idle_bytes(), 4096u);
  {
    auto b = pool.acquire(4096);  // the same buffer comes back
    EXPECT_EQ(b.buffer()(), first);
    auto c = pool.acquire(4096);  // a second lease at once needs a second buffer
    EXPECT_NE(c.buffer()(), first);
    auto d = pool.acquire(8192);  // another shape is another buffer
  }
  EXPECT_EQ(pool.allocations(), 3u);
  auto big = pool.acquire(2 << 20);  // larger than the idle cap: not kept when handed back
  big = BufferLease();
  EXPECT_EQ(pool.idle_bytes(), 4096u * 2 + 8192u);
}

// A pinned buffer is host memory mapped for its lifetime: what the host writes there a copy on the device
// reads, and what a read command writes there the host reads. It is pooled apart from device buffers of
// the same size, and comes back mapped at the same address.
TEST(BufferPool, APinnedBufferIsHostMemoryMappedForItsLifetime) {
  Runtime& runtime = test::runtime();
  BufferPool pool(runtime.context(), 1 << 20);
  constexpr size_t n = 1000;
  void* host = nullptr;
  {
    auto pinned = pool.acquire(n * sizeof(float), Memory::Pinned);
    auto device = pool.acquire(n * sizeof(float));
    ASSERT_NE(pinned.host(), nullptr);
    EXPECT_EQ(device.host(), nullptr);
    host = pinned.host();
    auto* values = static_cast<float*>(host);
    std::fill(values, values + n, 4.0f);
    auto lock = runtime.exclusive();
    const cl::CommandQueue& queue = runtime.queue();
    queue.enqueueWriteBuffer(device.buffer(), CL_TRUE, 0, n * sizeof(float), values);
    std::vector<float> twice(n, 8.0f);
    queue.enqueueWriteBuffer(device.buffer(), CL_TRUE, 0, 10 * sizeof(float), twice.data());
    queue.enqueueReadBuffer(device.buffer(), CL_TRUE, 0, n * sizeof(float), values);
    EXPECT_EQ(std::count(values, values + 10, 8.0f), 10);
    EXPECT_EQ(std::count(values + 10, values + n, 4.0f), long(n - 10));
  }
  EXPECT_EQ(pool.idle_bytes(), 2 * n * sizeof(float));
  auto again = pool.acquire(n * sizeof(float), Memory::Pinned);
  EXPECT_EQ(again.host(), host);
  EXPECT_EQ(pool.allocations(), 2u);
  BufferPool keeps_none(runtime.context(), 0);  // a buffer handed back is released: unmapped first
  for (int i = 0; i < 3; ++i) EXPECT_NE(keeps_none.acquire(64, Memory::Pinned).host(), nullptr);
  EXPECT_EQ(keeps_none.allocations(), 3u);
  EXPECT_EQ(keeps_none.idle_bytes(), 0u);
}

// Attached to a memory budget, the idle buffers count in it as cached memory: a call that needs the room
// takes them back, and a buffer handed back that finds no room is released rather than kept.
TEST(BufferPool, IdleBuffersCountInTheMemoryBudgetAndGiveWayToCalls) {
  Limits limits;
  limits.memory_budget = 1 << 20;
  LimitGate gate(limits);
  BufferPool pool(test::runtime().context(), 1 << 20);
  pool.attach(&gate);
  pool.acquire(256 << 10);
  pool.acquire(128 << 10);
  EXPECT_EQ(pool.idle_bytes(), 384u << 10);
  EXPECT_EQ(gate.cached_memory_bytes(), 384u << 10);
  EXPECT_EQ(gate.memory_bytes(), 384u << 10);
  {
    Slot call = gate.acquire_memory("a call", 768 << 10);  // room for it: the larger idle buffer goes
    EXPECT_EQ(pool.idle_bytes(), 128u << 10);
    EXPECT_EQ(gate.memory_bytes(), 896u << 10);
    pool.acquire(256 << 10);  // handed back with 128 KiB of room left: released
    EXPECT_EQ(pool.idle_bytes(), 128u << 10);
  }
  pool.attach(nullptr);  // detached: the gate holds nothing of the pool's
  EXPECT_EQ(gate.memory_bytes(), 0u);
  EXPECT_EQ(gate.cached_memory_bytes(), 0u);
}

// A daemon's cache keeps a quarter of the memory budget, no more than an eighth of the device's memory, and at
// least its own floor: a 4096^2 ocean layer's spectrum (six float planes, 384 MiB) under a budget of 1.5 GiB.
TEST(DeviceCache, ADaemonsCacheKeepsAQuarterOfTheBudgetAndAnEighthOfTheDevice) {
  constexpr uint64_t MiB = uint64_t(1) << 20, GiB = uint64_t(1) << 30;
  EXPECT_GE(cache_bound(3 * GiB / 2, 16 * GiB, 0), 4096 * 4096 * 6 * sizeof(float));
  EXPECT_EQ(cache_bound(8 * GiB, 141 * GiB, 256 * MiB), 2 * GiB);           // the budget's quarter
  EXPECT_EQ(cache_bound(2048 * GiB, 141 * GiB, 256 * MiB), 141 * GiB / 8);  // a GPU's eighth
  EXPECT_EQ(cache_bound(100 * MiB, 16 * GiB, 64 * MiB), 64 * MiB);          // the floor
}

// A buffer the cache keeps holds its bytes in the budget until the cache and every call that got it have
// released it. A call that needs the room takes back only buffers no other call uses (evicting one in use
// would free nothing); one evicted while in use (past the cache's own limit) holds its bytes on as call
// memory, which no cache can give back, until its last use ends.
TEST(DeviceCache, ABufferStillInUseStillCountsInTheMemoryBudget) {
  constexpr size_t kBytes = 512 << 10;
  auto make = [] {
    return DeviceCache<int>::Made{cl::Buffer(test::runtime().context(), CL_MEM_READ_WRITE, kBytes), kBytes};
  };
  Limits limits;
  limits.memory_budget = 1 << 20;
  LimitGate gate(limits);
  {
    DeviceCache<int> cache(1 << 20, &gate, "a test buffer");
    cl::Buffer in_use = cache.get(1, make);
    EXPECT_EQ(gate.cached_memory_bytes(), kBytes);
    test::expect_error(Code::ResourceExhausted, "--memory-budget", [&] { gate.acquire_memory("a call", 768 << 10); });
    EXPECT_EQ(cache.entries(), 1u);  // in use: kept
    in_use = cl::Buffer();           // its last use ends: the cache gives it back for the next call
    Slot call = gate.acquire_memory("a call", 768 << 10);
    EXPECT_EQ(cache.entries(), 0u);
    EXPECT_EQ(gate.memory_bytes(), 768u << 10);
  }
  DeviceCache<int> small(kBytes + 1, &gate, "a test buffer");
  cl::Buffer in_use = small.get(1, make);
  small.get(2, make);  // past the cache's limit: buffer 1 is evicted while in use
  EXPECT_EQ(small.entries(), 1u);
  EXPECT_EQ(gate.cached_memory_bytes(), kBytes);  // buffer 2's
  EXPECT_EQ(gate.memory_bytes(), 2 * kBytes);     // and buffer 1's, as call memory
  in_use = cl::Buffer();  // the runtime frees it, then (maybe on a thread of its own) runs its callback
  EXPECT_TRUE(gate.await_memory_room(limits.memory_budget - kBytes));
  EXPECT_EQ(gate.memory_bytes(), kBytes);
}

// However small its buffers, a cache keeps at most kMaxEntries of them, the most recently used: a client
// asking for ever new 96-byte spectra cannot make every lookup walk an endless list.
TEST(DeviceCache, ACacheKeepsAtMostItsEntryCountOfTinyBuffers) {
  constexpr size_t kBytes = 96, kMost = DeviceCache<int>::kMaxEntries;
  auto make = [] {
    return DeviceCache<int>::Made{cl::Buffer(test::runtime().context(), CL_MEM_READ_WRITE, kBytes), kBytes};
  };
  DeviceCache<int> cache(1 << 30, nullptr, "a test buffer");
  cache.get(0, make);
  for (int key = 1; key < int(kMost) + 100; ++key) {
    cache.get(key, make);
    cache.get(0, make);  // used again each time: kept
  }
  EXPECT_EQ(cache.entries(), kMost);
  EXPECT_EQ(cache.bytes(), kMost * kBytes);
  EXPECT_TRUE(cache.holds(0));
  EXPECT_TRUE(cache.holds(int(kMost) + 99));
  EXPECT_FALSE(cache.holds(1));
  EXPECT_EQ(cache.computed(), kMost + 100);
}

// A call that finds another call computing its key waits for it, but a cancelled one stops waiting (within
// the cache's look interval, 50 ms): here the other's computation ends only once the cancelled call has
// stopped, and is kept.
TEST(DeviceCache, ACancelledCallStopsWaitingForAnothersComputation) {
  constexpr size_t kBytes = 4096;
  DeviceCache<int> cache(1 << 20, nullptr, "a test buffer");
  std::atomic<bool> computing{false}, stopped{false};
  std::thread first([&] {
    cache.get(1, [&] {
      computing = true;
      while (!stopped) std::this_thread::sleep_for(std::chrono::milliseconds(1));
      return DeviceCache<int>::Made{cl::Buffer(test::runtime().context(), CL_MEM_READ_WRITE, kBytes), kBytes};
    });
  });
  while (!computing) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  bool computed_again = false;
  test::expect_error(Code::Cancelled, "waiting for another call to make a test buffer cancelled", [&] {
    cache.get(
        1, [&] { return computed_again = true, DeviceCache<int>::Made{}; }, Cancellation([] { return true; }));
  });
  stopped = true;
  first.join();
  EXPECT_FALSE(computed_again);
  EXPECT_EQ(cache.entries(), 1u);
}

// On a CPU device each pool buffer is made over host memory of its own, aligned, in which the device
// computes: what the device writes is there, and a map of the buffer returns that memory. Other buffers
// name none.
TEST(BufferPool, ACpuDeviceComputesInTheHostStorageOfItsBuffers) {
  const bool cpu = test::runtime().device_info().type == "cpu";
  BufferPool pool(test::runtime().context(), 1 << 20, cpu);
  auto lease = pool.acquire(1000);  // not a multiple of the alignment
  EXPECT_EQ(host_storage(cl::Buffer(test::runtime().context(), CL_MEM_READ_WRITE, 1000)), nullptr);
  void* storage = host_storage(lease.buffer());
  EXPECT_EQ(test::runtime().computes_in_host_storage(), cpu && test::host_buffers_on_cpu())
      << "the runtime's own probe of the same, unless told to make its buffers as a GPU's";
  if (!cpu) {
    EXPECT_EQ(storage, nullptr) << "only a CPU device's pool makes buffers over host memory";
    return;
  }
  ASSERT_NE(storage, nullptr);
  EXPECT_EQ(reinterpret_cast<uintptr_t>(storage) % kHostAlignment, 0u);
  auto lock = test::runtime().exclusive();
  const cl::CommandQueue& queue = test::runtime().queue();
  queue.enqueueFillBuffer(lease.buffer(), cl_float(2.5f), 0, 248 * sizeof(float));
  queue.finish();
  const float* values = static_cast<const float*>(storage);
  EXPECT_EQ(std::count(values, values + 248, 2.5f), 248);
  void* mapped = queue.enqueueMapBuffer(lease.buffer(), CL_TRUE, CL_MAP_READ, 0, 1000);
  EXPECT_EQ(mapped, storage);
  queue.enqueueUnmapMemObject(lease.buffer(), mapped);
  queue.finish();
}

// Holds the calling thread's queue until `gate` opens, 50 ms later: work queued meanwhile has not run
// when the caller's next statements do, unless they wait for it.
class QueueGate {
 public:
  explicit QueueGate(Runtime& runtime) : gate_(runtime.context()) {
    std::vector<cl::Event> after{gate_};
    runtime.queue().enqueueBarrierWithWaitList(&after);
    opener_ = std::thread([this] {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      gate_.setStatus(CL_COMPLETE);
    });
  }
  ~QueueGate() { opener_.join(); }

 private:
  cl::UserEvent gate_;
  std::thread opener_;
};

size_t count_of(const std::vector<float>& values, float v) {
  return size_t(std::count(values.begin(), values.end(), v));
}

// Where the device computes in its pool buffers' host storage, a read of a pool buffer queues no
// command; a buffer of no host storage is read by one. Either way the bytes are those the device wrote
// last: a copy made before the queue has finished would find the first fill's zeros.
TEST(HostTransfer, ReadsPoolBuffersWithNoCommandAfterTheQueueHasFinished) {
  Runtime& runtime = test::runtime();
  constexpr size_t n = 1 << 16, tail = 64;
  auto pooled = runtime.buffers().acquire(n * sizeof(float));
  cl::Buffer plain(runtime.context(), CL_MEM_READ_WRITE, tail * sizeof(float));
  auto lock = runtime.exclusive();
  const cl::CommandQueue& queue = runtime.queue();
  queue.enqueueFillBuffer(pooled.buffer(), cl_float(0), 0, n * sizeof(float));
  queue.finish();
  QueueGate gate(runtime);
  queue.enqueueFillBuffer(pooled.buffer(), cl_float(1), 0, n * sizeof(float));
  queue.enqueueFillBuffer(pooled.buffer(), cl_float(2), (n - tail) * sizeof(float), tail * sizeof(float));
  queue.enqueueFillBuffer(plain, cl_float(3), 0, tail * sizeof(float));
  std::vector<float> whole(n), end(tail), other(tail);
  ReadBack back(runtime);
  back.add(pooled.buffer(), 0, n * sizeof(float), whole.data());
  back.add(pooled.buffer(), (n - tail) * sizeof(float), tail * sizeof(float), end.data());
  back.add(plain, 0, tail * sizeof(float), other.data());
  EXPECT_EQ(back.commands(), runtime.computes_in_host_storage() ? 1u : 3u);
  back.wait();
  EXPECT_EQ(count_of(whole, 1.0f), n - tail);
  EXPECT_EQ(count_of(end, 2.0f), tail);
  EXPECT_EQ(count_of(other, 3.0f), tail);
}

// A write into a pool buffer's host storage (no command) lands after the commands queued before it, as a
// write command would: the fills queued behind the gate do not overwrite it.
TEST(HostTransfer, AWriteWithNoCommandComesAfterTheCommandsQueuedBeforeIt) {
  Runtime& runtime = test::runtime();
  constexpr size_t n = 1 << 16;
  auto pooled = runtime.buffers().acquire(n * sizeof(float));
  cl::Buffer plain(runtime.context(), CL_MEM_READ_WRITE, n * sizeof(float));
  auto lock = runtime.exclusive();
  const cl::CommandQueue& queue = runtime.queue();
  const std::vector<float> twos(n, 2.0f);
  std::vector<float> pooled_values(n), plain_values(n);
  {
    QueueGate gate(runtime);
    queue.enqueueFillBuffer(pooled.buffer(), cl_float(1), 0, n * sizeof(float));
    queue.enqueueFillBuffer(plain, cl_float(1), 0, n * sizeof(float));
    EXPECT_EQ(write_buffer(runtime, pooled.buffer(), n * sizeof(float), twos.data()),
              !runtime.computes_in_host_storage());
    EXPECT_TRUE(write_buffer(runtime, plain, n * sizeof(float), twos.data()));
    ReadBack back(runtime);
    back.add(pooled.buffer(), 0, n * sizeof(float), pooled_values.data());
    back.add(plain, 0, n * sizeof(float), plain_values.data());
    back.wait();
  }
  EXPECT_EQ(count_of(pooled_values, 2.0f), n);
  EXPECT_EQ(count_of(plain_values, 2.0f), n);
}

// A copy from or into host storage past the buffer's end is refused, as the command it replaces would be.
TEST(HostTransfer, ACopyPastTheEndOfABufferIsRefused) {
  Runtime& runtime = test::runtime();
  if (!runtime.computes_in_host_storage()) GTEST_SKIP() << "copies are commands on this device";
  auto pooled = runtime.buffers().acquire(1000);
  std::vector<char> bytes(1001);
  auto lock = runtime.exclusive();
  ReadBack back(runtime);
  test::expect_error(Code::Internal, "a read of 8 bytes at 996 runs past the end of a buffer of 1000",
                     [&] { back.add(pooled.buffer(), 996, 8, bytes.data()); });
  test::expect_error(Code::Internal, "a write of 1001 bytes at 0 runs past the end of a buffer of 1000",
                     [&] { write_buffer(runtime, pooled.buffer(), 1001, bytes.data()); });
  back.add(pooled.buffer(), 992, 8, bytes.data());
  back.wait();
}

// Views of ranges of a buffer the caller keeps. Of a pool buffer that the device computes in: its host
// storage itself, no copy, and the buffer goes back to the pool with the last view. Of device memory
// (the second pool's buffers on any device, the runtime's on a GPU): one pinned block of the runtime's
// pool, the ranges in it one after the other, which goes back with the last view. Either way the values
// are those the device wrote last: the write is held behind the gate when read_views() is called.
TEST(HostTransfer, ViewsKeepTheMemoryTheyView) {
  Runtime& runtime = test::runtime();
  constexpr size_t n = 4096, viewed = n / 4 + 5 + 8 + 3;
  // Off host storage, the first two are one read.
  const FloatRange ranges[] = {{n / 2, n / 4}, {n / 2 + n / 4, 5}, {0, 8}, {n - 3, 3}};
  BufferPool device_memory(runtime.context(), 1 << 20, false);  // never host storage
  for (BufferPool* pool : {&runtime.buffers(), &device_memory}) {
    BufferLease lease = pool->acquire(n * sizeof(float));
    const void* storage = computed_host_storage(runtime, lease.buffer());
    std::vector<float> values(n);
    for (size_t i = 0; i < n; ++i) values[i] = float(i);
    auto lock = runtime.exclusive();
    std::vector<FloatView> views;
    {
      QueueGate gate(runtime);
      runtime.queue().enqueueWriteBuffer(lease.buffer(), CL_FALSE, 0, n * sizeof(float), values.data());
      views = read_views(runtime, std::move(lease), ranges);
      ASSERT_EQ(views.size(), 4u);
      for (size_t r = 0; r < 4; ++r) {  // before the gate's destructor lets the queue run (if it has not)
        ASSERT_EQ(views[r].size(), ranges[r].count);
        for (size_t i = 0; i < ranges[r].count; ++i) ASSERT_EQ(views[r][i], float(ranges[r].offset + i)) << r;
      }
    }
    const float* first = views[0].data();
    if (storage) {
      EXPECT_EQ(first, static_cast<const float*>(storage) + n / 2) << "the buffer's own host storage";
    } else {
      EXPECT_EQ(views[1].data(), first + n / 4) << "one pinned block";
      EXPECT_EQ(views[2].data(), first + n / 4 + 5);
      EXPECT_EQ(views[3].data(), first + n / 4 + 5 + 8);
    }
    views.clear();  // what they held goes back to the pool, and comes out again
    if (storage) {
      EXPECT_EQ(host_storage(pool->acquire(n * sizeof(float)).buffer()), storage);
    } else {
      EXPECT_EQ(runtime.buffers().acquire(viewed * sizeof(float), Memory::Pinned).host(), first);
    }
  }
}

TEST(HostTransfer, RangesThatFollowOneAnotherAreReadAsOne) {
  const FloatRange ranges[] = {{0, 3}, {100, 0}, {3, 4}, {7, 0}, {7, 2}, {12, 1}, {13, 1}, {5, 2}, {7, 1}};
  const std::vector<FloatRange> runs = contiguous_runs(ranges);
  // In the order given (no sort, no overlap merged); ranges of no floats, wherever they are, break no run.
  const FloatRange expected[] = {{0, 9}, {12, 2}, {5, 3}};
  ASSERT_EQ(runs.size(), std::size(expected));
  for (size_t i = 0; i < runs.size(); ++i) {
    EXPECT_EQ(runs[i].offset, expected[i].offset) << i;
    EXPECT_EQ(runs[i].count, expected[i].count) << i;
  }
  EXPECT_TRUE(contiguous_runs({}).empty());
}

TEST(KernelSources, SplicesIncludesOnceAndReadsBuildOptions) {
  std::string dir = test::temp_dir("kernels");
  write(dir + "/common/a.clh", "#define A 1\n");
  write(dir + "/common/b.clh", "#include \"common/a.clh\"\n#define B 2\n");
  write(dir + "/x/prog.cl",
        "// squall-build-options: -cl-fast-relaxed-math\n#include \"common/a.clh\"\n"
        "#include \"common/b.clh\"\n__kernel void k(__global int* o) { o[0] = A + B; }\n");
  KernelSources sources(dir);
  ASSERT_EQ(sources.programs(), std::vector<std::string>{"x/prog.cl"});
  std::string text = sources.expanded("x/prog.cl");
  EXPECT_EQ(text.find("#define A 1"), text.rfind("#define A 1"));  // spliced once
  EXPECT_NE(text.find("#define B 2"), std::string::npos);
  EXPECT_EQ(sources.build_options("x/prog.cl"), " -cl-fast-relaxed-math");
}

TEST(KernelSources, MissingIncludeNamesBothFiles) {
  std::string dir = test::temp_dir("kernels-missing");
  write(dir + "/p.cl", "#include \"nowhere.clh\"\n");
  test::expect_error(Code::Internal, "nowhere.clh not found (included from p.cl)",
                     [&] { KernelSources(dir).expanded("p.cl"); });
}

TEST(Runtime, FailedBuildReportsTheDeviceBuildLog) {
  std::string dir = test::temp_dir("kernels-broken");
  write(dir + "/bad/broken.cl", "__kernel void k(__global float* o) { o[0] = undefined_symbol; }\n");
  RuntimeOptions options;
  options.kernel_dir = dir;
  Runtime rt(options);
  std::string msg = test::expect_error(Code::Internal, "bad/broken.cl failed to build", [&] { rt.build_programs(); });
  EXPECT_NE(msg.find("undefined_symbol"), std::string::npos) << msg;  // the compiler's own words
}

TEST(Runtime, KernelCacheDirectoryIsStableAndPopulated) {
  test::runtime();  // built: PoCL has written its cache
  const char* dir = std::getenv("POCL_CACHE_DIR");
  ASSERT_NE(dir, nullptr);
  EXPECT_EQ(configure_kernel_cache(), dir);  // an explicit environment wins
  EXPECT_TRUE(std::filesystem::is_directory(dir));
  if (test::runtime().device_info().platform.find("Portable") != std::string::npos) {
    EXPECT_FALSE(std::filesystem::is_empty(dir)) << "PoCL wrote nothing to " << dir;
  }
}

}  // namespace
}  // namespace squall
