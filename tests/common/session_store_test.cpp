// SessionStore: ids, the TTL on an injected clock, the session and byte limits of the LimitGate, and
// checkpoints that restore under the same id. No device needed.
#include "common/session_store.h"

#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <set>
#include <thread>

#include "common/byte_codec.h"
#include "support/expect_error.h"
#include "support/process.h"

namespace squall {
namespace {

using test::expect_error;
using namespace std::chrono_literals;

struct Counter {
  int value = 0;
};

class SessionStoreTest : public ::testing::Test {
 protected:
  SessionStore<Counter> store(Limits limits = {}, std::chrono::milliseconds ttl = 100ms) {
    gate_ = std::make_unique<LimitGate>(limits);
    return SessionStore<Counter>(*gate_, SessionPolicy{ttl, [this] { return now_; }}, "counter", "counter_id", "c-");
  }
  std::chrono::steady_clock::time_point now_{};
  std::unique_ptr<LimitGate> gate_;
};

// 128 bits from the kernel's generator: over 1000 ids each bit is set about half the time (binomial, sigma
// 16 of 500), where a counter or a clock would leave the high bits fixed.
TEST(SessionIds, EveryBitIsSetInAboutHalfOfThem) {
  int set[128] = {};
  for (int n = 0; n < 1000; ++n) {
    const std::string id = new_session_id("x-");
    ASSERT_EQ(id.size(), 2u + 32u) << id;
    for (int digit = 0; digit < 32; ++digit) {
      const int value = std::stoi(id.substr(2 + digit, 1), nullptr, 16);
      for (int bit = 0; bit < 4; ++bit) set[4 * digit + bit] += (value >> bit) & 1;
    }
  }
  for (int bit = 0; bit < 128; ++bit) EXPECT_NEAR(set[bit], 500, 100) << "bit " << bit;
}

TEST_F(SessionStoreTest, IdsAreDistinctAndCallsReachTheirSession) {
  auto s = store();
  std::set<std::string> ids;
  for (int i = 0; i < 20; ++i) ids.insert(s.add(s.reserve(0), std::make_shared<Counter>()));
  EXPECT_EQ(ids.size(), 20u);
  for (const auto& id : ids) {
    EXPECT_EQ(id.size(), 2u + 32u) << id;  // prefix + 128 bits in hex
    EXPECT_EQ(id.rfind("c-", 0), 0u) << id;
  }
  const std::string id = *ids.begin();
  s.with(id, [](Counter& c) { c.value += 3; });
  EXPECT_EQ(s.with(id, [](Counter& c) { return c.value; }), 3);
  expect_error(Code::NotFound, "counter_id = \"nope\"", [&] { s.get("nope"); });
}

// A client may propose a new session's id (in metadata, for a proxy to route on): one of a live session is
// refused naming where it came from, before anything is built under it.
TEST_F(SessionStoreTest, AProposedIdOfALiveSessionIsRefusedNamingTheProposal) {
  auto s = store();
  const std::string id = s.add(s.reserve(8), std::make_shared<Counter>());
  expect_error(Code::AlreadyExists, "metadata x-squall-session = \"" + id + "\" is already a live counter",
               [&] { s.id_for(id, "metadata x-squall-session"); });
  const std::string other = "c-" + std::string(32, 'a');
  EXPECT_EQ(s.id_for(other, "metadata x-squall-session"), other);
}

TEST_F(SessionStoreTest, IdleSessionsAreEvictedAfterTheTtlOnTheInjectedClock) {
  auto s = store({}, 100ms);
  std::string kept = s.add(s.reserve(0), std::make_shared<Counter>());
  std::string idle = s.add(s.reserve(0), std::make_shared<Counter>());
  now_ += 60ms;
  s.get(kept);   // its idle time restarts
  now_ += 60ms;  // idle: 120 ms, kept: 60 ms
  EXPECT_EQ(s.evict_idle(), 1u);
  EXPECT_EQ(s.size(), 1u);
  expect_error(Code::NotFound, "counter_id", [&] { s.get(idle); });
  s.get(kept);
  EXPECT_EQ(gate_->live_sessions(), 1u) << "an evicted session gives its slot back";
}

TEST_F(SessionStoreTest, CountAndBytesAreLimitedThroughTheGate) {
  Limits limits;
  limits.max_sessions = 2;
  limits.max_session_bytes = 1000;
  auto s = store(limits);
  std::string a = s.add(s.reserve(600), std::make_shared<Counter>());
  expect_error(Code::ResourceExhausted, "--max-session-bytes = 1000",
               [&] { s.add(s.reserve(500), std::make_shared<Counter>()); });
  EXPECT_EQ(gate_->session_bytes(), 600u) << "a refused session holds nothing";
  EXPECT_EQ(gate_->live_sessions(), 1u);
  s.add(s.reserve(400), std::make_shared<Counter>());
  EXPECT_EQ(s.bytes(), 1000u);
  expect_error(Code::ResourceExhausted, "--max-sessions", [&] { s.add(s.reserve(0), std::make_shared<Counter>()); });
  s.close(a);
  EXPECT_EQ(gate_->session_bytes(), 400u);
  s.add(s.reserve(600), std::make_shared<Counter>());
  expect_error(Code::NotFound, "counter_id", [&] { s.close(a); });
}

// A value read with get() keeps its reservation while it is used: closed meanwhile, its session's bytes and
// slot come back when the last reader lets it go, not before (a render of a stored volume that another call
// releases still holds the volume's memory).
TEST_F(SessionStoreTest, AValueInUseHoldsItsReservationPastItsClose) {
  Limits limits;
  limits.max_sessions = 1;
  limits.max_session_bytes = 1000;
  auto s = store(limits);
  const std::string id = s.add(s.reserve(600), std::make_shared<Counter>());
  std::shared_ptr<Counter> in_use = s.get(id);
  s.close(id);
  expect_error(Code::NotFound, "counter_id", [&] { s.get(id); });
  EXPECT_EQ(gate_->session_bytes(), 600u);
  EXPECT_EQ(gate_->live_sessions(), 1u);
  expect_error(Code::ResourceExhausted, "--max-sessions", [&] { s.add(s.reserve(0), std::make_shared<Counter>()); });
  in_use.reset();
  EXPECT_EQ(gate_->session_bytes(), 0u);
  EXPECT_EQ(gate_->live_sessions(), 0u);
  s.add(s.reserve(600), std::make_shared<Counter>());
}

// The thread of the call that waits: the store's clock tells when that call has found the session.
thread_local bool t_waiting_call = false;

// A session stays while calls run on it or wait for it, however much longer than the TTL they take (an
// eWave step of a large grid on a loaded machine): its idle time starts when the last of them ends.
TEST(SessionStoreRace, ASessionIsNotEvictedWhileCallsRunOrWaitOnIt) {
  std::atomic<int64_t> now_ms{0};
  std::promise<void> found;  // the waiting call's second clock read: after evict_idle, lookup() found it
  int waiting_reads = 0;     // on the waiting call's thread only
  auto clock = [&] {         // the time read before the signal, which lets the test move the clock on
    const auto now = std::chrono::steady_clock::time_point(std::chrono::milliseconds(now_ms));
    if (t_waiting_call && ++waiting_reads == 2) found.set_value();
    return now;
  };
  LimitGate gate{Limits{}};
  SessionStore<Counter> s(gate, SessionPolicy{100ms, clock}, "counter", "counter_id", "c-");
  const std::string id = s.add(s.reserve(0), std::make_shared<Counter>());
  std::promise<void> inside, go;
  std::thread running([&] {
    s.with(id, [&](Counter& c) {
      inside.set_value();
      go.get_future().wait();
      ++c.value;
    });
  });
  inside.get_future().wait();
  std::thread waiting([&] {
    t_waiting_call = true;
    s.with(id, [](Counter& c) { c.value += 10; });
  });
  found.get_future().wait();
  now_ms = 1000;  // both calls longer than the TTL
  EXPECT_EQ(s.evict_idle(), 0u);
  go.set_value();
  running.join();
  waiting.join();
  EXPECT_EQ(s.with(id, [](Counter& c) { return c.value; }), 11);
  now_ms = 1050;  // idle since the calls ended, at 1000
  EXPECT_EQ(s.evict_idle(), 0u);
  now_ms = 1200;
  EXPECT_EQ(s.evict_idle(), 1u);
  expect_error(Code::NotFound, "counter_id", [&] { s.with(id, [](Counter&) {}); });
}

// While the daemon drains, a new session is UNAVAILABLE (retry on another replica) before any limit is
// asked: a full store (whose sessions keep their slots until the process ends) does not answer
// RESOURCE_EXHAUSTED, which a client would not retry.
TEST(SessionStoreDrain, ANewSessionIsUnavailableEvenWhenTheStoreIsFull) {
  Limits limits;
  limits.max_sessions = 1;
  LimitGate gate(limits);
  SessionRegistry registry;
  SessionStore<Counter> s(gate, SessionPolicy{10min, [] { return std::chrono::steady_clock::now(); }, &registry},
                          "counter", "counter_id", "c-");
  const std::string id = s.add(s.reserve(0), std::make_shared<Counter>());
  EXPECT_TRUE(registry.holds(id)) << "the registry knows the sessions live here";
  EXPECT_FALSE(registry.holds("c-00000000000000000000000000000000"));
  registry.begin_drain();
  expect_error(Code::Unavailable, "squalld is shutting down: it takes no new counter; retry on another replica",
               [&] { s.add(s.reserve(0), std::make_shared<Counter>()); });
}

TEST_F(SessionStoreTest, CheckpointsRestoreUnderTheSameId) {
  auto s = store();
  std::string id = s.add(s.reserve(8), std::make_shared<Counter>(Counter{41}));
  std::string saved = s.checkpoint(id, 7, [](const Counter& c) { return std::to_string(c.value); });
  auto restore = [&](const std::string& data) {
    CheckpointHeader header;
    std::string payload = s.open_checkpoint(data, "state", 7, &header);
    EXPECT_EQ(header.version, 7u);
    return s.add(header.id, s.reserve(8), std::make_shared<Counter>(Counter{std::stoi(payload)}));
  };
  expect_error(Code::AlreadyExists, "counter_id = \"" + id + "\" is already a live counter", [&] { restore(saved); });
  s.close(id);
  EXPECT_EQ(restore(saved), id);
  EXPECT_EQ(s.with(id, [](Counter& c) { return c.value; }), 41);
  EXPECT_EQ(gate_->session_bytes(), 8u);

  CheckpointHeader header;
  expect_error(Code::InvalidArgument, "state is not a session checkpoint",
               [&] { s.open_checkpoint("junk", "state", 7, &header); });
  expect_error(Code::InvalidArgument, "truncated",
               [&] { s.open_checkpoint(saved.substr(0, saved.size() - 1), "state", 7, &header); });
  expect_error(Code::InvalidArgument, "follow the payload",
               [&] { s.open_checkpoint(saved + "x", "state", 7, &header); });
  expect_error(Code::InvalidArgument, "state holds counter payload version 7; this squalld reads version 8",
               [&] { s.open_checkpoint(saved, "state", 8, &header); });
  // A newer squalld's checkpoint: another replica (one that reads it) can take the call.
  expect_error(Code::Unavailable, "payload version 7; this squalld reads versions 5 to 6: retry on a newer squalld",
               [&] { s.open_checkpoint(saved, "state", 5, 6, &header); });
  // Damage anywhere (here one bit of the payload, of the id, of the checksum) is found by the checksum.
  for (size_t at : {saved.size() - 9, size_t(30), saved.size() - 1}) {
    std::string damaged = saved;
    damaged[at] ^= 1;
    expect_error(Code::InvalidArgument, "state is damaged: its checksum does not match its bytes",
                 [&] { s.open_checkpoint(damaged, "state", 7, &header); });
  }
  // A checkpoint of a squalld before checksums (its version without kChecksummed) is read as it is.
  ByteWriter legacy;
  legacy.put_bytes(std::string_view("SQSESS\0\1", 8));
  legacy.put(uint32_t(7)), legacy.put_bytes("counter");  // the kind
  legacy.put(uint32_t(7));                               // the version
  legacy.put(uint32_t(id.size())), legacy.put_bytes(id);
  legacy.put_counted("41");
  s.close(id);
  EXPECT_EQ(s.open_checkpoint(legacy.take(), "state", 7, &header), "41");
  EXPECT_EQ(header.version, 7u);
  EXPECT_EQ(header.id, id);
  LimitGate other_gate{Limits{}};
  SessionStore<Counter> other(other_gate, {}, "volume", "volume_id");
  expect_error(Code::InvalidArgument, "holds a counter, not a volume",
               [&] { other.open_checkpoint(saved, "state", 7, &header); });
}

// A checkpoint names the client it counts against only when one is counted (--max-sessions-per-client), in
// the kWithClient form; a checkpoint of no client keeps the form every squalld since checksums reads.
TEST(SessionCheckpoint, NamesItsClientOnlyWhenOneIsCounted) {
  CheckpointHeader header;
  const std::string plain = encode_checkpoint({"counter", 3, "c-1"}, "payload");
  EXPECT_EQ(decode_checkpoint(plain, "counter", "state", &header), "payload");
  EXPECT_EQ(header.client, "");
  ByteReader in(plain, "state", "a checkpoint");
  in.get_bytes(8 + 4 + 7, "magic and kind");
  EXPECT_EQ(in.get<uint32_t>("the version"), 3u | kChecksummed);

  const std::string named = encode_checkpoint({"counter", 3, "c-1", "ipv4:127.0.0.7"}, "payload");
  EXPECT_EQ(decode_checkpoint(named, "counter", "state", &header), "payload");
  EXPECT_EQ(header.version, 3u);
  EXPECT_EQ(header.client, "ipv4:127.0.0.7");
  // Read as a squalld before the flag reads it: a payload version newer than any it knows.
  ByteReader older(named, "state", "a checkpoint");
  older.get_bytes(8 + 4 + 7, "magic and kind");
  EXPECT_GT(older.get<uint32_t>("the version") & ~kChecksummed, 3u);
  std::string damaged = named;
  damaged[named.size() - 20] ^= 1;  // in the client's name
  expect_error(Code::InvalidArgument, "state is damaged",
               [&] { decode_checkpoint(damaged, "counter", "state", &header); });
}

// Where --max-sessions-per-client is in force, a store's checkpoints to the state directory name the client
// that created the session, and no client where it is not.
TEST(SessionStoreStateDir, ACheckpointNamesTheClientItsSessionCountsAgainst) {
  for (uint32_t per_client : {0u, 2u}) {
    const std::string dir = test::temp_dir("store-client");
    SessionRegistry registry(std::make_unique<StateDir>(dir, "--state-dir"), "a");
    registry.begin();
    LimitGate gate{Limits{.max_sessions_per_client = per_client}};
    SessionStore<Counter> s(gate, SessionPolicy{.registry = &registry}, "counter", "counter_id", "c-");
    s.persist(
        1, [](const Counter& c) { return std::to_string(c.value); }, [](const std::string&) {});
    const std::string id = s.add(s.reserve(8, "ipv4:127.0.0.7"), std::make_shared<Counter>(Counter{7}));
    ASSERT_EQ(s.checkpoint_all(false), 1u);
    CheckpointHeader header;
    EXPECT_EQ(decode_checkpoint(*registry.state_dir()->read(id), "counter", "checkpoint", &header), "7");
    EXPECT_EQ(header.client, per_client ? "ipv4:127.0.0.7" : "") << "--max-sessions-per-client " << per_client;
  }
}

// Stores of two kinds (ids "c-..." and "v-...") on two replicas sharing one state directory, as squalld's
// eWave sessions and cloud volumes do: each store writes its values as text and resumes them.
struct Replica {
  Replica(const std::string& dir, const std::string& name)
      : registry(std::make_unique<StateDir>(dir, "--state-dir"), name),
        counters(gate, policy(), "counter", "counter_id", "c-"),
        volumes(gate, policy(), "volume", "volume_id", "v-") {
    for (SessionStore<Counter>* store : {&counters, &volumes})
      store->persist(
          1, [](const Counter& c) { return std::to_string(c.value); },
          [store](const std::string& bytes) {
            CheckpointHeader header;
            const std::string value = store->open_checkpoint(bytes, "checkpoint", 1, &header);
            store->add(header.id, store->reserve(8), std::make_shared<Counter>(Counter{std::stoi(value)}));
          });
    registry.begin();  // beats: a replica serves its sessions while its heartbeat is fresh
  }
  SessionPolicy policy() {
    SessionPolicy p;
    p.registry = &registry;
    return p;
  }
  LimitGate gate{Limits{}};
  SessionRegistry registry;
  SessionStore<Counter> counters, volumes;
};

// A session whose replica drained lives on in the state directory: closing it on another replica removes
// its checkpoint (nothing is resumed, and its id is NOT_FOUND after), the drained replica answers
// UNAVAILABLE (the session is no longer its to close), and a store of another kind never touches it.
TEST(SessionStoreStateDir, ClosingACheckpointedSessionRemovesItsCheckpointOnly) {
  const std::string dir = test::temp_dir("store-close");
  Replica a(dir, "a"), b(dir, "b");
  const std::string id = a.counters.add(a.counters.reserve(8), std::make_shared<Counter>(Counter{7}));
  ASSERT_EQ(a.counters.checkpoint_all(true), 1u);  // a drains
  const StateDir& files = *a.registry.state_dir();
  ASSERT_TRUE(files.read(id).has_value());

  expect_error(Code::NotFound, "volume_id", [&] { b.volumes.close(id); });
  EXPECT_TRUE(files.read(id).has_value()) << "a volume store removed a counter's checkpoint";
  b.counters.close(id);
  EXPECT_FALSE(files.read(id).has_value());
  EXPECT_EQ(b.counters.size(), 0u) << "closing resumed it";
  expect_error(Code::NotFound, "counter_id", [&] { b.counters.close(id); });
  expect_error(Code::NotFound, "counter_id", [&] { b.counters.with(id, [](Counter&) {}); });
  expect_error(Code::Unavailable, "moved to the state directory", [&] { a.counters.close(id); });
}

// With a state directory, an eviction pass passes a session with a call in flight by, without waiting for
// the call: it would otherwise wait for the session's lock to remove its files, holding up what ran the pass
// (a call on another session, a close, the sweeper) and the slots of the other sessions it evicts. The
// session keeps its checkpoint, and is evicted, files and all, once idle past the TTL.
TEST(SessionStoreStateDir, AnEvictionPassDoesNotWaitForACallInFlight) {
  const std::string dir = test::temp_dir("store-evict");
  std::atomic<int64_t> now_ms{0};
  SessionRegistry registry(std::make_unique<StateDir>(dir, "--state-dir"), "a");
  registry.begin();
  SessionPolicy policy{100ms, [&] { return std::chrono::steady_clock::time_point(std::chrono::milliseconds(now_ms)); },
                       &registry};
  LimitGate gate{Limits{}};
  SessionStore<Counter> s(gate, policy, "counter", "counter_id", "c-");
  s.persist(
      1, [](const Counter& c) { return std::to_string(c.value); },
      [&s](const std::string& bytes) {
        CheckpointHeader header;
        const std::string value = s.open_checkpoint(bytes, "checkpoint", 1, &header);
        s.add(header.id, s.reserve(8), std::make_shared<Counter>(Counter{std::stoi(value)}));
      });
  const std::string id = s.add(s.reserve(8), std::make_shared<Counter>(Counter{7}));
  ASSERT_EQ(s.checkpoint_all(false), 1u);
  std::promise<void> inside, go;
  std::thread running([&] {
    s.with(id, [&](Counter&) {
      inside.set_value();
      go.get_future().wait();
    });
  });
  inside.get_future().wait();
  now_ms = 1000;  // past the TTL, with a call running on it
  auto pass = std::async(std::launch::async, [&] { return s.evict_idle(); });
  const std::future_status waited = pass.wait_for(5s);
  go.set_value();
  running.join();
  EXPECT_EQ(waited, std::future_status::ready) << "the eviction pass waited for the call";
  EXPECT_EQ(pass.get(), 0u);
  EXPECT_TRUE(registry.state_dir()->read(id).has_value());
  now_ms = 1050;  // idle since the call ended, at 1000
  EXPECT_EQ(s.evict_idle(), 0u);
  now_ms = 1200;
  EXPECT_EQ(s.evict_idle(), 1u);
  EXPECT_FALSE(registry.state_dir()->read(id).has_value()) << "the checkpoint of an evicted session was kept";
  expect_error(Code::NotFound, "counter_id", [&] { s.with(id, [](Counter&) {}); });
}

TEST_F(SessionStoreTest, ClosingAnExpiredIdIsNotFound) {
  auto s = store({}, 100ms);
  std::string id = s.add(s.reserve(0), std::make_shared<Counter>());
  now_ += 101ms;
  expect_error(Code::NotFound, "counter_id", [&] { s.close(id); });
  EXPECT_FALSE(s.erase(id));
  EXPECT_EQ(gate_->live_sessions(), 0u);
}

}  // namespace
}  // namespace squall
