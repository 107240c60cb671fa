// The limits squalld enforces, all in one place. Each is a daemon flag of the same name; each check
// throws squall::Error with a message that names the request field and the flag, e.g.
//   "height.nx * height.ny = 67108864 cells exceeds --max-grid-cells = 16777216".
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

namespace squall {

struct Limits {
  uint64_t max_grid_cells = 4096ull * 4096ull;  // --max-grid-cells: cells of one field
  uint32_t max_streams = 16;                    // --max-streams: concurrent streaming calls
  uint32_t max_calls = 256;                     // --max-calls: unary calls of the capabilities running at once
  uint32_t max_streams_per_client = 0;          // --max-streams-per-client: of those, one client's (0: no
                                                // limit of its own)
  double stream_idle_seconds = 600;             // --stream-idle-timeout: how long a stream may wait on its
                                                // client (to send, or to read) before it is cancelled; 0: for ever
  uint32_t max_sessions = 64;                   // --max-sessions: live stateful sessions
  uint32_t max_sessions_per_client = 0;         // --max-sessions-per-client: of those, the ones one client
                                                // created (0: no limit of its own)
  uint64_t max_message_bytes = 64ull << 20;     // --max-message-bytes: one gRPC message
  uint64_t max_session_bytes = 2ull << 30;      // --max-session-bytes: host + device bytes of all sessions
                                                // (squalld's default: half the device's global memory)
  double max_render_samples = 4e11;             // --max-render-samples: estimated density samples of one cloud render
  double max_advection_samples = 1e9;           // --max-advection-samples: a cloud build's estimated velocity
                                                // samples (active voxels x substeps, x2 for MacCormack)
  double max_bake_work = 1e12;                  // --max-bake-work: a river bake's estimated wall-segment and
                                                // polygon-point tests (nodes x those near each)
  uint64_t memory_budget = 8ull << 30;          // --memory-budget: bytes of sessions, stored volumes and calls'
                                                // working memory together (squalld's default: 3/4 of the
                                                // cgroup memory limit, else of the physical memory)
};

class LimitGate;

// A held amount of a limited resource (a stream, a session, session bytes). Gives it back when destroyed;
// movable, not copyable.
class Slot {
 public:
  Slot() = default;
  Slot(Slot&& other) noexcept : counter_(other.counter_), also_(other.also_), amount_(other.amount_) {
    other.counter_ = nullptr;
  }
  Slot& operator=(Slot&& other) noexcept;
  Slot(const Slot&) = delete;
  Slot& operator=(const Slot&) = delete;
  ~Slot() { release(); }
  void release();
  // Gives back `bytes` of the amount held (all of it at most) and holds the rest: a holder that needs less.
  void give_back(uint64_t bytes);
  // Moves `bytes` of the amount held (all of it at most) to a Slot of their own, held in the same counts:
  // a reservation's share that is given to one use.
  Slot split(uint64_t bytes);
  // Drops the hold without giving the amount back: for a holder that outlived the counts it was taken from.
  void abandon() { counter_ = nullptr; }
  uint64_t amount() const { return counter_ ? amount_ : 0; }

 private:
  friend class LimitGate;
  Slot(std::atomic<uint64_t>* counter, uint64_t amount) : counter_(counter), amount_(amount) {}
  std::atomic<uint64_t>* counter_ = nullptr;
  std::atomic<uint64_t>* also_ = nullptr;  // a second count the amount is held in, or none
  uint64_t amount_ = 0;
};

// A cache of what the next calls would compute again, whose bytes count in the memory budget as cached
// memory: a call that finds no room in the budget takes it back (LimitGate::acquire_memory).
class MemoryReclaimer {
 public:
  virtual ~MemoryReclaimer() = default;
  // Drops what it keeps, least recently used first, until `bytes` of its memory are let go of or it keeps
  // nothing. Returns the bytes it has let go of that are not given back to the budget yet (a device runtime
  // gives them back later, from a thread of its own). Called with no lock of the caller's held.
  virtual uint64_t reclaim(uint64_t bytes) = 0;
};

class LimitGate {
 public:
  explicit LimitGate(const Limits& limits) : limits_(limits) {}
  const Limits& limits() const { return limits_; }

  // A grid size taken from a request. Each extent must be >= 1 (INVALID_ARGUMENT naming
  // field.nx / .ny / .nz) and the product at most max_grid_cells (RESOURCE_EXHAUSTED).
  // nz = 0 means a 2D grid. Sizes are signed so a negative request value is caught, not wrapped.
  void check_grid(const std::string& field, int64_t nx, int64_t ny, int64_t nz = 0) const;
  // The same for a 2D grid whose extents have fields of other names (a texture's width and height).
  void check_grid(const std::string& x_field, const std::string& y_field, int64_t nx, int64_t ny) const;

  // A reply of `bytes` of payload (planes, images, checkpoints) and up to kReplyFieldBytes of other fields
  // (names, units, spacings, statistics, framing); RESOURCE_EXHAUSTED, naming the flag, beyond
  // max_message_bytes, before the work is done (gRPC would refuse to send it, naming nothing).
  static constexpr uint64_t kReplyFieldBytes = 4096;
  void check_message_bytes(const std::string& what, uint64_t bytes) const;

  // The work a cloud render would do, estimated before it runs (density samples, an upper bound);
  // RESOURCE_EXHAUSTED naming `field` (the setting that drives it, e.g. "settings.step") beyond
  // max_render_samples, with `cheaper`: what would cost less ("a larger step, ...").
  void check_render_samples(const std::string& field, const std::string& value, double samples,
                            const std::string& cheaper) const;
  // The work a river bake would do, estimated before it runs (`tests`: wall segments and polygon points
  // tested, summed over its nodes); RESOURCE_EXHAUSTED naming `what` beyond max_bake_work.
  void check_bake_work(const std::string& what, double tests) const;

