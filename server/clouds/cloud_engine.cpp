#include "clouds/cloud_engine.h"

#include "common/error.h"

namespace squall::clouds {

CloudEngine::CloudEngine(Runtime& runtime, LimitGate& gate, const CloudEngineOptions& options)
    : runtime_(runtime),
      options_(options),
      renderer_(runtime),
      stored_(gate, SessionPolicy{options.ttl, options.clock}, "stored volume", "volume_id", "cloud-") {}

std::shared_ptr<StoredVolume> CloudEngine::upload(CloudVolume volume) {
  auto stored = std::make_shared<StoredVolume>();
  stored->volume = std::move(volume);
  stored->device = upload_volume(runtime_, stored->volume);
  stored->bytes = stored->volume.stats.bytes + stored->device.device_bytes;
  if (stored->volume.temperature) stored->bytes += stored->volume.temperature->tree().memUsage();
  return stored;
}

std::shared_ptr<StoredVolume> CloudEngine::build(CloudModel model, const std::string& field) {
  if (model.max_active_voxels > options_.max_active_voxels) model.max_active_voxels = options_.max_active_voxels;
  return upload(build_cloud(model, field));
}

std::string CloudEngine::keep(const std::shared_ptr<StoredVolume>& volume) {
  volume->id = stored_.add(volume, volume->bytes);
  return volume->id;
}

std::shared_ptr<StoredVolume> CloudEngine::find(const std::string& id, const std::string& field) {
  return stored_.get(id, field);
}

bool CloudEngine::release(const std::string& id) { return stored_.erase(id); }

Image CloudEngine::render(const StoredVolume& volume, const RenderSettings& settings, const std::string& field) {
  return renderer_.render(volume.device, settings, field);
}

std::string CloudEngine::checkpoint(const std::string& id) {
  return stored_.checkpoint(id, kCheckpointVersion, [](const StoredVolume& v) { return write_vdb(v.volume); });
}

std::string CloudEngine::restore_checkpoint(const std::string& bytes) {
  std::shared_ptr<StoredVolume> restored;
  std::string id = stored_.restore(bytes, "checkpoint", [&](uint32_t version, const std::string& vdb, uint64_t* used) {
    if (version != kCheckpointVersion)
      fail(Code::InvalidArgument, "checkpoint has volume payload version " + std::to_string(version) +
                                      ", this squalld reads " + std::to_string(kCheckpointVersion));
    restored = upload(read_vdb(vdb, "checkpoint payload"));
    *used = restored->bytes;
    return restored;
  });
  restored->id = id;
  return id;
}

}  // namespace squall::clouds
