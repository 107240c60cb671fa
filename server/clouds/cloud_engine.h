// The clouds engine of squalld (no gRPC): builds volumes, keeps them on the server under an id (with an
// idle TTL and a memory cap over host and device bytes) and renders them.
#pragma once

#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "clouds/renderer.h"
#include "clouds/volume.h"
#include "runtime/runtime.h"

namespace squall::clouds {

struct CloudEngineOptions {
  std::chrono::milliseconds ttl{std::chrono::minutes(10)};  // a stored volume idle this long is dropped
  uint64_t max_stored_bytes = 2ull << 30;                   // host + device bytes of all stored volumes
  uint64_t max_active_voxels = 256ull << 20;                // cap on any model's max_active_voxels
};

// A built volume, uploaded to the device.
struct StoredVolume {
  std::string id;
  CloudVolume volume;
  DeviceVolume device;
  uint64_t bytes = 0;  // host tree bytes (density + temperature) + device bytes
};

class CloudEngine {
 public:
  CloudEngine(Runtime& runtime, const CloudEngineOptions& options);

  // Builds the model (validated; its max_active_voxels is capped by the engine's) and uploads it.
  std::shared_ptr<StoredVolume> build(CloudModel model, const std::string& field = "model");
  // Keeps a volume under a new id; RESOURCE_EXHAUSTED when the stored bytes would exceed the cap.
  std::string keep(const std::shared_ptr<StoredVolume>& volume);
  // The volume stored under id (its TTL restarts); NOT_FOUND naming `field` otherwise.
  std::shared_ptr<StoredVolume> find(const std::string& id, const std::string& field = "volume_id");
  bool release(const std::string& id);
  Image render(const StoredVolume& volume, const RenderSettings& settings, const std::string& field = "settings");

  void evict_expired();
  size_t stored_count();
  uint64_t stored_bytes();

 private:
  struct Entry {
    std::shared_ptr<StoredVolume> volume;
    std::chrono::steady_clock::time_point last_used;
  };
  Runtime& runtime_;
  CloudEngineOptions options_;
  CloudRenderer renderer_;
  std::mutex mutex_;
  std::map<std::string, Entry> stored_;
  uint64_t stored_bytes_ = 0;
  uint64_t next_id_ = 1;
};

}  // namespace squall::clouds
