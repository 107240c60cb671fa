// The clouds engine of squalld (no gRPC): builds volumes, keeps them on the server under an id in a
// SessionStore (an idle TTL; a --max-sessions slot and host + device bytes against --max-session-bytes
// each; checkpointable as .vdb bytes) and renders them.
#pragma once

#include <chrono>
#include <memory>
#include <string>

#include "clouds/renderer.h"
#include "clouds/volume.h"
#include "common/limits.h"
#include "common/session_store.h"
#include "runtime/runtime.h"

namespace squall::clouds {

struct CloudEngineOptions {
  SessionPolicy sessions;  // a stored volume idle past sessions.ttl is dropped (clock: tests replace it)
  uint64_t max_active_voxels = 256ull << 20;  // cap on any model's max_active_voxels
  double max_advection_samples = 1e9;         // any model's max_advection_samples (--max-advection-samples)
};

// A built volume, uploaded to the device. Immutable once built: renders share it without a lock.
struct StoredVolume {
  std::string id;
  CloudVolume volume;
  DeviceVolume device;
  uint64_t bytes = 0;  // host tree bytes (density + temperature) + device bytes
};

class CloudEngine {
 public:
  // Version of the checkpoint payload: 2, the bytes the volume holds (a u64, StoredVolume::bytes) and then
  // its .vdb bytes; 1 (an older squalld's): the .vdb bytes alone.
  static constexpr uint32_t kCheckpointVersion = 2;
  static constexpr uint32_t kOldestCheckpointVersion = 1;

  CloudEngine(Runtime& runtime, LimitGate& gate, const CloudEngineOptions& options);

  // Builds the model (validated; its max_active_voxels is capped by the engine's) and uploads it.
  // Error(Cancelled) once `cancel` is requested (checked between stages and slices; also for render).
  std::shared_ptr<StoredVolume> build(CloudModel model, const std::string& field = "model",
                                      const Cancellation& cancel = {});
  // What build() checks before building anything: the model with the engine's budgets, validated
  // (Error(InvalidArgument) naming `field`). Returns the bytes its build holds at most (build_bytes), for the
  // caller to reserve in the memory budget first.
  uint64_t validate(CloudModel model, const std::string& field = "model") const;
  // Where a volume about to be built will be kept: its id, a new one or the client's `proposed` one
  // (SessionStore::id_for, checked again by keep()), and its --max-sessions slot (and one of `client`'s
  // --max-sessions-per-client; empty: no client's), taken before the build so that a full or draining
  // server refuses before the work (RESOURCE_EXHAUSTED, UNAVAILABLE).
  struct Place {
    std::string id;
    SessionStore<StoredVolume>::Reservation reservation;
  };
  Place place(const std::string& proposed = "", const std::string& client = "");
  // Keeps a volume in `place`; RESOURCE_EXHAUSTED past --max-session-bytes or the memory budget. Its bytes
  // move from `build`, the build's reservation, where that holds them all.
  std::string keep(const std::shared_ptr<StoredVolume>& volume, Place place, Slot* build = nullptr);
  std::string keep(const std::shared_ptr<StoredVolume>& volume) { return keep(volume, place()); }
  // The volume stored under id (its TTL restarts); NOT_FOUND naming volume_id otherwise.
  std::shared_ptr<StoredVolume> find(const std::string& id);
  // Drops a stored volume; NOT_FOUND naming volume_id (the id escaped and cut) when there is none.
  void release(const std::string& id);
  // CloudRenderer::render.
  Image render(const StoredVolume& volume, const RenderSettings& settings, const std::string& field = "settings",
               const Cancellation& cancel = {}, const Slot* map_memory = nullptr);

  // A stored volume as versioned bytes, and back under its id: its session slot and the bytes it records
  // are reserved before its .vdb bytes are read (RESOURCE_EXHAUSTED, and nothing decoded, where they do not
  // fit), then adjusted to what the volume read holds; it counts against the --max-sessions-per-client of
  // the client its checkpoint names.
  std::string checkpoint(const std::string& id);
  std::string restore_checkpoint(const std::string& bytes);

  void evict_expired() { stored_.evict_idle(); }
  size_t stored_count() const { return stored_.size(); }
  uint64_t stored_bytes() const { return stored_.bytes(); }

 private:
  using Reservation = SessionStore<StoredVolume>::Reservation;

  std::shared_ptr<StoredVolume> upload(CloudVolume volume, const NanoGrids& grids);
  // Stores a built volume under `id`, written into it before it is shared, with its reservation (made by
  // place() and keep(), or by the checkpoint's restore).
  std::string add(const std::string& id, Reservation reservation, const std::shared_ptr<StoredVolume>& volume);

  Runtime& runtime_;
  CloudEngineOptions options_;
  CloudRenderer renderer_;  // before stored_: the stored volumes' kept maps give their share back to it
  SessionStore<StoredVolume> stored_;
};

}  // namespace squall::clouds