  Slot acquire_stream();  // RESOURCE_EXHAUSTED when max_streams are open
  Slot acquire_call();    // a unary call's, for its length; RESOURCE_EXHAUSTED when max_calls are running
  // One of `client`'s streams (a peer address, a token's name); RESOURCE_EXHAUSTED when it has
  // max_streams_per_client open. Clients are counted in kClientBuckets buckets by a hash of the name, so
  // the memory is fixed; two clients sharing a bucket share its limit. An empty Slot when there is no
  // such limit.
  Slot acquire_client_stream(const std::string& client);
  Slot acquire_session();  // RESOURCE_EXHAUSTED when max_sessions are live
  // One of the sessions `client` creates, held for the session's life; RESOURCE_EXHAUSTED when it has
  // max_sessions_per_client live. Counted in buckets as acquire_client_stream counts streams.
  Slot acquire_client_session(const std::string& client);
  // `bytes` more held by sessions; RESOURCE_EXHAUSTED naming `what` past max_session_bytes.
  Slot acquire_session_bytes(const std::string& what, uint64_t bytes);

  // `bytes` more of the one memory budget (a session's or stored volume's bytes, a call's working memory
  // while it runs); RESOURCE_EXHAUSTED naming `what` and --memory-budget past memory_budget. Taken before
  // the memory is allocated, so a flood is refused rather than killed by the kernel's OOM killer. Where
  // the budget has no room, the caches (add_reclaimer) first give back what they keep.
  Slot acquire_memory(const std::string& what, uint64_t bytes);
  // Makes `slot` hold what `needed()` reports, asking again until it reports no more: acquiring may make the
  // caches give back what the caller counted on finding there (its own kept spectrum), which it then
  // builds and needs room for. RESOURCE_EXHAUSTED naming `what` past the budget.
  void top_up(Slot& slot, const std::string& what, const std::function<uint64_t()>& needed);
  // RESOURCE_EXHAUSTED, worded as acquire_memory's, where `bytes` would pass the memory budget even with
  // nothing else held: work that could never run, refused before any of it is done.
  void check_memory(const std::string& what, uint64_t bytes) const;
  // acquire_memory for what a cache keeps: only room that no one holds (it takes back no cache's memory),
  // counted as cached memory until the Slot goes.
  Slot acquire_cache_memory(const std::string& what, uint64_t bytes);
  // Moves `bytes` of `held`, memory of this budget that a call holds (acquire_memory, which may have taken
  // it back from caches), to a cache: the same bytes, counted once, now as cached memory (what a call made
  // and a cache keeps after it, e.g. a render's shadow map). `held` keeps the rest. An empty Slot, and
  // `held` unchanged, where `held` is not this budget's call memory or holds fewer bytes.
  Slot cache_from(Slot& held, uint64_t bytes);
  // The reverse, for what a cache lets go while calls still use it: `cached` (acquire_cache_memory's) holds
  // its bytes on as memory that no cache can give back. No-op for any other Slot.
  void uncache(Slot& cached);
  // The caches acquire_memory takes memory back from, in the order added. A cache removes itself before it
  // goes.
  void add_reclaimer(MemoryReclaimer* cache);
  void remove_reclaimer(MemoryReclaimer* cache);
  // Whether acquire_memory(bytes) would find room once `given_back` of the bytes held now are given back
  // (a cache's own, which it would drop for them). Other holders may take the room meanwhile.
  bool memory_room(uint64_t bytes, uint64_t given_back = 0) const;
  // Waits at most kReleaseWait for memory_room(bytes); whether it came. What a cache lets go of may be given
  // back later, by a device runtime's thread: OpenCL calls a memory object's destructor callback once it has
  // freed the object's resources (OpenCL 1.2 s5.4.1, clSetMemObjectDestructorCallback), which NVIDIA's
  // runtime does after clReleaseMemObject has returned.
  static constexpr auto kReleaseWait = std::chrono::milliseconds(200);
  bool await_memory_room(uint64_t bytes) const;

  uint32_t open_streams() const { return uint32_t(streams_.load()); }
  uint32_t live_sessions() const { return uint32_t(sessions_.load()); }
  uint64_t session_bytes() const { return session_bytes_.load(); }
  uint64_t memory_bytes() const { return memory_bytes_.load(); }
  uint64_t cached_memory_bytes() const { return cached_bytes_.load(); }  // of memory_bytes(), the caches'

 private:
  static Slot take(std::atomic<uint64_t>& counter, uint64_t amount, uint64_t limit, const std::string& what,
                   const char* flag, const char* held_as);
  Slot take_memory(const std::string& what, uint64_t bytes);  // of the memory budget, taking back nothing
  // Each extent >= 1 (INVALID_ARGUMENT naming its field), their product at most max_grid_cells.
  void check_extents(const std::vector<std::string>& fields, const std::vector<int64_t>& extents) const;

  Limits limits_;
  std::atomic<uint64_t> streams_{0};
  std::atomic<uint64_t> calls_{0};
  std::atomic<uint64_t> sessions_{0};
  std::atomic<uint64_t> session_bytes_{0};
  std::atomic<uint64_t> memory_bytes_{0};
  std::atomic<uint64_t> cached_bytes_{0};
  std::mutex reclaimers_mutex_;  // held while a cache gives memory back: one call takes it back at a time
  std::vector<MemoryReclaimer*> reclaimers_;
  static constexpr size_t kClientBuckets = 4096;
  std::array<std::atomic<uint64_t>, kClientBuckets> client_streams_{};
  std::array<std::atomic<uint64_t>, kClientBuckets> client_sessions_{};
};

}  // namespace squall
