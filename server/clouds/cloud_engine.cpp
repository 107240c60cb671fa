#include "clouds/cloud_engine.h"

#include <cstdio>
#include <random>

#include "common/error.h"

namespace squall::clouds {

CloudEngine::CloudEngine(Runtime& runtime, const CloudEngineOptions& options)
    : runtime_(runtime), options_(options), renderer_(runtime) {}

std::shared_ptr<StoredVolume> CloudEngine::build(CloudModel model, const std::string& field) {
  if (model.max_active_voxels > options_.max_active_voxels) model.max_active_voxels = options_.max_active_voxels;
  auto stored = std::make_shared<StoredVolume>();
  stored->volume = build_cloud(model, field);
  stored->device = upload_volume(runtime_, stored->volume);
  stored->bytes = stored->volume.stats.bytes + stored->device.device_bytes;
  if (stored->volume.temperature) stored->bytes += stored->volume.temperature->tree().memUsage();
  return stored;
}

std::string CloudEngine::keep(const std::shared_ptr<StoredVolume>& volume) {
  evict_expired();
  std::lock_guard<std::mutex> lock(mutex_);
  if (stored_bytes_ + volume->bytes > options_.max_stored_bytes)
    fail(Code::ResourceExhausted, "keeping this volume (" + std::to_string(volume->bytes) + " bytes) would exceed " +
                                      "the clouds store's cap of " + std::to_string(options_.max_stored_bytes) +
                                      " bytes (" + std::to_string(stored_bytes_) + " in use); release volumes first");
  // Ids are not guessable: a random part besides the counter.
  static thread_local std::mt19937_64 rng(std::random_device{}());
  char id[40];
  std::snprintf(id, sizeof id, "cloud-%llu-%016llx", (unsigned long long)next_id_++, (unsigned long long)rng());
  volume->id = id;
  stored_[id] = {volume, std::chrono::steady_clock::now()};
  stored_bytes_ += volume->bytes;
  return id;
}

std::shared_ptr<StoredVolume> CloudEngine::find(const std::string& id, const std::string& field) {
  evict_expired();
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = stored_.find(id);
  if (it == stored_.end())
    fail(Code::NotFound, field + " = \"" + id + "\" is not a stored volume (unknown, released or expired)");
  it->second.last_used = std::chrono::steady_clock::now();
  return it->second.volume;
}

bool CloudEngine::release(const std::string& id) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = stored_.find(id);
  if (it == stored_.end()) return false;
  stored_bytes_ -= it->second.volume->bytes;
  stored_.erase(it);
  return true;
}

Image CloudEngine::render(const StoredVolume& volume, const RenderSettings& settings, const std::string& field) {
  return renderer_.render(volume.device, settings, field);
}

void CloudEngine::evict_expired() {
  std::lock_guard<std::mutex> lock(mutex_);
  auto now = std::chrono::steady_clock::now();
  for (auto it = stored_.begin(); it != stored_.end();) {
    if (now - it->second.last_used > options_.ttl) {
      stored_bytes_ -= it->second.volume->bytes;
      it = stored_.erase(it);
    } else {
      ++it;
    }
  }
}

size_t CloudEngine::stored_count() {
  std::lock_guard<std::mutex> lock(mutex_);
  return stored_.size();
}

uint64_t CloudEngine::stored_bytes() {
  std::lock_guard<std::mutex> lock(mutex_);
  return stored_bytes_;
}

}  // namespace squall::clouds
