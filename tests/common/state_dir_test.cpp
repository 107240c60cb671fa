// StateDir and persistent SessionStores: atomic files named by id, expiry, and sessions written by one
// registry (a draining replica) and resumed by another (any replica sharing the directory). No device.
#include "common/state_dir.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <optional>
#include <thread>

#include "common/session_store.h"
#include "support/expect_error.h"
#include "support/process.h"

namespace squall {
namespace {

using test::expect_error;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

struct Counter {
  int value = 0;
};

const std::string kId = "c-0123456789abcdef0123456789abcdef";

// One replica's view: its registry over the shared directory, begun as squalld begins it, and a persistent
// store of Counters whose checkpoint payload is the value as text (a negative value cannot be written: its
// save throws).
struct Replica {
  explicit Replica(
      const std::string& dir, const std::string& name = "replica",
      SteadyClock clock = [] { return std::chrono::steady_clock::now(); }, std::chrono::milliseconds owner_timeout = 5s,
      std::chrono::milliseconds ttl = 1h)
      : registry(std::make_unique<StateDir>(dir, "--state-dir"), name, owner_timeout),
        store(gate, SessionPolicy{ttl, std::move(clock), &registry}, "counter", "counter_id", "c-") {
    registry.begin();
    store.persist(
        1,
        [](const Counter& c) {
          if (c.value < 0) throw std::runtime_error("a negative counter cannot be written");
          return std::to_string(c.value);
        },
        [this](const std::string& bytes) {
          CheckpointHeader header;
          std::string payload = store.open_checkpoint(bytes, "checkpoint", 1, &header);
          auto counter = std::make_shared<Counter>();
          counter->value = std::stoi(payload);
          store.add(header.id, store.reserve(0), counter);
        });
  }
  LimitGate gate{Limits{}};
  SessionRegistry registry;
  SessionStore<Counter> store;
};

std::vector<std::string> files(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename().string());
  return names;
}

// Writes `bytes` to the file at `path`.
void put(const std::string& path, const std::string& bytes) { std::ofstream(path, std::ios::binary) << bytes; }

TEST(StateDir, WritesWholeFilesNamedByIdAndExpiresOldOnes) {
  const std::string root = test::temp_dir("state-dir"), dir = root + "/state";
  fs::create_directories(dir);
  StateDir state(dir, "--state-dir");
  state.write(kId, "first");
  state.write(kId, "second");
  EXPECT_EQ(state.read(kId).value(), "second");
  EXPECT_EQ(files(dir), std::vector<std::string>{kId + ".session"}) << "no temporary file is left behind";
  // An id that cannot name a file of the directory (a path, capitals) reads nothing, even where such a
  // file exists, and writes nothing.
  put(root + "/" + kId + ".session", "outside");
  put(dir + "/C-UPPER.session", "upper");
  EXPECT_FALSE(state.read("../" + kId)) << "an id that is no file name reads nothing";
  EXPECT_FALSE(state.read("C-UPPER"));
  expect_error(Code::Internal, "cannot name a file", [&] { state.write("../x", "bytes"); });
  EXPECT_FALSE(fs::exists(root + "/x.session"));
  fs::remove(dir + "/C-UPPER.session");
  EXPECT_EQ(state.expire(1h), 0u);
  std::this_thread::sleep_for(20ms);
  EXPECT_EQ(state.expire(10ms), 1u);
  EXPECT_FALSE(state.read(kId));
  state.heartbeat("host:50051/x");
  EXPECT_TRUE(state.alive("host:50051/x", 1h));
  EXPECT_TRUE(fs::exists(dir + "/replicas/host_3a50051_2fx")) << "a replica's name is escaped into one file name";
  std::this_thread::sleep_for(20ms);
  EXPECT_FALSE(state.alive("host:50051/x", 10ms)) << "an old heartbeat is a dead replica";
  state.retire("host:50051/x");
  EXPECT_FALSE(state.alive("host:50051/x", 1h));
  EXPECT_THROW(StateDir("/proc/no-such-dir", "--state-dir"), std::runtime_error);
}

// A write that fails (here past RLIMIT_FSIZE, as on a full volume) is UNAVAILABLE and leaves no partial file
// behind, where each checkpoint pass on a full volume would leave one per session; the last checkpoint stays.
TEST(StateDir, AWriteThatFailsLeavesNoFileBehind) {
  const std::string dir = test::temp_dir("state-full");
  StateDir state(dir, "--state-dir");
  state.write(kId, "small");
  struct sigaction ignore {
  }, before{};  // past the limit write(2) fails (EFBIG) rather than raise SIGXFSZ
  ignore.sa_handler = SIG_IGN;
  ASSERT_EQ(sigaction(SIGXFSZ, &ignore, &before), 0);
  rlimit saved{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &saved), 0);
  rlimit small = saved;
  small.rlim_cur = 4096;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  std::optional<Error> refused;
  try {
    state.write(kId, std::string(1 << 16, 'x'));
  } catch (const Error& e) {
    refused = e;
  }
  setrlimit(RLIMIT_FSIZE, &saved);
  sigaction(SIGXFSZ, &before, nullptr);
  ASSERT_TRUE(refused.has_value()) << "a write past the file size limit succeeded";
  EXPECT_EQ(refused->code(), Code::Unavailable) << refused->what();
  EXPECT_EQ(files(dir), std::vector<std::string>{kId + ".session"}) << "a partial file was left behind";
  EXPECT_EQ(state.read(kId).value(), "small");
}

