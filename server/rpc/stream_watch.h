// StreamWatch: ends streaming calls that wait on their client too long. A stream blocked in a read (its
// client sends nothing) or in a write (its client reads nothing: HTTP/2 flow control) holds a
// --max-streams slot; once it has waited --stream-idle-timeout seconds it is cancelled, and the slot
// comes back. Time a stream spends computing its next frame is not waiting.
#pragma once

#include <grpcpp/server_context.h>

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

namespace squall::rpc {

// One stream as the watch sees it: since when it waits on its client (steady-clock nanoseconds; 0 while it
// does not), and whether the watch cancelled it.
struct StreamWaiting {
  explicit StreamWaiting(grpc::ServerContext& context) : context(context) {}
  grpc::ServerContext& context;
  std::atomic<int64_t> since_ns{0};
  std::atomic<bool> idled_out{false};
};

class StreamWatch {
 public:
  // idle_seconds 0: streams may wait on their clients for ever (no thread is started).
  explicit StreamWatch(double idle_seconds);
  ~StreamWatch();
  StreamWatch(const StreamWatch&) = delete;
  StreamWatch& operator=(const StreamWatch&) = delete;

  // A stream is watched from add() to remove(), which its call makes before its context goes.
  void add(StreamWaiting* stream);
  void remove(StreamWaiting* stream);
  double idle_seconds() const { return idle_seconds_; }

  static int64_t now_ns();

 private:
  void run();
  std::vector<std::string> cancel_idle(int64_t now);  // the peers of the streams it cancels

  const double idle_seconds_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::set<StreamWaiting*> streams_;
  std::thread thread_;  // last: started once the members above exist
};

}  // namespace squall::rpc
