// The device's queues (--device-queues): two requests hold two queues at once and a third waits for one;
// one kernel object launched from two queues at once keeps each launch's arguments; a buffer handed back
// under one queue goes to another only after that queue's lease has ended (its work finished); one
// queue serializes as the single in-order queue did; a freed queue goes to the request that waited longest,
// unless a much shorter kind of work asks meanwhile, which goes first a bounded number of times; long work
// holds about half the queues at most while much shorter work is about, and the rest are kept for it; holds
// alone and beside others are learned apart.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <future>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "common/error.h"
#include "runtime/kernel.h"
#include "runtime/runtime.h"
#include "support/expect_error.h"

namespace squall {
namespace {

// A runtime of the CPU device with two queues and the runtime/ programs (built once per test binary).
Runtime& two_queue_runtime() {
  static Runtime* instance = [] {
    RuntimeOptions options;
    if (const char* d = std::getenv("SQUALL_TEST_DEVICE")) options.device = d;
    options.program_prefixes = {"runtime/"};
    options.queues = 2;
    auto* r = new Runtime(options);  // never destroyed, like test::runtime()
    r->build_programs();
    return r;
  }();
  return *instance;
}

TEST(DeviceQueues, TwoLeasesHoldTwoQueuesAtOnceAndAThirdWaits) {
  Runtime& rt = two_queue_runtime();
  ASSERT_EQ(rt.queue_count(), 2u);
  std::promise<void> second_held, release;
  std::shared_future<void> released = release.get_future().share();
  std::atomic<bool> third_held{false};
  const cl::CommandQueue* holder_queue = nullptr;
  const auto waited = rt.device_wait();
  std::thread holder([&] {
    auto lease = rt.exclusive();
    EXPECT_EQ(held_queue_slot(), int(lease.slot()));
    holder_queue = &rt.queue();
    second_held.set_value();
    released.wait();
  });
  second_held.get_future().wait();
  {
    auto lease = rt.exclusive();  // the other queue, while the holder keeps its own
    EXPECT_EQ(held_queue_slot(), int(lease.slot()));
    EXPECT_NE(&rt.queue(), holder_queue);
    std::thread third([&] {
      auto lease3 = rt.exclusive();
      third_held = true;
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    EXPECT_FALSE(third_held) << "a third request ran while both queues were held";
    release.set_value();
    third.join();
  }
  holder.join();
  EXPECT_TRUE(third_held);
  EXPECT_EQ(held_queue_slot(), -1);
  EXPECT_GT(rt.device_wait().seconds, waited.seconds) << "the third request's wait is counted";
}

// Two threads launch the same Kernel<> object 200 times each, on their own queues, each filling its own
// buffer with its own value: with one kernel object for both queues, the arguments one thread sets
// would be launched by the other.
TEST(DeviceQueues, OneKernelLaunchedFromTwoQueuesKeepsEachLaunchsArguments) {
  Runtime& rt = two_queue_runtime();
  Kernel<cl::Buffer, cl_float, cl_int> fill(rt, "runtime/selftest.cl", "fill");
  const int n = 4096;
  std::atomic<int> wrong{0};
  auto run = [&](float value) {
    cl::Buffer buffer(rt.context(), CL_MEM_READ_WRITE, n * sizeof(float));
    std::vector<float> out(n);
    for (int i = 0; i < 200; ++i) {
      auto lease = rt.exclusive();
      fill.launch(cl::NDRange(n), cl::NullRange, buffer, cl_float(value + float(i)), cl_int(n));
      rt.queue().enqueueReadBuffer(buffer, CL_TRUE, 0, n * sizeof(float), out.data());
      for (float v : out)
        if (v != value + float(i)) ++wrong;
    }
  };
  std::thread a(run, 1000.0f), b(run, 2000.0f);
  a.join();
  b.join();
  EXPECT_EQ(wrong.load(), 0);
}

TEST(DeviceQueues, ABufferHandedBackUnderOneQueueGoesToAnotherOnlyWhenItsLeaseEnds) {
  Runtime& rt = two_queue_runtime();
  const size_t bytes = 12345 * 4;  // a size of its own in the pool
  std::promise<void> handed_back, other_done;
  std::shared_future<void> other = other_done.get_future().share();
  cl_mem first_buffer = nullptr;
  std::thread first([&] {
    auto lease = rt.exclusive();
    {
      BufferLease b = rt.buffers().acquire(bytes);
      first_buffer = b.buffer()();
    }
    {
      BufferLease again = rt.buffers().acquire(bytes);  // the same queue: after its own work, in order
      EXPECT_EQ(again.buffer()(), first_buffer);
    }
    handed_back.set_value();
    other.wait();
  });
  handed_back.get_future().wait();
  BufferLease kept;  // kept out of the pool, which then holds only the first thread's buffer
  {
    auto lease = rt.exclusive();  // the other queue, while the first is still held
    kept = rt.buffers().acquire(bytes);
    EXPECT_NE(kept.buffer()(), first_buffer) << "a buffer went to another queue while its queue was held";
  }
  other_done.set_value();
  first.join();  // the first lease has ended: its buffer is free for every queue
  auto lease = rt.exclusive();
  BufferLease b = rt.buffers().acquire(bytes);
  EXPECT_EQ(b.buffer()(), first_buffer);
}

// A request that gives its queue back and asks again at once (as a long render does between slices)
// goes behind the request already waiting: the freed queue is handed to the first in line.
TEST(DeviceQueues, AFreedQueueGoesToTheRequestWaitingNotToOneAskingLater) {
  Runtime& rt = two_queue_runtime();
  std::promise<void> other_held, finished;
  std::shared_future<void> done = finished.get_future().share();
  std::thread other([&] {
    auto lease = rt.exclusive();
    other_held.set_value();
    done.wait();
  });
  other_held.get_future().wait();
  auto lease = rt.exclusive();
  std::mutex mutex;
  std::vector<std::string> order;
  std::thread waiter([&] {
    auto mine = rt.exclusive();
    std::lock_guard<std::mutex> lock(mutex);
    order.push_back("waiting");
  });
  while (rt.device_wait().waiting == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  lease.unlock();
  lease = rt.exclusive();
  {
    std::lock_guard<std::mutex> lock(mutex);
    order.push_back("asking later");
  }
  lease.unlock();  // before the join: if the queue went to this thread, the waiter still gets one
  waiter.join();
  finished.set_value();
  other.join();
  EXPECT_EQ(order, (std::vector<std::string>{"waiting", "asking later"}));
  EXPECT_EQ(rt.device_wait().waiting, 0u);
}

// Queues of the runtime's device (one unless told), and the order in which callers that wait get one.
struct QueuesInLine {
  explicit QueuesInLine(size_t count = 1)
      : slots(two_queue_runtime().context(), two_queue_runtime().device(), count, 0, nullptr) {}
  QueueSlots slots;
  std::mutex mutex;
  std::vector<std::string> order;
  std::vector<std::thread> callers;

  ~QueuesInLine() {
    for (auto& c : callers)
      if (c.joinable()) c.join();
  }
  // A caller of `kind` that waits in line and records `name` when it gets a queue. Returns once it is in
  // line, or after 2 s (the test's expectations then fail; a caller never served hangs the test).
  void ask(const WorkKind& kind, const std::string& name) {
    const size_t before = slots.waiting();
    callers.emplace_back([this, kind, name] {
      auto lease = slots.acquire(kind);
      std::lock_guard<std::mutex> lock(mutex);
      order.push_back(name);
    });
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(2);
    while (slots.waiting() == before && std::chrono::steady_clock::now() < give_up)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  std::vector<std::string> served() {
    for (auto& c : callers) c.join();
    return order;
  }
};

constexpr WorkKind kTile{"test.tile", 1 << 20}, kStep{"test.step", 1 << 16}, kRender{"test.render", 4096};

// Holds alone on the device and beside other leases are learned apart, and the smaller mean is expected:
// a kind's hold beside others is stretched by their work, and its first hold alone may carry one-off costs.
TEST(DeviceQueues, TheSmallerOfTheHoldsAloneAndBesideOthersIsExpected) {
  QueuesInLine q(2);
  q.slots.record_hold(kStep, 0.040, /*alone=*/false);
  EXPECT_DOUBLE_EQ(q.slots.expected_hold(kStep), 0.040) << "the only mean known";
  q.slots.record_hold(kStep, 0.010, /*alone=*/true);
  EXPECT_DOUBLE_EQ(q.slots.expected_hold(kStep), 0.010);
  q.slots.record_hold(kTile, 0.500, /*alone=*/true);  // a first tile that made its plans
  q.slots.record_hold(kTile, 0.030, /*alone=*/false);
  EXPECT_DOUBLE_EQ(q.slots.expected_hold(kTile), 0.030);

  // A lease that never shares the device is learned as alone; two that overlap are learned as beside
  // others. An 80 ms lease alone gives 80 ms; beside a second, short lease, the mean beside others is that
  // lease's hold, then moved an eighth of the way to 80 ms: about 10 ms. Learned as alone, the 80 ms
  // lease would leave the short one's hold expected.
  // Each kind starts with a 500 ms mean of the other sort, which the smaller mean must then be chosen over.
  const WorkKind alone{"test.alone", 1}, shared{"test.shared", 1};
  q.slots.record_hold(alone, 0.500, /*alone=*/false);
  q.slots.record_hold(shared, 0.500, /*alone=*/true);
  {
    auto lease = q.slots.acquire(alone);
    std::this_thread::sleep_for(std::chrono::milliseconds(80));
  }
  {
    auto first = q.slots.acquire(shared);
    std::thread([&] { auto second = q.slots.acquire(shared); }).join();
    std::this_thread::sleep_for(std::chrono::milliseconds(80));
  }
  EXPECT_GE(q.slots.expected_hold(alone), 0.080);  // a sleep lasts at least its time
  // 0.5 s if not learned; the margin over 80 ms is for a sleep that a loaded machine stretches
  EXPECT_LT(q.slots.expected_hold(alone), 0.300) << "the lease alone was learned beside others";
  EXPECT_GT(q.slots.expected_hold(shared), 0.008) << "the first lease was learned as alone";
  EXPECT_LT(q.slots.expected_hold(shared), 0.040) << "the overlapping leases were learned as alone";
}

// Leases of `kind`, each held on a thread of its own until `until` is ready: hold() returns once the lease
// is held, or after 2 s (the test's expectations then fail; a lease never granted hangs the test).
struct Holders {
  QueuesInLine& q;
  std::vector<std::thread> threads{};
  ~Holders() {
    for (auto& t : threads) t.join();
  }
  void hold(const WorkKind& kind, std::shared_future<void> until) {
    const size_t before = q.slots.held();
    threads.emplace_back([this, kind, until] {
      auto lease = q.slots.acquire(kind);
      until.wait();
    });
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(2);
    while (q.slots.held() == before && std::chrono::steady_clock::now() < give_up)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
};

// Waits up to 2 s for `done`.
void wait_for(const std::function<bool()>& done) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (!done() && std::chrono::steady_clock::now() < give_up)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

// With 1 ms renders about, 60 ms tiles hold two of four queues at most: a third tile waits although two
// are free, while a caller of no kind and a render take them. A freed queue then goes to the first in line
// that may take it: the render's to a caller of no kind behind the tile, a tile's to the tile.
TEST(DeviceQueues, WhileMuchShorterWorkIsAboutLongWorkHoldsHalfTheQueues) {
  QueuesInLine q(4);
  q.slots.record_hold(kTile, 0.060);
  q.slots.record_hold(kRender, 0.001);
  std::promise<void> end_tiles, end_render;
  std::shared_future<void> tiles_end = end_tiles.get_future().share(), render_ends = end_render.get_future().share();
  {
    Holders holders{q};
    holders.hold(kTile, tiles_end);
    holders.hold(kTile, tiles_end);
    q.ask(kTile, "tile");
    EXPECT_EQ(q.slots.held(), 2u) << "a third tile was let in";
    holders.hold({}, tiles_end);
    holders.hold(kRender, render_ends);
    EXPECT_EQ(q.slots.held(), 4u) << "work of no kind or a render waited with queues free";
    q.ask({}, "no kind, later");
    end_render.set_value();
    wait_for([&] { return q.slots.waiting() < 2 && q.slots.held() == 3; });  // the later caller came and went
    EXPECT_EQ(q.slots.waiting(), 1u) << "the render's queue went to neither waiter";
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    EXPECT_EQ(q.slots.waiting(), 1u) << "the tile took a queue beyond the limit";
    end_tiles.set_value();
  }
  EXPECT_EQ(q.served(), (std::vector<std::string>{"no kind, later", "tile"}));
}

// Without much shorter work about, a kind takes every queue: tiles alone, and tiles after renders that
// last asked more than kShortWorkWindow ago.
TEST(DeviceQueues, WithNoMuchShorterWorkAboutEveryQueueMayBeTaken) {
  QueuesInLine q(4);
  q.slots.record_hold(kTile, 0.060);
  std::promise<void> end;
  std::shared_future<void> ends = end.get_future().share();
  {
    Holders holders{q};
    for (int i = 0; i < 4; ++i) holders.hold(kTile, ends);
    EXPECT_EQ(q.slots.held(), 4u);
    end.set_value();
  }
  QueuesInLine later(4);  // holds of 60 ms and 1 ms again (the tiles above have taught q shorter ones)
  later.slots.record_hold(kTile, 0.060);
  later.slots.record_hold(kRender, 0.001);
  std::this_thread::sleep_for(QueueSlots::kShortWorkWindow + std::chrono::milliseconds(100));
  std::promise<void> end_again;
  std::shared_future<void> ends_again = end_again.get_future().share();
  Holders holders{later};
  for (int i = 0; i < 4; ++i) holders.hold(kTile, ends_again);
  EXPECT_EQ(later.slots.held(), 4u) << "queues were kept for renders that have gone";
  end_again.set_value();
}

// A tile waits at the limit while renders are about; once they have gone (no render asked for a queue in
// kShortWorkWindow), it takes one of the free queues by itself, with no other call to the pool, while the
// two tiles before it still hold theirs.
TEST(DeviceQueues, AWaiterWhoseKindIsNoLongerLimitedTakesAFreeQueue) {
  QueuesInLine q(4);
  q.slots.record_hold(kTile, 0.060);
  q.slots.record_hold(kRender, 0.001);
  std::promise<void> end;
  std::shared_future<void> ends = end.get_future().share();
  Holders holders{q};
  holders.hold(kTile, ends);
  holders.hold(kTile, ends);
  const auto asked = std::chrono::steady_clock::now();
  q.ask(kTile, "tile");
  std::this_thread::sleep_for(QueueSlots::kShortWorkWindow / 2);
  EXPECT_EQ(q.slots.waiting(), 1u) << "the tile took a queue beyond the limit while renders were about";
  wait_for([&] { return q.slots.waiting() == 0; });
  const auto waited = std::chrono::steady_clock::now() - asked;
  EXPECT_EQ(q.slots.waiting(), 0u) << "the tile still waits with two queues free";
  EXPECT_LT(waited, QueueSlots::kShortWorkWindow + QueueSlots::kShortWorkWindow / 2);  // polled every 1/8
  EXPECT_GE(q.slots.held(), 2u) << "the tiles before it still hold their queues";
  end.set_value();
  EXPECT_EQ(q.served(), (std::vector<std::string>{"tile"}));
}

TEST(DeviceQueues, LongWorkHoldsAboutHalfTheQueuesAtMost) {
  const std::vector<std::pair<size_t, size_t>> limits{{1, 1}, {2, 2}, {3, 2}, {4, 2}, {5, 3}, {8, 4}, {16, 8}};
  for (const auto& [count, limit] : limits) EXPECT_EQ(QueuesInLine(count).slots.long_limit(), limit) << count;
}

// A lease's hold is learned when it ends; later holds move the mean by an eighth of their difference;
// a size in another power of two is another kind.
TEST(DeviceQueues, TheQueuesLearnHowLongEachKindOfWorkHoldsOne) {
  QueuesInLine q;
  {
    auto lease = q.slots.acquire(kTile);
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
  }
  EXPECT_GE(q.slots.expected_hold(kTile), 0.030);  // a sleep lasts at least its time
  q.slots.record_hold(kRender, 0.010);
  q.slots.record_hold(kRender, 0.090);
  EXPECT_DOUBLE_EQ(q.slots.expected_hold(kRender), 0.020);
  EXPECT_EQ(q.slots.expected_hold({"test.render", 8192}), 0) << "a size twice as large is another kind";
  EXPECT_EQ(q.slots.expected_hold({"test.render", 8191}), 0.020) << "4096 to 8191: one kind";
}

// Each call site's leases, waits and holds are summed: a tile holds the queue 40 ms while a render
// waits for it; a lease of no kind is counted under "".
TEST(DeviceQueues, EachCallSitesWaitsAndHoldsAreSummed) {
  QueuesInLine q;
  {
    auto tile = q.slots.acquire(kTile);
    q.ask(kRender, "render");
    std::this_thread::sleep_for(std::chrono::milliseconds(40));
  }
  q.served();
  { auto unnamed = q.slots.acquire(); }
  const auto sites = q.slots.site_times();
  ASSERT_EQ(sites.size(), 3u);
  const auto& tile = sites.at("test.tile");
  const auto& render = sites.at("test.render");
  EXPECT_EQ(tile.leases, 1u);
  EXPECT_EQ(tile.wait_seconds, 0) << "the queue was free";
  EXPECT_GE(tile.hold_seconds, 0.040);  // a sleep lasts at least its time
  EXPECT_EQ(render.leases, 1u);
  EXPECT_GT(render.wait_seconds, 0.020) << "it waited for the tile's sleep, less the time it took to ask";
  EXPECT_LT(render.hold_seconds, tile.hold_seconds);
  EXPECT_EQ(sites.at("").leases, 1u);
}

// A render expected to take 1 ms goes ahead of a 60 ms tile waiting, but not of a caller of no kind
// (which may be short); a render of a size not learned yet waits in turn.
TEST(DeviceQueues, AMuchShorterKindOfWorkGoesAheadOfLongerWorkWaiting) {
  QueuesInLine q;
  q.slots.record_hold(kTile, 0.060);
  q.slots.record_hold(kRender, 0.001);
  {
    auto holder = q.slots.acquire();
    q.ask({}, "no kind");
    q.ask(kTile, "tile");
    q.ask(kRender, "render");
    q.ask({"test.render", 1 << 20}, "new render");
  }
  EXPECT_EQ(q.served(), (std::vector<std::string>{"no kind", "render", "tile", "new render"}));
}

// A 50 ms step keeps its turn behind a 60 ms tile, and a waiter is passed at most kMaxPassed times.
TEST(DeviceQueues, WorkOfAboutTheSameHoldKeepsItsTurnAndAWaiterIsPassedABoundedNumberOfTimes) {
  QueuesInLine q;
  q.slots.record_hold(kTile, 0.060);
  q.slots.record_hold(kStep, 0.050);
  q.slots.record_hold(kRender, 0.001);
  {
    auto holder = q.slots.acquire();
    q.ask(kTile, "tile");
    q.ask(kStep, "step");
    for (int i = 0; i <= QueueSlots::kMaxPassed; ++i) q.ask(kRender, "render " + std::to_string(i));
  }
  std::vector<std::string> expected;
  for (int i = 0; i < QueueSlots::kMaxPassed; ++i) expected.push_back("render " + std::to_string(i));
  expected.insert(expected.end(), {"tile", "step", "render 4"});
  EXPECT_EQ(q.served(), expected);
}

TEST(DeviceQueues, ASecondLeaseOnOneThreadIsAnInternalError) {
  Runtime& rt = two_queue_runtime();
  auto lease = rt.exclusive();
  test::expect_error(Code::Internal, "second device queue", [&] { auto again = rt.exclusive(); });
}

}  // namespace
}  // namespace squall