TEST(StateDir, ASessionReleasedByOneReplicaIsResumedByAnother) {
  const std::string dir = test::temp_dir("state-move");
  Replica a(dir, "a"), b(dir, "b");
  const std::string id = a.store.add(a.store.id_for(kId, "metadata"), a.store.reserve(0), std::make_shared<Counter>());
  ASSERT_EQ(id, kId) << "the proposed id is taken";
  a.store.with(id, [](Counter& c) { c.value = 7; });
  EXPECT_EQ(a.registry.checkpoint_all(false), 1u);
  a.store.with(id, [](Counter& c) { c.value = 8; });  // a periodic checkpoint does not release
  a.registry.begin_drain();
  EXPECT_TRUE(a.registry.holds(id)) << "a call naming it goes on while the daemon drains";
  EXPECT_EQ(a.registry.checkpoint_all(true), 1u);
  EXPECT_FALSE(a.registry.holds(id)) << "released: a stream naming it in its metadata no longer outlives the drain";
  expect_error(Code::Unavailable, "moved to the state directory", [&] { a.store.with(id, [](Counter&) {}); });
  expect_error(Code::Unavailable, "shutting down",
               [&] { a.store.add(a.store.reserve(0), std::make_shared<Counter>()); });
  EXPECT_EQ(b.store.with(id, [](Counter& c) { return c.value; }), 8) << "resumed with the drained state";
  EXPECT_EQ(b.store.size(), 1u);
  b.store.close(id);
  EXPECT_FALSE(b.registry.state_dir()->read(id)) << "closing removes the checkpoint";
  Replica c(dir);
  expect_error(Code::NotFound, "counter_id", [&] { c.store.get(id); });
}

// A session idle longer than --session-ttl is evicted; written by a drain and not resumed within the TTL, it is
// as gone for the replica that is asked for it, while a replica of a longer TTL still resumes it.
TEST(StateDir, ACheckpointIdleLongerThanTheTtlIsNotResumed) {
  const std::string dir = test::temp_dir("state-ttl");
  const auto steady = [] { return std::chrono::steady_clock::now(); };
  {
    Replica a(dir, "a");
    a.store.add(a.store.id_for(kId, "metadata"), a.store.reserve(0), std::make_shared<Counter>(Counter{5}));
    a.registry.begin_drain();
    ASSERT_EQ(a.registry.checkpoint_all(true), 1u);
  }
  std::this_thread::sleep_for(700ms);
  Replica b(dir, "b", steady, 5s, 500ms);
  expect_error(Code::NotFound, "counter_id", [&] { b.store.get(kId); });
  Replica c(dir, "c", steady, 5s, 1h);
  EXPECT_EQ(c.store.with(kId, [](Counter& n) { return n.value; }), 5);
}

// A checkpoint this squalld cannot read (damaged, or of a format it does not know) is no fault of the call
// naming its id: DATA_LOSS (stored data damaged: a retry cannot help), naming the file's session.
TEST(StateDir, AnUnreadableCheckpointIsDataLoss) {
  const std::string dir = test::temp_dir("state-damaged");
  put(dir + "/" + kId + ".session", "not a checkpoint");
  Replica a(dir, "a");
  expect_error(
      Code::DataLoss,
      "counter " + kId + "'s checkpoint in the state directory is damaged or of a format this squalld does not read: ",
      [&] { a.store.get(kId); });
}

TEST(StateDir, ALiveOwnerIsAskedToHandTheSessionOverInsteadOfAStaleResume) {
  const std::string dir = test::temp_dir("state-handover");
  Replica a(dir, "a"), b(dir, "b");
  std::string id = a.store.add(a.store.reserve(0), std::make_shared<Counter>());
  a.registry.checkpoint_all(false);                   // a periodic checkpoint: value 0
  a.store.with(id, [](Counter& c) { c.value = 5; });  // the current state, on a only
  a.registry.heartbeat();
  EXPECT_EQ(a.registry.tick(), 0u);  // no request yet
  expect_error(Code::Unavailable, "is live on replica a, which is asked to hand it over", [&] { b.store.get(id); });
  EXPECT_EQ(b.registry.tick(), 0u) << "b holds nothing to hand over";
  EXPECT_EQ(a.registry.tick(), 1u) << "a answers the request";
  EXPECT_EQ(a.store.size(), 0u) << "a let the session go";
  EXPECT_EQ(b.store.with(id, [](Counter& c) { return c.value; }), 5) << "b resumed the current state, not 0";
  EXPECT_EQ(b.registry.state_dir()->owner(id).value(), "b");
  EXPECT_TRUE(b.registry.state_dir()->handover_requests().empty());
}

TEST(StateDir, ASessionOfADeadOwnerResumesFromItsLastCheckpoint) {
  const std::string dir = test::temp_dir("state-dead");
  std::string id;
  {
    Replica a(dir, "a");
    id = a.store.add(a.store.reserve(0), std::make_shared<Counter>());
    a.store.with(id, [](Counter& c) { c.value = 3; });
    a.registry.checkpoint_all(false);
    a.registry.heartbeat();
    a.registry.state_dir()->retire("a");  // a is killed: its heartbeat stops
  }
  Replica b(dir, "b");
  EXPECT_EQ(b.store.with(id, [](Counter& c) { return c.value; }), 3);
}

