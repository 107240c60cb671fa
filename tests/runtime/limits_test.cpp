// The limit gate: each check names the request field and the daemon flag.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>
#include <vector>

#include "common/error.h"
#include "common/limits.h"

#include "support/expect_error.h"

namespace squall {
namespace {

std::string message_of(const std::function<void()>& f, Code expected) { return test::expect_error(expected, "", f); }

TEST(Limits, GridWithinLimitPasses) {
  LimitGate gate(Limits{.max_grid_cells = 1024 * 1024});
  EXPECT_NO_THROW(gate.check_grid("tile", 1024, 1024));
  EXPECT_NO_THROW(gate.check_grid("volume", 64, 64, 256));
}

TEST(Limits, NonPositiveExtentIsInvalidArgumentNamingTheField) {
  LimitGate gate(Limits{});
  EXPECT_EQ(message_of([&] { gate.check_grid("layers[2]", -5, 64); }, Code::InvalidArgument),
            "layers[2].nx = -5 must be >= 1");
  EXPECT_EQ(message_of([&] { gate.check_grid("map", 64, 0); }, Code::InvalidArgument), "map.ny = 0 must be >= 1");
  EXPECT_EQ(message_of([&] { gate.check_grid("vol", 4, 4, -1); }, Code::InvalidArgument), "vol.nz = -1 must be >= 1");
}

TEST(Limits, OversizeGridIsResourceExhaustedNamingTheFlag) {
  LimitGate gate(Limits{.max_grid_cells = 1000});
  EXPECT_EQ(message_of([&] { gate.check_grid("tile", 100, 11); }, Code::ResourceExhausted),
            "tile.nx * tile.ny = 1100 cells exceeds --max-grid-cells = 1000");
  // Extents whose product overflows 64 bits are still caught.
  message_of([&] { gate.check_grid("tile", int64_t(1) << 40, int64_t(1) << 40, int64_t(1) << 40); },
             Code::ResourceExhausted);
}

TEST(Limits, StreamsAndSessionsAreCountedAndReleased) {
  LimitGate gate(Limits{.max_streams = 2, .max_sessions = 1});
  {
    Slot a = gate.acquire_stream();
    Slot b = gate.acquire_stream();
    EXPECT_EQ(gate.open_streams(), 2u);
    EXPECT_EQ(message_of([&] { gate.acquire_stream(); }, Code::ResourceExhausted),
              "streams: 2 already open, the limit is --max-streams = 2");
    Slot moved = std::move(a);  // moving keeps one slot, not two
    EXPECT_EQ(gate.open_streams(), 2u);
  }
  EXPECT_EQ(gate.open_streams(), 0u);
  Slot s = gate.acquire_session();
  message_of([&] { gate.acquire_session(); }, Code::ResourceExhausted);
  s.release();
  EXPECT_NO_THROW(gate.acquire_session());
}

TEST(Limits, EachClientHasItsOwnShareOfStreams) {
  LimitGate gate(Limits{.max_streams = 16, .max_streams_per_client = 2});
  Slot a = gate.acquire_client_stream("ipv4:127.0.0.1");
  Slot b = gate.acquire_client_stream("ipv4:127.0.0.1");
  EXPECT_EQ(message_of([&] { gate.acquire_client_stream("ipv4:127.0.0.1"); }, Code::ResourceExhausted),
            "streams of ipv4:127.0.0.1: 2 already open, the limit is --max-streams-per-client = 2");
  Slot other = gate.acquire_client_stream("ipv6:[::1]");  // another client still finds its share
  Slot again = gate.acquire_client_stream("ipv6:[::1]");
  a.release();
  EXPECT_NO_THROW(gate.acquire_client_stream("ipv4:127.0.0.1"));  // a released slot comes back
  EXPECT_NO_THROW(LimitGate(Limits{.max_streams_per_client = 0}).acquire_client_stream("any"));  // 0: no limit
}

// A client's share of sessions: held for each session's life, refused past it naming the client and the flag,
// another client's share untouched; 0 is no limit.
TEST(Limits, EachClientHasItsOwnShareOfSessions) {
  LimitGate gate(Limits{.max_streams_per_client = 1, .max_sessions = 64, .max_sessions_per_client = 2});
  Slot a = gate.acquire_client_session("ipv4:127.0.0.1");
  Slot b = gate.acquire_client_session("ipv4:127.0.0.1");
  EXPECT_EQ(message_of([&] { gate.acquire_client_session("ipv4:127.0.0.1"); }, Code::ResourceExhausted),
            "sessions of ipv4:127.0.0.1: 2 already live, the limit is --max-sessions-per-client = 2");
  Slot other = gate.acquire_client_session("ipv6:[::1]");
  Slot stream = gate.acquire_client_stream("ipv4:127.0.0.1");  // streams are counted apart, to their own limit
  EXPECT_EQ(message_of([&] { gate.acquire_client_stream("ipv4:127.0.0.1"); }, Code::ResourceExhausted),
            "streams of ipv4:127.0.0.1: 1 already open, the limit is --max-streams-per-client = 1");
  a.release();
  EXPECT_NO_THROW(gate.acquire_client_session("ipv4:127.0.0.1"));
  EXPECT_NO_THROW(LimitGate(Limits{.max_sessions_per_client = 0}).acquire_client_session("any"));
}

// A reply's payload and room for its other fields (names, statistics) must fit.
TEST(Limits, MessageBytes) {
  LimitGate gate(Limits{.max_message_bytes = 5096});
  EXPECT_NO_THROW(gate.check_message_bytes("frame", 1000));
  EXPECT_EQ(message_of([&] { gate.check_message_bytes("frame", 1001); }, Code::ResourceExhausted),
            "frame needs 1001 bytes and up to 4096 of other fields, more than --max-message-bytes = 5096");
  EXPECT_THROW(gate.check_message_bytes("frame", UINT64_MAX), Error);
}

// memory_room says whether acquire_memory would succeed, counting what a holder would give back for it.
TEST(Limits, MemoryRoomMatchesWhatAcquireMemoryTakes) {
  Limits limits;
  limits.memory_budget = 100;
  LimitGate gate(limits);
  Slot held = gate.acquire_memory("held", 60);
  EXPECT_TRUE(gate.memory_room(40));
  EXPECT_FALSE(gate.memory_room(41));
  EXPECT_TRUE(gate.memory_room(100, 60));
  EXPECT_FALSE(gate.memory_room(101, 60));
  EXPECT_NO_THROW(gate.acquire_memory("fits", 40));
  squall::test::expect_error(Code::ResourceExhausted, "--memory-budget", [&] { gate.acquire_memory("past", 41); });
}

// A cache of pieces of 30 bytes, given back oldest first: the smallest cache there can be.
class PieceCache : public MemoryReclaimer {
 public:
  explicit PieceCache(LimitGate& gate) : gate_(gate) { gate_.add_reclaimer(this); }
  ~PieceCache() override { gate_.remove_reclaimer(this); }
  void keep() { pieces_.push_back(gate_.acquire_cache_memory("a piece", 30)); }
  size_t pieces() const { return pieces_.size(); }
  uint64_t reclaim(uint64_t bytes) override {
    for (uint64_t freed = 0; freed < bytes && !pieces_.empty(); freed += 30) pieces_.erase(pieces_.begin());
    return 0;  // given back at once
  }

