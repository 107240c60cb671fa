#include "clouds/cloud_engine.h"

#include "clouds/build_memory.h"
#include "common/error.h"

namespace squall::clouds {
namespace {

// A checkpoint's payload: the volume as .vdb bytes.
std::string save(const StoredVolume& volume) { return write_vdb(volume.volume); }

}  // namespace

CloudEngine::CloudEngine(Runtime& runtime, LimitGate& gate, const CloudEngineOptions& options)
    : runtime_(runtime),
      options_(options),
      renderer_(runtime, &gate),
      stored_(gate, options.sessions, "stored volume", "volume_id", "cloud-") {
  stored_.persist(kCheckpointVersion, save, [this](const std::string& bytes) { restore_checkpoint(bytes); });
}

std::shared_ptr<StoredVolume> CloudEngine::upload(CloudVolume volume) {
  auto stored = std::make_shared<StoredVolume>();
  stored->volume = std::move(volume);
  stored->device = upload_volume(runtime_, stored->volume);
  stored->bytes = stored->volume.stats.bytes + stored->device.device_bytes;
  if (stored->volume.temperature) stored->bytes += stored->volume.temperature->tree().memUsage();
  return stored;
}

namespace {

// The model with the engine's budgets: its max_active_voxels capped, the advection samples the daemon's.
CloudModel budgeted(CloudModel model, const CloudEngineOptions& options) {
  if (model.max_active_voxels > options.max_active_voxels) model.max_active_voxels = options.max_active_voxels;
  model.max_advection_samples = options.max_advection_samples;
  return model;
}

}  // namespace

std::shared_ptr<StoredVolume> CloudEngine::build(CloudModel model, const std::string& field,
                                                 const Cancellation& cancel) {
  return upload(build_cloud(budgeted(std::move(model), options_), field, cancel));
}

uint64_t CloudEngine::validate(CloudModel model, const std::string& field) const {
  model = budgeted(std::move(model), options_);
  std::vector<MeshPiece> pieces;
  clouds::validate(model, field, &pieces);
  return build_bytes(model, pieces);
}

std::string CloudEngine::store(const std::string& id, const std::shared_ptr<StoredVolume>& volume) {
  auto reservation = stored_.reserve(volume->bytes);
  volume->id = id;
  volume->device.kept_shadow_map = std::make_shared<KeptShadowMap>();  // its renders share their map
  return stored_.add(id, std::move(reservation), volume);
}

std::string CloudEngine::kept_id(const std::string& proposed) const {
  return stored_.id_for(proposed, kProposedIdField);
}

std::string CloudEngine::keep(const std::shared_ptr<StoredVolume>& volume, const std::string& id) {
  return store(id, volume);
}

std::shared_ptr<StoredVolume> CloudEngine::find(const std::string& id) { return stored_.get(id); }

void CloudEngine::release(const std::string& id) { stored_.close(id); }

Image CloudEngine::render(const StoredVolume& volume, const RenderSettings& settings, const std::string& field,
                          const Cancellation& cancel, const Slot* map_memory) {
  return renderer_.render(volume.device, settings, field, cancel, map_memory);
}

std::string CloudEngine::checkpoint(const std::string& id) { return stored_.checkpoint(id, kCheckpointVersion, save); }

std::string CloudEngine::restore_checkpoint(const std::string& bytes) {
  CheckpointHeader header;
  std::string vdb = stored_.open_checkpoint(bytes, "checkpoint", kCheckpointVersion, &header);
  // Like BuildVolume with keep, the volume is built first: its bytes are known once it is uploaded.
  return store(header.id, upload(read_vdb(vdb, "checkpoint payload")));
}

}  // namespace squall::clouds