// Ownership changes under the session's lock: an owner file is claimed only where there is none or
// `may_take` lets its owner go, and removed only by the replica it names, and nothing is left behind.
TEST(StateDir, OwnershipIsClaimedOnlyWhereThereIsNoneAndGivenUpOnlyByItsOwner) {
  const std::string dir = test::temp_dir("state-owner-cas");
  StateDir state(dir, "--state-dir");
  EXPECT_TRUE(state.create_owner(kId, "a"));
  EXPECT_FALSE(state.create_owner(kId, "b"));
  EXPECT_EQ(state.owner(kId).value(), "a");
  EXPECT_FALSE(state.remove_owner_if(kId, "b"));
  EXPECT_EQ(state.owner(kId).value(), "a");
  EXPECT_TRUE(state.remove_owner_if(kId, "a"));
  EXPECT_FALSE(state.owner(kId));
  EXPECT_FALSE(state.remove_owner_if(kId, "a"));
  EXPECT_TRUE(state.create_owner(kId, "b"));
  std::string holder;
  EXPECT_FALSE(state.claim_owner(
      kId, "c", [](const std::string&) { return false; }, &holder));
  EXPECT_EQ(holder, "b");
  EXPECT_TRUE(state.claim_owner(kId, "c", [](const std::string& owner) { return owner == "b"; }));
  EXPECT_EQ(state.owner(kId).value(), "c");
  EXPECT_EQ(files(dir), std::vector<std::string>{kId + ".owner"});
}

// A checkpoint is put in place only while its owner file names the writer, checked under the ownership lock
// as the rename is made: a replica stalled past the owner timeout (another has claimed the session since)
// leaves the new owner's checkpoint as it is, and no temporary file behind.
TEST(StateDir, ACheckpointIsPutInPlaceOnlyByItsOwner) {
  const std::string dir = test::temp_dir("state-write-owned");
  StateDir state(dir, "--state-dir");
  ASSERT_TRUE(state.create_owner(kId, "a"));
  EXPECT_TRUE(state.write_owned(kId, "a at step 1", "a"));
  ASSERT_TRUE(state.claim_owner(kId, "b", [](const std::string&) { return true; }));  // a taken for dead
  EXPECT_FALSE(state.write_owned(kId, "a at step 2", "a"));
  EXPECT_EQ(state.read(kId).value(), "a at step 1");
  EXPECT_TRUE(state.write_owned(kId, "b at step 2", "b"));
  ASSERT_TRUE(state.remove_owner_if(kId, "b"));  // given up: no owner at all
  EXPECT_FALSE(state.write_owned(kId, "a at step 3", "a"));
  EXPECT_EQ(state.read(kId).value(), "b at step 2");
  EXPECT_EQ(files(dir), std::vector<std::string>{kId + ".session"});
}

// A lock held by a replica that is changing the session's owner makes another wait, and answer
// UNAVAILABLE after a few seconds; one left by a replica that died holding it (older than seconds) is broken.
TEST(StateDir, AnOwnershipLockLeftBehindIsBrokenAndALiveOneWaitedFor) {
  const std::string dir = test::temp_dir("state-owner-lock");
  StateDir state(dir, "--state-dir");
  const std::string lock = dir + "/" + kId + ".lock";
  put(lock, "held");
  const auto start = std::chrono::steady_clock::now();
  expect_error(Code::Unavailable, "is being changed by another replica", [&] { state.create_owner(kId, "a"); });
  EXPECT_GE(std::chrono::steady_clock::now() - start, 1s);
  EXPECT_FALSE(state.owner(kId));
  std::thread holder([&] {  // its holder is done in 300 ms
    std::this_thread::sleep_for(300ms);
    fs::remove(lock);
  });
  EXPECT_TRUE(state.create_owner(kId, "a"));
  holder.join();
  EXPECT_TRUE(state.remove_owner_if(kId, "a"));
  put(lock, "held");
  fs::last_write_time(lock, fs::last_write_time(lock) - 60s);  // its holder died a minute ago
  EXPECT_TRUE(state.create_owner(kId, "a"));
  EXPECT_EQ(files(dir), std::vector<std::string>{kId + ".owner"});
}

// Replicas that receive calls for one session at once (a proxy's ring changing while a client's calls are
// in flight), its owner dead: one of them resumes it and the others answer UNAVAILABLE, so that no step is
// served by a replica that then finds the session taken and lets it go. It fails when ownership is set
// unconditionally: two replicas resume it, both answer, and one of them loses what it served.
TEST(StateDir, ReplicasResumingOneSessionAtOnceLeaveItToOne) {
  const std::string dir = test::temp_dir("state-resume-race");
  std::vector<std::unique_ptr<Replica>> replicas;
  for (const char* name : {"b", "c", "d", "e"}) replicas.push_back(std::make_unique<Replica>(dir, name));
  for (int round = 0; round < 20; ++round) {
    std::string id;
    {
      Replica a(dir, "a");
      id = a.store.add(a.store.reserve(0), std::make_shared<Counter>());
      a.registry.checkpoint_all(false);
      a.registry.state_dir()->retire("a");  // a is killed: its heartbeat stops
    }
    for (auto& r : replicas) r->registry.heartbeat();
    std::atomic<int> ready = 0, served = 0;
    std::vector<std::thread> calls;
    for (auto& r : replicas)
      calls.emplace_back([&, replica = r.get()] {
        for (++ready; ready < int(replicas.size());) std::this_thread::yield();
        try {
          replica->store.with(id, [](Counter& c) { ++c.value; });
          ++served;
        } catch (const Error& e) {
          EXPECT_EQ(e.code(), Code::Unavailable) << e.what();
        }
      });
    for (auto& t : calls) t.join();
    ASSERT_EQ(served, 1) << "round " << round;
    const std::string owner = replicas[0]->registry.state_dir()->owner(id).value();
    for (auto& r : replicas)
      EXPECT_EQ(r->store.size(), r->registry.replica() == owner ? 1u : 0u) << r->registry.replica();
    for (auto& r : replicas) r->store.erase(id);
  }
}

