#include "rpc/stream_watch.h"

#include <algorithm>
#include <chrono>

#include "common/log.h"
#include "common/validate.h"

namespace squall::rpc {

StreamWatch::StreamWatch(double idle_seconds) : idle_seconds_(idle_seconds) {
  if (idle_seconds_ > 0) thread_ = std::thread([this] { run(); });
}

StreamWatch::~StreamWatch() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void StreamWatch::add(StreamWaiting* stream) {
  std::lock_guard<std::mutex> lock(mutex_);
  streams_.insert(stream);
}

void StreamWatch::remove(StreamWaiting* stream) {
  std::lock_guard<std::mutex> lock(mutex_);
  streams_.erase(stream);
}

int64_t StreamWatch::now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// Looks a few times per timeout (at most once a second), so a stream ends at most a quarter late.
void StreamWatch::run() {
  const auto period = std::chrono::duration<double>(std::min(1.0, idle_seconds_ / 4));
  std::unique_lock<std::mutex> lock(mutex_);
  while (!wake_.wait_for(lock, period, [this] { return stopping_; })) {
    const std::vector<std::string> cancelled = cancel_idle(now_ns());
    lock.unlock();
    for (const std::string& peer : cancelled)
      log(LogLevel::Warn, "stream from ", peer, " waited on its client for ", validate::number(idle_seconds_),
          " s (--stream-idle-timeout): cancelled, its stream slot freed");
    lock.lock();
  }
}

// Under mutex_, which keeps each context alive (a call removes its stream before it ends); the log lines
// are written once it is released.
std::vector<std::string> StreamWatch::cancel_idle(int64_t now) {
  const auto limit = int64_t(idle_seconds_ * 1e9);
  std::vector<std::string> peers;
  for (StreamWaiting* stream : streams_) {
    const int64_t since = stream->since_ns.load();
    if (since == 0 || now - since < limit || stream->idled_out.exchange(true)) continue;
    peers.push_back(stream->context.peer());
    stream->context.TryCancel();
  }
  return peers;
}

}  // namespace squall::rpc
