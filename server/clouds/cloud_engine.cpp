#include "clouds/cloud_engine.h"

#include "clouds/build_memory.h"
#include "common/byte_codec.h"
#include "common/error.h"

namespace squall::clouds {
namespace {

// A checkpoint's payload (CloudEngine::kCheckpointVersion): the bytes the volume holds, then its .vdb bytes.
std::string save(const StoredVolume& volume) {
  ByteWriter out;
  out.put(volume.bytes);
  out.put_bytes(write_vdb(volume.volume));
  return out.take();
}

// What a stored volume holds: its host trees (density and temperature) and its grids on the device.
uint64_t held_bytes(const CloudVolume& volume, const NanoGrids& grids) {
  uint64_t bytes = volume.stats.bytes + grids.bytes();
  if (volume.temperature) bytes += volume.temperature->tree().memUsage();
  return bytes;
}

// The model with the engine's budgets: its max_active_voxels capped, the advection samples the daemon's.
CloudModel budgeted(CloudModel model, const CloudEngineOptions& options) {
  if (model.max_active_voxels > options.max_active_voxels) model.max_active_voxels = options.max_active_voxels;
  model.max_advection_samples = options.max_advection_samples;
  return model;
}

}  // namespace

CloudEngine::CloudEngine(Runtime& runtime, LimitGate& gate, const CloudEngineOptions& options)
    : runtime_(runtime),
      options_(options),
      renderer_(runtime, &gate),
      stored_(gate, options.sessions, "stored volume", "volume_id", "cloud-") {
  stored_.persist(kCheckpointVersion, save, [this](const std::string& bytes) { restore_checkpoint(bytes); });
}

std::shared_ptr<StoredVolume> CloudEngine::upload(CloudVolume volume, const NanoGrids& grids) {
  auto stored = std::make_shared<StoredVolume>();
  stored->bytes = held_bytes(volume, grids);
  stored->volume = std::move(volume);
  stored->device = upload_volume(runtime_, stored->volume, grids);
  return stored;
}

std::shared_ptr<StoredVolume> CloudEngine::build(CloudModel model, const std::string& field,
                                                 const Cancellation& cancel) {
  CloudVolume volume = build_cloud(budgeted(std::move(model), options_), field, cancel);
  const NanoGrids grids = to_nanovdb(volume);  // the caller reserved its build's bytes (validate())
  return upload(std::move(volume), grids);
}

uint64_t CloudEngine::validate(CloudModel model, const std::string& field) const {
  model = budgeted(std::move(model), options_);
  std::vector<MeshPiece> pieces;
  clouds::validate(model, field, &pieces);
  return build_bytes(model, pieces);
}

std::string CloudEngine::add(const std::string& id, Reservation reservation,
                             const std::shared_ptr<StoredVolume>& volume) {
  volume->id = id;
  volume->device.kept_shadow_map = std::make_shared<KeptShadowMap>();  // its renders share their map
  return stored_.add(id, std::move(reservation), volume);
}

CloudEngine::Place CloudEngine::place(const std::string& proposed, const std::string& client) {
  std::string id = stored_.id_for(proposed, kProposedIdField);
  return {std::move(id), stored_.reserve_session(client)};
}

std::string CloudEngine::keep(const std::shared_ptr<StoredVolume>& volume, Place place, Slot* build) {
  stored_.reserve_bytes(place.reservation, volume->bytes, build);
  return add(place.id, std::move(place.reservation), volume);
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
  std::string payload =
      stored_.open_checkpoint(bytes, "checkpoint", kOldestCheckpointVersion, kCheckpointVersion, &header);
  Reservation reservation = stored_.reserve_session(header.client);
  if (header.version >= 2) {  // reserved before anything is decoded
    ByteReader in(payload, "checkpoint payload", "a stored volume");
    stored_.reserve_bytes(reservation, in.get<uint64_t>("the bytes the volume holds"));
    payload.erase(0, in.offset());  // the .vdb bytes
  }
  CloudVolume volume = read_vdb(payload, "checkpoint payload");
  const NanoGrids grids = to_nanovdb(volume);  // converted, not uploaded: the device memory is taken once reserved
  // A version 1 payload, or a tree that this OpenVDB sizes otherwise than the one that wrote it.
  if (const uint64_t held = held_bytes(volume, grids); held < reservation.bytes) {
    reservation.memory.give_back(reservation.bytes - held);
    reservation.budget.give_back(reservation.bytes - held);
    reservation.bytes = held;
  } else if (held > reservation.bytes) {
    reservation.memory.release();  // given back first, not counted twice
    reservation.budget.release();
    stored_.reserve_bytes(reservation, held);
  }
  return add(header.id, std::move(reservation), upload(std::move(volume), grids));
}

}  // namespace squall::clouds