// A heartbeat's age is the file system's time now (this replica's own last heartbeat there, plus the time
// since) less the time the file system stamped on it, so that a file server whose clock is off from the
// replicas' (here a minute behind: every file it stamps looks a minute old to them) takes no live replica
// for dead, and a heartbeat that stopped is still seen to stop.
TEST(StateDir, HeartbeatsAreJudgedByTheFileSystemsClockNotTheReaders) {
  const std::string dir = test::temp_dir("state-clock");
  StateDir a(dir, "--state-dir"), b(dir, "--state-dir");
  a.heartbeat("a");
  b.heartbeat("b");
  for (const char* name : {"a", "b"}) {
    const std::string file = dir + "/replicas/" + name;
    fs::last_write_time(file, fs::last_write_time(file) - 60s);
  }
  EXPECT_TRUE(b.alive("a", 5s));
  const std::string a_file = dir + "/replicas/a";
  fs::last_write_time(a_file, fs::last_write_time(a_file) - 10s);  // a stopped beating 10 s before b's last
  EXPECT_FALSE(b.alive("a", 5s));
  EXPECT_FALSE(b.alive("c", 5s)) << "no heartbeat at all";
}

// A claim left behind (a resume that failed after claiming, on a file system that then failed) would keep
// every other replica answering UNAVAILABLE while its owner lives: the owner answers a handover request for
// a session it does not hold by giving the ownership up, and the session resumes where it was asked for.
TEST(StateDir, AReplicaAskedForASessionItOwnsButDoesNotHoldGivesTheOwnershipUp) {
  const std::string dir = test::temp_dir("state-stray-claim");
  Replica a(dir, "a"), b(dir, "b");
  const std::string id = a.store.add(a.store.reserve(0), std::make_shared<Counter>(Counter{7}));
  const std::string bytes = a.store.checkpoint(id, 1, [](const Counter& c) { return std::to_string(c.value); });
  a.store.erase(id);
  a.registry.state_dir()->write(id, bytes);
  ASSERT_TRUE(a.registry.state_dir()->create_owner(id, "a"));  // owned by a, live nowhere
  a.registry.heartbeat();
  expect_error(Code::Unavailable, "is live on replica a", [&] { b.store.get(id); });
  EXPECT_EQ(a.registry.tick(), 1u);
  EXPECT_FALSE(a.registry.state_dir()->owner(id));
  EXPECT_EQ(b.store.with(id, [](Counter& c) { return c.value; }), 7);
  EXPECT_EQ(a.registry.state_dir()->owner(id).value(), "b");
  EXPECT_EQ(a.registry.tick(), 0u) << "b's request, answered";

  // A claim of a's that is pending (a resume between its claim and its session's going live) is not stray.
  const std::string resuming = "c-00000000000000000000000000000002";
  ASSERT_TRUE(a.registry.claim(resuming));
  a.registry.state_dir()->request_handover(resuming);
  EXPECT_EQ(a.registry.tick(), 0u);
  EXPECT_EQ(a.registry.state_dir()->owner(resuming).value(), "a");
  a.registry.release(resuming);
  EXPECT_FALSE(a.registry.state_dir()->owner(resuming));
}

// A replica killed and started again under the same name holds none of its former sessions, while its
// heartbeat says it is alive: once the former heartbeat has stopped, it clears its former ownership as it
// starts, so another replica resumes them from their last checkpoint at once rather than asking it for a
// handover it cannot answer. A second live process beating under the name is refused.
TEST(StateDir, ARestartedReplicaClaimsNoneOfItsFormerSessions) {
  const std::string dir = test::temp_dir("state-restart");
  const auto now = [] { return std::chrono::steady_clock::now(); };
  std::string id;
  {
    Replica a(dir, "a", now, 1s);
    id = a.store.add(a.store.reserve(0), std::make_shared<Counter>());
    a.store.with(id, [](Counter& c) { c.value = 4; });
    a.registry.checkpoint_all(false);
    a.registry.heartbeat();
  }  // killed: no drain, its ownership and heartbeat stay
  Replica b(dir, "b", now, 1s);
  b.registry.heartbeat();
  expect_error(Code::Unavailable, "is live on replica a", [&] { b.store.get(id); });
  Replica restarted(dir, "a", now, 1s);  // waits for the former heartbeat to stop
  b.registry.heartbeat();                // as its daemon would have meanwhile
  EXPECT_EQ(b.store.with(id, [](Counter& c) { return c.value; }), 4);
  EXPECT_EQ(b.registry.state_dir()->owner(id).value(), "b");
  EXPECT_TRUE(b.registry.state_dir()->handover_requests().empty()) << "b's request to a, answered";
  std::atomic<bool> beating = true;
  std::thread other([&] {
    while (beating) restarted.registry.heartbeat(), std::this_thread::sleep_for(20ms);
  });
  EXPECT_THROW(Replica(dir, "a", now, 1s), std::runtime_error) << "a second process as replica a";
  beating = false;
  other.join();
}

