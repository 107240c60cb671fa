// SessionStore: ids, the TTL on an injected clock, the session and byte limits of the LimitGate, and
// checkpoints that restore under the same id. No device needed.
#include "common/session_store.h"

#include <gtest/gtest.h>

#include <set>

#include "support/expect_error.h"

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

TEST_F(SessionStoreTest, IdsAreUnguessableAndCallsReachTheirSession) {
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
  expect_error(Code::FailedPrecondition, "counter_id = \"" + id + "\" is already a live counter",
               [&] { restore(saved); });
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
  LimitGate other_gate{Limits{}};
  SessionStore<Counter> other(other_gate, {}, "volume", "volume_id");
  expect_error(Code::InvalidArgument, "holds a counter, not a volume",
               [&] { other.open_checkpoint(saved, "state", 7, &header); });
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