 private:
  LimitGate& gate_;
  std::vector<Slot> pieces_;
};

// What caches keep counts in the budget as cached memory, and a call that finds no room takes back what it
// needs of it, no more; a cache takes nothing from another, nor a call for which all they keep is too little.
TEST(Limits, ACallTakesBackWhatCachesKeepAndOnlyWhatItNeeds) {
  Limits limits;
  limits.memory_budget = 100;
  LimitGate gate(limits);
  PieceCache cache(gate), other(gate);
  for (int i = 0; i < 3; ++i) cache.keep();
  EXPECT_EQ(gate.memory_bytes(), 90u);
  EXPECT_EQ(gate.cached_memory_bytes(), 90u);
  squall::test::expect_error(Code::ResourceExhausted, "--memory-budget", [&] { other.keep(); });
  EXPECT_EQ(cache.pieces(), 3u);
  squall::test::expect_error(Code::ResourceExhausted, "--memory-budget", [&] { gate.acquire_memory("huge", 101); });
  EXPECT_EQ(cache.pieces(), 3u);
  {
    Slot call = gate.acquire_memory("a call", 50);  // 40 bytes more than are free: two pieces
    EXPECT_EQ(cache.pieces(), 1u);
    EXPECT_EQ(gate.memory_bytes(), 80u);
    EXPECT_EQ(gate.cached_memory_bytes(), 30u);
  }
  Slot sessions = gate.acquire_memory("sessions", 70);
  squall::test::expect_error(Code::ResourceExhausted, "--memory-budget", [&] { gate.acquire_memory("past", 31); });
  EXPECT_EQ(cache.pieces(), 1u) << "the cache gave back what could not make room";
  EXPECT_NO_THROW(gate.acquire_memory("fits once the cache gives back", 30));
  EXPECT_EQ(gate.cached_memory_bytes(), 0u);
}

// A cache whose pieces, once let go of, are given back by a thread of their own `late` afterwards: as an
// OpenCL runtime may run a buffer's destructor callback after clReleaseMemObject has returned.
class LateCache : public MemoryReclaimer {
 public:
  LateCache(LimitGate& gate, std::chrono::milliseconds late) : gate_(gate), late_(late) { gate_.add_reclaimer(this); }
  ~LateCache() override {
    gate_.remove_reclaimer(this);
    for (std::thread& t : releases_) t.join();
  }
  void keep() { pieces_.push_back(gate_.acquire_cache_memory("a piece", 30)); }
  uint64_t reclaim(uint64_t bytes) override {
    uint64_t freed = 0;
    for (; freed < bytes && !pieces_.empty(); freed += 30) {
      gate_.uncache(pieces_.back());
      releases_.emplace_back([piece = std::move(pieces_.back()), late = late_]() mutable {
        std::this_thread::sleep_for(late);
        piece.release();
      });
      pieces_.pop_back();
    }
    return freed;
  }