// A handover that fails (the session cannot be written) is logged and stays requested, and the other
// requests are answered. A drain that cannot write it lets it go all the same: another replica resumes its
// last checkpoint at once, rather than once the draining replica has exited.
TEST(StateDir, AHandoverThatFailsDoesNotKeepTheOthersFromBeingAnswered) {
  const std::string dir = test::temp_dir("state-handover-fails");
  Replica a(dir, "a"), b(dir, "b");
  const std::string failing = a.store.add(a.store.reserve(0), std::make_shared<Counter>());
  const std::string fine = a.store.add(a.store.reserve(0), std::make_shared<Counter>());
  a.registry.checkpoint_all(false);  // both at 0
  a.store.with(failing, [](Counter& c) { c.value = -1; });
  a.store.with(fine, [](Counter& c) { c.value = 2; });
  a.registry.heartbeat();
  for (const std::string& id : {failing, fine})
    expect_error(Code::Unavailable, "is live on replica a", [&] { b.store.get(id); });
  EXPECT_EQ(a.registry.tick(), 1u) << "the session that can be written is handed over";
  EXPECT_EQ(b.store.with(fine, [](Counter& c) { return c.value; }), 2);
  EXPECT_EQ(a.store.with(failing, [](Counter& c) { return c.value; }), -1) << "still live on a";
  EXPECT_EQ(a.registry.state_dir()->handover_requests(), std::vector<std::string>{failing});
  a.registry.begin_drain();
  EXPECT_EQ(a.registry.checkpoint_all(true), 0u);
  expect_error(Code::Unavailable, "moved to the state directory", [&] { a.store.get(failing); });
  a.registry.heartbeat();  // still beating while it drains
  EXPECT_EQ(b.store.with(failing, [](Counter& c) { return c.value; }), 0) << "its last checkpoint";
}

// A drained replica's sessions are the state another replica resumes: evicting them there as idle (the
// drain's calls still run evictions) leaves the new owner's checkpoint and ownership alone.
TEST(StateDir, ADrainedReplicaEvictingItsReleasedSessionsLeavesTheNewOwnersFiles) {
  const std::string dir = test::temp_dir("state-drain-evict");
  auto now = std::chrono::steady_clock::now();
  Replica a(dir, "a", [&] { return now; }), b(dir, "b");
  const std::string id = a.store.add(a.store.reserve(0), std::make_shared<Counter>());
  a.registry.begin_drain();
  EXPECT_EQ(a.registry.checkpoint_all(true), 1u);
  EXPECT_EQ(b.store.with(id, [](Counter& c) { return ++c.value; }), 1);
  b.registry.checkpoint_all(false);
  now += 2h;
  EXPECT_EQ(a.store.evict_idle(), 1u);
  EXPECT_EQ(b.registry.state_dir()->owner(id).value(), "b");
  EXPECT_TRUE(b.registry.state_dir()->read(id));
}

// A replica taken for dead while it still runs (its heartbeat late) finds its sessions owned by the replica
// that resumed them, or by none once that one closed them: a call reads the ownership (within a second) and
// a checkpoint does too, and the session is let go there, the new owner's files untouched. It fails when the
// old replica serves on, writes its older state over the new owner's, or brings a closed session back.
TEST(StateDir, AReplicaTakenForDeadLetsGoOfTheSessionsAnotherResumed) {
  const std::string dir = test::temp_dir("state-taken-over");
  auto now = std::chrono::steady_clock::now();
  Replica a(dir, "a", [&] { return now; }), b(dir, "b");
  const std::string called = a.store.add(a.store.reserve(0), std::make_shared<Counter>());
  const std::string written = a.store.add(a.store.reserve(0), std::make_shared<Counter>());
  const std::string closed = a.store.add(a.store.reserve(0), std::make_shared<Counter>());
  a.registry.checkpoint_all(false);  // all at 0
  a.store.with(written, [](Counter& c) { c.value = 1; });
  a.registry.state_dir()->retire("a");  // its heartbeat late: presumed dead
  b.registry.heartbeat();
  for (const std::string& id : {called, written, closed}) b.store.with(id, [](Counter& c) { c.value = 5; });
  b.store.close(closed);
  b.registry.checkpoint_all(false);
  const auto state = [&](const std::string& id) { return b.registry.state_dir()->read(id).value(); };
  const std::string five_called = state(called), five_written = state(written);
  a.store.with(called, [](Counter&) {});  // its ownership read less than a second ago
  now += 2s;
  expect_error(Code::Unavailable, "moved to the state directory", [&] { a.store.with(called, [](Counter&) {}); });
  EXPECT_EQ(a.store.size(), 2u);
  EXPECT_EQ(a.registry.checkpoint_all(false), 0u) << "nothing written over b's";
  EXPECT_EQ(a.store.size(), 0u);
  EXPECT_EQ(state(called), five_called);
  EXPECT_EQ(state(written), five_written);
  for (const std::string& id : {called, written}) EXPECT_EQ(b.registry.state_dir()->owner(id).value(), "b");
  EXPECT_FALSE(b.registry.state_dir()->read(closed)) << "closed on b, not brought back";
  EXPECT_FALSE(b.registry.state_dir()->owner(closed));
}

TEST(StateDir, ADrainingReplicaSendsCallsForCheckpointedIdsElsewhere) {
  const std::string dir = test::temp_dir("state-drain");
  Replica a(dir, "a"), b(dir, "b");
  std::string id = a.store.add(a.store.reserve(0), std::make_shared<Counter>());
  a.registry.checkpoint_all(true);
  b.registry.begin_drain();
  expect_error(Code::Unavailable, "retry on another replica", [&] { b.store.get(id); });
  expect_error(Code::NotFound, "counter_id", [&] { b.store.get("c-ffffffffffffffffffffffffffffffff"); });
}

