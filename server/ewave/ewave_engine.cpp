#include "ewave/ewave_engine.h"

#include <cstdio>
#include <random>

#include "common/error.h"
#include "common/log.h"

namespace squall::ewave {

EWaveEngine::EWaveEngine(Runtime& runtime, fft::Fft& fft, LimitGate& gate, EWaveEngineOptions options)
    : runtime_(runtime), fft_(fft), gate_(gate), options_(std::move(options)) {}

std::string EWaveEngine::new_id() {
  static std::mutex mutex;
  static std::random_device device;  // the kernel's CSPRNG (getrandom) on Linux
  std::lock_guard<std::mutex> lock(mutex);
  std::string id;
  for (int word = 0; word < 4; ++word) {  // 4 x 32 = 128 bits
    char hex[9];
    std::snprintf(hex, sizeof(hex), "%08x", unsigned(device()));
    id += hex;
  }
  return id;
}

std::string EWaveEngine::add(std::unique_ptr<EWaveSession> session, Slot slot) {
  auto entry = std::make_shared<Entry>();
  entry->session = std::move(session);
  entry->slot = std::move(slot);
  entry->last_use = options_.clock();
  std::lock_guard<std::mutex> lock(mutex_);
  std::string id;
  do id = new_id();
  while (sessions_.count(id));
  sessions_.emplace(id, std::move(entry));
  return id;
}

std::string EWaveEngine::create(const EWaveConfig& config) {
  validate(config, &gate_);
  evict_idle();
  Slot slot = gate_.acquire_session();
  return add(std::make_unique<EWaveSession>(runtime_, fft_, config, options_.ocean), std::move(slot));
}

std::string EWaveEngine::create_from_state(const std::string& bytes) {
  EWaveConfig config = EWaveSession::config_from_state(bytes);
  validate(config, &gate_);
  evict_idle();
  Slot slot = gate_.acquire_session();
  auto session = std::make_unique<EWaveSession>(runtime_, fft_, config, options_.ocean);
  session->restore(bytes);
  return add(std::move(session), std::move(slot));
}

std::shared_ptr<EWaveEngine::Entry> EWaveEngine::find(const std::string& id) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = sessions_.find(id);
  if (it == sessions_.end()) fail(Code::NotFound, "session_id \"" + id + "\" is not a live eWave session");
  it->second->last_use = options_.clock();
  return it->second;
}

Frame EWaveEngine::step(const std::string& id, const StepInputs& inputs) {
  auto entry = find(id);
  std::lock_guard<std::mutex> lock(entry->mutex);
  return entry->session->step(inputs);
}

std::string EWaveEngine::state(const std::string& id) {
  auto entry = find(id);
  std::lock_guard<std::mutex> lock(entry->mutex);
  return entry->session->state();
}

void EWaveEngine::restore(const std::string& id, const std::string& bytes) {
  auto entry = find(id);
  std::lock_guard<std::mutex> lock(entry->mutex);
  entry->session->restore(bytes);
}

EWaveConfig EWaveEngine::config(const std::string& id) {
  auto entry = find(id);
  std::lock_guard<std::mutex> lock(entry->mutex);
  return entry->session->config();
}

void EWaveEngine::close(const std::string& id) {
  std::shared_ptr<Entry> entry;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = sessions_.find(id);
    if (it == sessions_.end()) fail(Code::NotFound, "session_id \"" + id + "\" is not a live eWave session");
    entry = std::move(it->second);
    sessions_.erase(it);
  }
  std::lock_guard<std::mutex> wait(entry->mutex);  // a step in flight finishes first
}

size_t EWaveEngine::evict_idle() {
  std::vector<std::shared_ptr<Entry>> evicted;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto now = options_.clock();
    for (auto it = sessions_.begin(); it != sessions_.end();) {
      if (now - it->second->last_use > options_.session_ttl) {
        evicted.push_back(std::move(it->second));
        it = sessions_.erase(it);
      } else {
        ++it;
      }
    }
  }
  if (!evicted.empty()) log(LogLevel::Info, "ewave: evicted ", evicted.size(), " idle sessions");
  return evicted.size();
}

size_t EWaveEngine::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return sessions_.size();
}

}  // namespace squall::ewave
