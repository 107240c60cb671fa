// The clouds engine's volume store (ids, idle TTL, memory cap) and the OBJ reader.
#include <gtest/gtest.h>

#include <functional>
#include <memory>

#include "clouds/cloud_engine.h"
#include "clouds/obj_mesh.h"
#include "common/byte_codec.h"
#include "common/error.h"
#include "common/session_checkpoint.h"
#include "support/expect_error.h"
#include "support/test_runtime.h"

namespace squall::clouds {
namespace {

CloudModel small_sphere() {
  CloudModel m;
  m.voxel_size = 0.5;
  m.skin = 1;
  m.spheres.push_back({{0, 0, 0}, 3});
  return m;
}

// An engine with its own limits and a clock the test moves.
struct TestStore {
  explicit TestStore(Limits limits = {}, CloudEngineOptions options = {}) : gate(limits) {
    options.sessions.clock = [this] { return now; };
    engine = std::make_unique<CloudEngine>(test::runtime(), gate, options);
  }
  LimitGate gate;
  std::chrono::steady_clock::time_point now{};
  std::unique_ptr<CloudEngine> engine;
};

std::string error_of(const std::function<void()>& f, Code code) { return test::expect_error(code, "", f); }

TEST(Engine, StoresFindsAndReleasesVolumes) {
  TestStore store;
  CloudEngine& engine = *store.engine;
  auto v = engine.build(small_sphere());
  EXPECT_GT(v->bytes, v->device.device_bytes);
  std::string id = engine.keep(v);
  EXPECT_EQ(engine.find(id)->volume.stats.active_voxels, v->volume.stats.active_voxels);
  EXPECT_EQ(engine.stored_count(), 1u);
  EXPECT_EQ(engine.stored_bytes(), v->bytes);
  engine.release(id);
  EXPECT_EQ(engine.stored_bytes(), 0u);
  std::string msg = error_of([&] { engine.find(id); }, Code::NotFound);
  EXPECT_NE(msg.find("volume_id = \"" + id + "\""), std::string::npos) << msg;
}

TEST(Engine, IdleVolumesExpireAndTheMemoryCapHolds) {
  CloudEngineOptions options;
  options.sessions.ttl = std::chrono::milliseconds(50);
  TestStore store({}, options);
  CloudEngine& engine = *store.engine;
  std::string id = engine.keep(engine.build(small_sphere()));
  store.now += std::chrono::milliseconds(40);
  engine.find(id);  // used: its idle time restarts
  store.now += std::chrono::milliseconds(40);
  EXPECT_EQ(engine.stored_count(), 1u);
  store.now += std::chrono::milliseconds(20);
  error_of([&] { engine.find(id); }, Code::NotFound);
  EXPECT_EQ(engine.stored_count(), 0u);

  options.sessions.ttl = std::chrono::minutes(1);
  auto v = engine.build(small_sphere());
  Limits limits;
  limits.max_session_bytes = v->bytes + v->bytes / 2;  // room for one
  TestStore capped_store(limits, options);
  CloudEngine& capped = *capped_store.engine;
  capped.keep(v);
  std::string msg = error_of([&] { capped.keep(capped.build(small_sphere())); }, Code::ResourceExhausted);
  EXPECT_NE(msg.find("cap"), std::string::npos) << msg;
}

// A volume kept after its build takes its bytes from the build's reservation, which counted them, rather than
// from the budget a second time; and with every --max-sessions slot taken, the next is refused before a build.
TEST(Engine, AKeptVolumeMovesItsBytesFromItsBuildsReservation) {
  const CloudModel model = small_sphere();
  TestStore probe;
  const uint64_t build_bytes = probe.engine->validate(model), volume_bytes = probe.engine->build(model)->bytes;
  ASSERT_LT(volume_bytes, build_bytes);
  Limits limits;
  limits.memory_budget = build_bytes + volume_bytes / 2;  // the build, not the build and the volume again
  limits.max_sessions = 1;
  TestStore store(limits);
  CloudEngine& engine = *store.engine;
  CloudEngine::Place place = engine.place();
  Slot build = store.gate.acquire_memory("the build", engine.validate(model));
  engine.keep(engine.build(model), std::move(place), &build);
  EXPECT_EQ(build.amount(), build_bytes - volume_bytes);
  build.release();
  EXPECT_EQ(store.gate.memory_bytes(), volume_bytes);
  std::string msg = error_of([&] { engine.place(); }, Code::ResourceExhausted);
  EXPECT_NE(msg.find("--max-sessions"), std::string::npos) << msg;
}

// A client's stored volumes count against --max-sessions-per-client from their place on, before the build;
// another client, and volumes kept for no client (resumed from checkpoints), keep their share.
TEST(Engine, AClientsStoredVolumesCountAgainstItsShare) {
  Limits limits;
  limits.max_sessions_per_client = 1;
  TestStore store(limits);
  CloudEngine& engine = *store.engine;
  const std::string id = engine.keep(engine.build(small_sphere()), engine.place("", "ipv4:127.0.0.1"));
  std::string msg = error_of([&] { engine.place("", "ipv4:127.0.0.1"); }, Code::ResourceExhausted);
  EXPECT_NE(msg.find("sessions of ipv4:127.0.0.1: 1 already live, the limit is --max-sessions-per-client = 1"),
            std::string::npos)
      << msg;
  EXPECT_NO_THROW(engine.place("", "ipv6:[::1]"));
  EXPECT_NO_THROW(engine.place());
  engine.release(id);
  EXPECT_NO_THROW(engine.place("", "ipv4:127.0.0.1"));
}

// A kept volume's renders from two cameras make one deep shadow map, held in the memory budget until the
// volume is released; a volume rendered without being kept keeps none.
TEST(Engine, AKeptVolumeKeepsItsShadowMapUntilReleased) {
  TestStore store;
  CloudEngine& engine = *store.engine;
  RenderSettings s;
  Light sun;
  sun.intensity = {1000};
  s.lights = {sun};
  s.shadow_map_size = {32, 32, 32};
  const auto once = engine.build(small_sphere());
  engine.render(*once, s);
  EXPECT_FALSE(once->device.kept_shadow_map);
  const uint64_t before = store.gate.memory_bytes();
  std::string id = engine.keep(engine.build(small_sphere()));
  const uint64_t stored = store.gate.memory_bytes();
  engine.render(*engine.find(id), s);
  s.camera.eye = {10, -25, 4};
  engine.render(*engine.find(id), s);
  EXPECT_EQ(engine.find(id)->device.kept_shadow_map->made, 1u);
  EXPECT_EQ(store.gate.memory_bytes(), stored + 32 * 32 * 32 * sizeof(float));
  engine.release(id);
  EXPECT_EQ(store.gate.memory_bytes(), before);
}

TEST(Engine, CheckpointRestoresTheVolumeUnderItsIdAsVdb) {
  TestStore store;
  CloudEngine& engine = *store.engine;
  auto v = engine.build(small_sphere());
  std::string id = engine.keep(v);
  std::string saved = engine.checkpoint(id);
  engine.release(id);
  EXPECT_EQ(engine.restore_checkpoint(saved), id);
  auto restored = engine.find(id);
  EXPECT_EQ(restored->id, id);
  EXPECT_EQ(restored->volume.stats.active_voxels, v->volume.stats.active_voxels);
  EXPECT_EQ(restored->volume.stats.bounds, v->volume.stats.bounds);
  EXPECT_EQ(restored->device.device_bytes, v->device.device_bytes);
  EXPECT_EQ(engine.stored_bytes(), restored->bytes);
  error_of([&] { engine.restore_checkpoint(saved); }, Code::AlreadyExists);
}

// A checkpoint whose volume does not fit is refused before its grids take device memory: no upload (no
// queue leased) happens.
TEST(Engine, ACheckpointThatDoesNotFitIsRefusedBeforeItsUpload) {
  TestStore store;
  auto v = store.engine->build(small_sphere());
  const std::string id = store.engine->keep(v);
  const std::string saved = store.engine->checkpoint(id);
  Limits limits;
  limits.max_session_bytes = v->bytes - 1;
  TestStore capped(limits);
  const uint64_t uploads = test::runtime().device_wait().acquisitions;
  error_of([&] { capped.engine->restore_checkpoint(saved); }, Code::ResourceExhausted);
  EXPECT_EQ(test::runtime().device_wait().acquisitions, uploads);
  EXPECT_EQ(capped.engine->stored_count(), 0u);
  limits.max_session_bytes = v->bytes;
  TestStore fits(limits);
  EXPECT_EQ(fits.engine->restore_checkpoint(saved), id);
  EXPECT_EQ(fits.engine->stored_bytes(), v->bytes);
}

// A checkpoint records the bytes its volume holds, and those are reserved before its .vdb bytes are decoded:
// a record past the limits is refused as such even where the bytes that follow are no .vdb at all. A record
// off either way (another OpenVDB's sizes) and one of the first payload version (the .vdb bytes alone, as an
// older squalld writes them) resume, reserved as the volume read holds.
TEST(Engine, ACheckpointsRecordedSizeIsReservedBeforeItIsDecoded) {
  TestStore store;
  auto v = store.engine->build(small_sphere());
  const std::string id = store.engine->keep(v);
  const CheckpointHeader header{"stored volume", CloudEngine::kCheckpointVersion, id};
  ByteWriter huge;
  huge.put(uint64_t(1) << 60);
  huge.put_bytes("not a .vdb stream");
  store.engine->release(id);
  const uint64_t before = store.gate.memory_bytes();
  error_of([&] { store.engine->restore_checkpoint(encode_checkpoint(header, huge.take())); }, Code::ResourceExhausted);
  ByteWriter fits;
  fits.put(v->bytes);
  fits.put_bytes("not a .vdb stream");
  error_of([&] { store.engine->restore_checkpoint(encode_checkpoint(header, fits.take())); }, Code::InvalidArgument);
  EXPECT_EQ(store.engine->stored_count(), 0u);
  EXPECT_EQ(store.gate.memory_bytes(), before) << "a refused checkpoint keeps no reservation";

  // Recorded sizes off either way (another OpenVDB's), and none (version 1): reserved as the volume read holds.
  for (const uint64_t recorded : {v->bytes + 4096, v->bytes - 1, uint64_t(0)}) {
    ByteWriter payload;
    if (recorded) payload.put(recorded);
    payload.put_bytes(write_vdb(v->volume));
    const uint32_t version = recorded ? CloudEngine::kCheckpointVersion : 1;
    EXPECT_EQ(store.engine->restore_checkpoint(encode_checkpoint({"stored volume", version, id}, payload.take())), id);
    EXPECT_EQ(store.engine->find(id)->bytes, v->bytes);
    EXPECT_EQ(store.engine->stored_bytes(), v->bytes) << "recorded " << recorded;
    EXPECT_EQ(store.gate.memory_bytes(), before + v->bytes) << "recorded " << recorded;
    store.engine->release(id);
  }
}

TEST(Engine, ModelBudgetIsCappedByTheEngine) {
  CloudEngineOptions options;
  options.max_active_voxels = 500;
  TestStore store({}, options);
  CloudEngine& engine = *store.engine;
  CloudModel m = small_sphere();
  m.max_active_voxels = ~0ull;
  std::string msg = error_of([&] { engine.build(m); }, Code::ResourceExhausted);
  EXPECT_NE(msg.find("max_active_voxels = 500"), std::string::npos) << msg;
}

TEST(Obj, QuadCubeBuildsTheSameCloudAsItsTriangles) {
  const char* obj =
      "# unit cube, quads\nv -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n"
      "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 3 4 8 7\nf 2 3 7 6\nf 1/1 5/2 8/3 4/4\n";
  TriangleMesh mesh = parse_obj(obj, "model.meshes[0].obj");
  EXPECT_EQ(mesh.vertices.size(), 8u);
  EXPECT_EQ(mesh.triangles.size(), 36u);
  CloudModel m;
  m.voxel_size = 0.1;
  m.skin = 0.2;
  m.meshes.push_back(mesh);
  CloudVolume v = build_cloud(m);
  EXPECT_GE(v.stats.active_voxels, 19u * 19 * 19);
  EXPECT_LE(v.stats.active_voxels, 21u * 21 * 21);
  std::string msg = error_of([] { parse_obj("v 0 0 0\nf 1 2 3\n", "model.meshes[1].obj"); }, Code::InvalidArgument);
  EXPECT_NE(msg.find("model.meshes[1].obj line 2"), std::string::npos) << msg;
  // Numbers are read whole and in decimal: a fractional index, a coordinate with more after it, one that is
  // not finite or hexadecimal is refused naming it (escaped), not read in part.
  const std::string triangle = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  for (const auto& [text, needle] : std::vector<std::pair<std::string, std::string>>{
           {triangle + "f 1.9 2 3\n", "line 4: face index \"1.9\" is not a whole number"},
           {triangle + "f 1 2 x\n", "line 4: face index \"x\" is not a whole number"},
           {"v 0 0 nan\n", "line 1: vertex coordinate \"nan\" is not a finite decimal number"},
           {"v 0 0 1e999\n", "line 1: vertex coordinate \"1e999\" is not a finite decimal number"},
           {"v 0 0 1m\n", "line 1: vertex coordinate \"1m\" is not a finite decimal number"},
           {"v 0 0 0x1p3\n", "line 1: vertex coordinate \"0x1p3\" is not a finite decimal number"},
           {"v 0 0 \x01\n", "line 1: vertex coordinate \"\\x01\" is not a finite decimal number"},
           {"v 0 0\n", "line 1: a vertex needs three numbers"}}) {
    msg = error_of([&] { parse_obj(text, "obj"); }, Code::InvalidArgument);
    EXPECT_NE(msg.find(needle), std::string::npos) << msg;
  }
  EXPECT_EQ(parse_obj("v 0 0 0 1\nv 1 0 0 1\nv 0 1 0 1\nf 1/1/1 2//2 -1\n", "obj").triangles.size(), 3u)
      << "a w after x y z, and v/vt/vn and negative indices, as OBJ allows";
  EXPECT_EQ(parse_obj("v 0 0 0 # a\nv 1 0 0#b\nv 0 1 0\nf 1 2 3 # c\nf 3 2 1#\n# f 1 2 3\n", "obj").triangles.size(),
            6u)
      << "a comment after a vertex or a face, or in place of a line";
}

}  // namespace
}  // namespace squall::clouds