TEST(StateDir, ProposedIdsMustLookLikeOursAndBeNew) {
  const std::string dir = test::temp_dir("state-ids");
  Replica a(dir);
  EXPECT_EQ(a.store.id_for("", "metadata x").size(), 2u + 32u);
  for (const std::string bad : {"0123456789abcdef0123456789abcdef", "c-0123", "c-0123456789ABCDEF0123456789abcdef",
                                "c-0123456789abcdef0123456789abcdeg", "c-../../../../etc/passwd/0123456789"})
    expect_error(Code::InvalidArgument, "metadata x = ", [&] { a.store.id_for(bad, "metadata x"); });
  a.registry.state_dir()->write(kId, "anything");
  expect_error(Code::AlreadyExists, "checkpointed counter", [&] { a.store.id_for(kId, "metadata x"); });
  const std::string owned = "c-00000000000000000000000000000001";
  a.registry.state_dir()->create_owner(owned, "elsewhere");
  expect_error(Code::AlreadyExists, "checkpointed counter", [&] { a.store.id_for(owned, "metadata x"); });
  // A session live here is owned here too: its id is named as live, not as checkpointed.
  const std::string live = a.store.add(a.store.reserve(0), std::make_shared<Counter>());
  expect_error(Code::AlreadyExists, "metadata x = \"" + live + "\" is already a live counter",
               [&] { a.store.id_for(live, "metadata x"); });
}

// A close waits for the call in flight on its session. A call that comes meanwhile finds the session gone
// (NOT_FOUND), not resumed from its periodic checkpoint, and so does a second close, which leaves the
// checkpoint and ownership to the first (the first would otherwise find its ownership gone: UNAVAILABLE);
// once the close returns nothing of it is left.
TEST(StateDir, ACallOrACloseDuringACloseDoesNotResumeTheSession) {
  Replica a(test::temp_dir("state-closing"), "a");
  const std::string id = a.store.add(a.store.id_for(kId, "metadata"), a.store.reserve(0), std::make_shared<Counter>());
  ASSERT_EQ(a.registry.checkpoint_all(false), 1u);  // a periodic checkpoint
  std::atomic<bool> in_call{false}, done{false};
  std::thread call([&] {
    a.store.with(id, [&](Counter&) {
      in_call = true;
      while (!done) std::this_thread::sleep_for(1ms);
    });
  });
  while (!in_call) std::this_thread::sleep_for(1ms);
  std::string first_close = "running";  // "closed", or its error
  std::thread closer([&] {
    try {
      a.store.close(id);
      first_close = "closed";
    } catch (const Error& e) {
      first_close = e.what();
    }
  });
  while (a.store.size() != 0) std::this_thread::sleep_for(1ms);  // taken out; the close waits for the call
  expect_error(Code::NotFound, "counter_id", [&] { a.store.get(id); });
  expect_error(Code::NotFound, "counter_id", [&] { a.store.close(id); });
  EXPECT_TRUE(a.registry.state_dir()->read(id)) << "the checkpoint is the first close's to remove";
  done = true;
  call.join();
  closer.join();
  EXPECT_EQ(first_close, "closed");
  EXPECT_FALSE(a.registry.state_dir()->read(id)) << "the close removed the checkpoint";
  expect_error(Code::NotFound, "counter_id", [&] { a.store.get(id); });
  EXPECT_EQ(a.store.size(), 0u);
}

TEST(StateDir, EvictingASessionRemovesItsCheckpoint) {
  const std::string dir = test::temp_dir("state-evict");
  LimitGate gate{Limits{}};
  SessionRegistry registry(std::make_unique<StateDir>(dir, "--state-dir"));
  registry.begin();
  auto now = std::chrono::steady_clock::now();
  SessionStore<Counter> store(gate, SessionPolicy{100ms, [&] { return now; }, &registry}, "counter", "counter_id",
                              "c-");
  store.persist(
      1, [](const Counter&) { return std::string("x"); }, [](const std::string&) {});
  std::string id = store.add(store.reserve(0), std::make_shared<Counter>());
  registry.checkpoint_all(false);
  ASSERT_TRUE(registry.state_dir()->read(id));
  now += 200ms;
  EXPECT_EQ(store.evict_idle(), 1u);
  EXPECT_FALSE(registry.state_dir()->read(id)) << "an expired session does not come back from the directory";
}

// Something other than a regular file in a checkpoint's, an owner's, a heartbeat's or a handover's place
// (a FIFO, whose open(2) would wait for a writer; a directory) is damage: DATA_LOSS for the call naming the
// session, at once and naming the file within the directory only; a replica starting beside such an owner
// file, heartbeats and handover requests do not wait either, and an expiry pass removes stale ones.
TEST(StateDir, FilesThatAreNotRegularAreDamageNotAWait) {
  const std::string dir = test::temp_dir("state-fifo");
  const std::string other = "c-fedcba9876543210fedcba9876543210";
  ASSERT_EQ(::mkfifo((dir + "/" + kId + ".session").c_str(), 0600), 0);
  ASSERT_EQ(::mkfifo((dir + "/" + other + ".owner").c_str(), 0600), 0);
  fs::create_directory(dir + "/c-00000000000000000000000000000000.session");
  Replica a(dir, "a");  // begins beside the FIFO owner file
  expect_error(Code::DataLoss, "state directory: " + kId + ".session: not a regular file", [&] { a.store.get(kId); });
  const std::string message = expect_error(Code::DataLoss, "c-00000000000000000000000000000000.session: not a regular",
                                           [&] { a.store.get("c-00000000000000000000000000000000"); });
  EXPECT_EQ(message.find(dir), std::string::npos) << "the host's path stays on the host: " << message;
  ASSERT_EQ(::mkfifo((dir + "/" + other + ".handover").c_str(), 0600), 0);
  a.registry.state_dir()->request_handover(other);
  ASSERT_EQ(::mkfifo((dir + "/replicas/fifo").c_str(), 0600), 0);
  expect_error(Code::Unavailable, "cannot write this replica's heartbeat",
               [&] { a.registry.state_dir()->heartbeat("fifo"); });
  EXPECT_FALSE(a.registry.state_dir()->owner(other)) << "no owner named";
  std::this_thread::sleep_for(20ms);
  a.registry.heartbeat();
  EXPECT_EQ(a.registry.state_dir()->expire(10ms), 5u) << "the stale FIFOs and the empty directory";
  EXPECT_FALSE(fs::exists(dir + "/" + kId + ".session"));
  EXPECT_FALSE(fs::exists(dir + "/" + other + ".owner"));
}