 private:
  LimitGate& gate_;
  std::chrono::milliseconds late_;
  std::vector<Slot> pieces_;
  std::vector<std::thread> releases_;
};

// A call that finds no room waits for what the caches let go of and is given back late, for a bounded time.
TEST(Limits, ACallWaitsForTheMemoryACacheLetGoOfToComeBackLate) {
  Limits limits;
  limits.memory_budget = 60;
  LimitGate gate(limits);
  {
    LateCache cache(gate, LimitGate::kReleaseWait / 10);
    cache.keep(), cache.keep();
    const auto start = std::chrono::steady_clock::now();
    Slot call = gate.acquire_memory("a call", 60);
    EXPECT_GE(std::chrono::steady_clock::now() - start, LimitGate::kReleaseWait / 10);
    EXPECT_EQ(gate.memory_bytes(), 60u);
  }
  LateCache later(gate, LimitGate::kReleaseWait * 3);
  later.keep(), later.keep();
  squall::test::expect_error(Code::ResourceExhausted, "--memory-budget", [&] { gate.acquire_memory("a call", 60); });
}

// Work that could never fit is refused up front, whatever is held now; work that fits an empty budget is
// not, however full the budget is.
TEST(Limits, WorkPastTheWholeBudgetIsRefusedUpFront) {
  Limits limits;
  limits.memory_budget = 100;
  LimitGate gate(limits);
  const Slot held = gate.acquire_memory("held", 100);
  squall::test::expect_error(Code::ResourceExhausted, "huge (101 bytes) would pass the memory budget on its own",
                             [&] { gate.check_memory("huge", 101); });
  EXPECT_NO_THROW(gate.check_memory("fits", 100));
  EXPECT_EQ(gate.memory_bytes(), 100u) << "a check holds nothing";
}

// What a call made and a cache keeps moves from the call's memory to the cache's, counted once: with the
// budget full, the cache keeps it, the budget holds it as cached memory after the call, and a later call
// takes it back. Only this budget's call memory moves, and no more than the call holds.
TEST(Limits, ACacheTakesWhatACallMadeFromTheCallsMemory) {
  Limits limits;
  limits.memory_budget = 100;
  LimitGate gate(limits), other(limits);
  PieceCache cache(gate);
  Slot kept;
  {
    Slot call = gate.acquire_memory("a call", 100);
    EXPECT_FALSE(gate.memory_room(30));
    kept = gate.cache_from(call, 30);
    EXPECT_EQ(kept.amount(), 30u);
    EXPECT_EQ(call.amount(), 70u);
    EXPECT_EQ(gate.memory_bytes(), 100u);
    EXPECT_EQ(gate.cached_memory_bytes(), 30u);
    EXPECT_EQ(gate.cache_from(call, 71).amount(), 0u) << "more than the call holds";
    Slot elsewhere = other.acquire_memory("another budget's call", 50);
    EXPECT_EQ(gate.cache_from(elsewhere, 10).amount(), 0u) << "another budget's memory";
    EXPECT_EQ(gate.cache_from(kept, 10).amount(), 0u) << "memory a cache holds already";
    EXPECT_EQ(call.amount(), 70u);
  }
  EXPECT_EQ(gate.memory_bytes(), 30u);
  EXPECT_EQ(gate.cached_memory_bytes(), 30u);
  kept = Slot();
  EXPECT_EQ(gate.memory_bytes(), 0u);
  EXPECT_EQ(gate.cached_memory_bytes(), 0u);
}

// A holder that needs less gives part of its amount back and holds the rest; a cache's part leaves the
// cached count too, and no more than is held goes back. A share split off is held as before.
TEST(Limits, ASlotGivesPartOfItsAmountBackOrSplitsItOff) {
  Limits limits;
  limits.memory_budget = 100;
  LimitGate gate(limits);
  Slot call = gate.acquire_memory("a call", 80);
  Slot kept = gate.cache_from(call, 30);
  call.give_back(20);
  EXPECT_EQ(call.amount(), 30u);
  EXPECT_EQ(gate.memory_bytes(), 60u);
  kept.give_back(10);
  EXPECT_EQ(gate.memory_bytes(), 50u);
  EXPECT_EQ(gate.cached_memory_bytes(), 20u);
  call.give_back(1000);
  EXPECT_EQ(call.amount(), 0u);
  EXPECT_EQ(gate.memory_bytes(), 20u);
  // A share split off is held in the same counts, and goes back when its own Slot goes.
  call = gate.acquire_memory("a call", 40);
  Slot share = call.split(15);
  EXPECT_EQ(share.amount(), 15u);
  EXPECT_EQ(call.amount(), 25u);
  EXPECT_EQ(gate.memory_bytes(), 60u);
  Slot rest = call.split(1000);
  EXPECT_EQ(rest.amount(), 25u);
  EXPECT_EQ(call.amount(), 0u);
  EXPECT_EQ(gate.cache_from(share, 15).amount(), 15u) << "a share is call memory, as its Slot's; it goes";
  EXPECT_EQ(gate.memory_bytes(), 45u);
  rest = Slot();
  EXPECT_EQ(gate.memory_bytes(), 20u);
  call = Slot();
  kept = Slot();
  EXPECT_EQ(gate.memory_bytes(), 0u);
  EXPECT_EQ(gate.cached_memory_bytes(), 0u);
}

}  // namespace
}  // namespace squall