// A checkpoint file whose header names another session (copied, or renamed by hand) resumes nothing: the
// session it names stays as it was (closed), and the call gets DATA_LOSS.
TEST(StateDir, ACheckpointHoldingAnotherSessionsIdResumesNothing) {
  const std::string dir = test::temp_dir("state-other-id");
  const std::string copy = "c-fedcba9876543210fedcba9876543210";
  Replica a(dir, "a");
  a.store.add(a.store.id_for(kId, "metadata"), a.store.reserve(0), std::make_shared<Counter>(Counter{4}));
  ASSERT_EQ(a.registry.checkpoint_all(false), 1u);
  fs::copy_file(dir + "/" + kId + ".session", dir + "/" + copy + ".session");
  a.store.close(kId);
  Replica b(dir, "b");
  expect_error(Code::DataLoss, "counter checkpoint " + copy + " holds another session's id",
               [&] { b.store.get(copy); });
  EXPECT_EQ(b.store.size(), 0u);
  EXPECT_FALSE(b.registry.state_dir()->owner(kId)) << "the closed session was not brought back";
  EXPECT_FALSE(b.registry.state_dir()->owner(copy)) << "nor is the copy's id left claimed";
  expect_error(Code::NotFound, "counter_id", [&] { b.store.get(kId); });
}

// A state directory moved away, replaced by a file or by an empty directory (a volume unmounted from its
// mount point) is no sign that another replica took the sessions over: they stay live here (their
// checkpoints fail until it is back), and a heartbeat does not make an empty directory in its place.
TEST(StateDir, AStateDirectoryGoneOrReplacedLetsNoLiveSessionGo) {
  const std::string root = test::temp_dir("state-gone"), dir = root + "/state";
  Replica a(dir, "a");
  const std::string id = a.store.add(a.store.reserve(0), std::make_shared<Counter>(Counter{6}));
  fs::rename(dir, root + "/moved");
  expect_error(Code::Unavailable, "cannot write this replica's heartbeat", [&] { a.registry.heartbeat(); });
  EXPECT_FALSE(fs::exists(dir)) << "the heartbeat made the directory again";
  EXPECT_EQ(a.registry.checkpoint_all(false), 0u);
  put(dir, "a file where the directory was");
  EXPECT_EQ(a.registry.checkpoint_all(false), 0u);
  EXPECT_EQ(a.store.with(id, [](Counter& c) { return c.value; }), 6) << "the session is still live here";
  fs::remove(dir);
  fs::create_directory(dir);
  EXPECT_EQ(a.registry.checkpoint_all(false), 0u) << "not written into an empty mount point";
  EXPECT_TRUE(fs::is_empty(dir));
  expect_error(Code::Unavailable, "no longer the directory squalld started with",
               [&] { a.store.add(a.store.reserve(0), std::make_shared<Counter>()); });
  EXPECT_EQ(a.store.with(id, [](Counter& c) { return c.value; }), 6);
  fs::remove(dir);
  fs::rename(root + "/moved", dir);
  EXPECT_EQ(a.registry.checkpoint_all(false), 1u) << "written again once the directory is back";
}

// A replica whose heartbeat cannot be written (here its file replaced by a folder) is taken for dead by the
// others at the owner timeout, and they resume its sessions: from half that timeout after its last beat it
// serves none of them and takes no new one, and once a beat is written it serves them again. One that
// cannot beat at all does not begin.
TEST(StateDir, AReplicaWhoseHeartbeatFailsServesNoSessionPastHalfTheOwnerTimeout) {
  const std::string dir = test::temp_dir("state-no-beat");
  const auto now = [] { return std::chrono::steady_clock::now(); };
  Replica a(dir, "a", now, 2s);  // its last beat is a second from going stale: ample under a loaded machine
  const std::string id = a.store.add(a.store.reserve(0), std::make_shared<Counter>(Counter{6}));
  const std::string beat = dir + "/replicas/a";
  fs::remove(beat);
  fs::create_directory(beat);
  expect_error(Code::Unavailable, "cannot write this replica's heartbeat", [&] { a.registry.heartbeat(); });
  EXPECT_EQ(a.store.with(id, [](Counter& c) { return c.value; }), 6) << "within half the timeout of its last beat";
  std::this_thread::sleep_for(1500ms);
  expect_error(Code::Unavailable, "cannot write its heartbeat", [&] { a.store.with(id, [](Counter&) {}); });
  expect_error(Code::Unavailable, "cannot write its heartbeat",
               [&] { a.store.add(a.store.reserve(0), std::make_shared<Counter>()); });
  EXPECT_THROW(Replica(dir, "a", now, 2s), Error) << "a second process under this name cannot beat either";
  EXPECT_EQ(a.registry.state_dir()->owner(id).value_or("none"), "a") << "and it cleared no ownership first";
  fs::remove(beat);
  a.registry.heartbeat();
  EXPECT_EQ(a.store.with(id, [](Counter& c) { return c.value; }), 6) << "served again once a beat is written";
}

// A heartbeat whose write hangs (a hard mount whose file server is gone) fails nothing, but is not written
// either: the other replicas take the replica for dead all the same, so from half the owner timeout after its
// last beat it serves none of its sessions, as when its writes fail.
TEST(StateDir, AReplicaWhoseHeartbeatIsNotWrittenServesNoSessionPastHalfTheOwnerTimeout) {
  const std::string dir = test::temp_dir("state-beat-hangs");
  const auto now = [] { return std::chrono::steady_clock::now(); };
  Replica a(dir, "a", now, 2s);
  const std::string id = a.store.add(a.store.reserve(0), std::make_shared<Counter>(Counter{6}));
  EXPECT_TRUE(a.registry.beating());
  std::this_thread::sleep_for(1500ms);  // no beat: its thread waits on the write
  EXPECT_FALSE(a.registry.heartbeat_failing());
  EXPECT_FALSE(a.registry.beating());
  expect_error(Code::Unavailable, "cannot write its heartbeat", [&] { a.store.with(id, [](Counter&) {}); });
  a.registry.heartbeat();
  EXPECT_EQ(a.store.with(id, [](Counter& c) { return c.value; }), 6) << "served again once a beat is written";
}

// A replica killed holding a session leaves its owner file, and once the checkpoint has expired too nothing
// else removes it: an expiry pass does when the owner has not beaten for the TTL, with its heartbeat. A live
// owner's file stays, and so does a dead one's whose session has a checkpoint.
TEST(StateDir, OwnerFilesAndHeartbeatsOfAReplicaKilledLongAgoExpire) {
  const std::string dir = test::temp_dir("state-dead-owner");
  const std::string live = "c-11111111111111111111111111111111", kept = "c-22222222222222222222222222222222";
  StateDir state(dir, "--state-dir");
  state.heartbeat("dead");
  ASSERT_TRUE(state.create_owner(kId, "dead"));
  ASSERT_TRUE(state.create_owner(live, "live"));
  ASSERT_TRUE(state.create_owner(kept, "dead"));
  std::this_thread::sleep_for(1500ms);
  state.heartbeat("live");
  state.write(kept, "a checkpoint of its own");
  // A TTL well past the few calls between the live beat and the expiry, however loaded the machine (with
  // 300 ms, a stall under a parallel test run once expired the live replica's files too).
  EXPECT_EQ(state.expire(1000ms), 2u) << "the dead replica's owner file of kId and its heartbeat";
  EXPECT_FALSE(state.owner(kId));
  EXPECT_FALSE(fs::exists(dir + "/replicas/dead"));
  EXPECT_EQ(state.owner(live).value(), "live");
  EXPECT_EQ(state.owner(kept).value(), "dead");
}

// A checkpoint's age says nothing of a session that its owner holds live (a replica that checkpoints seldom or
// only when it drains): it stays while that owner beats, and expires once the owner has been silent for the
// TTL, as one with no owner does.
TEST(StateDir, ACheckpointStaysWhileItsOwnerBeats) {
  const std::string dir = test::temp_dir("state-live-owner");
  const std::string live = "c-11111111111111111111111111111111", dead = "c-22222222222222222222222222222222";
  const std::string unowned = "c-33333333333333333333333333333333";
  StateDir state(dir, "--state-dir");
  state.heartbeat("dead");
  ASSERT_TRUE(state.create_owner(live, "live"));
  ASSERT_TRUE(state.create_owner(dead, "dead"));
  for (const std::string& id : {live, dead, unowned}) state.write(id, "a checkpoint");
  std::this_thread::sleep_for(1500ms);
  state.heartbeat("live");
  // A TTL well past the few calls between the live beat and the expiry, however loaded the machine.
  EXPECT_FALSE(state.expired(live, 1000ms)) << "its owner beats";
  EXPECT_TRUE(state.expired(live, 1000ms, "live")) << "asked by its owner, which does not hold it (a file left behind)";
  EXPECT_FALSE(state.expired(live, 1000ms, "live", [&](const std::string& id) { return id == live; }))
      << "asked by its owner, which holds it";
  EXPECT_TRUE(state.expired(dead, 1000ms)) << "its owner has been silent for the TTL";
  EXPECT_TRUE(state.expired(unowned, 1000ms));
  state.expire(1000ms);
  EXPECT_EQ(state.read(live).value_or("gone"), "a checkpoint");
  EXPECT_FALSE(state.read(dead));
  EXPECT_FALSE(state.read(unowned));
  EXPECT_EQ(state.owner(live).value_or("none"), "live");
}

// A directory squalld makes is its user's alone (file names are session ids); one given keeps its mode.
TEST(StateDir, ADirectoryItMakesIsItsUsersAlone) {
  const std::string root = test::temp_dir("state-mode");
  StateDir made(root + "/made", "--state-dir");
  made.heartbeat("a");
  EXPECT_EQ(fs::status(root + "/made").permissions(), fs::perms::owner_all);
  EXPECT_EQ(fs::status(root + "/made/replicas").permissions(), fs::perms::owner_all);
  EXPECT_EQ(fs::status(root + "/made/replicas/a").permissions(), fs::perms::owner_read | fs::perms::owner_write);
  fs::create_directory(root + "/given");
  fs::permissions(root + "/given", fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec);
  StateDir given(root + "/given", "--state-dir");
  EXPECT_EQ(fs::status(root + "/given").permissions(),
            fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec);
}

}  // namespace
}  // namespace squall
