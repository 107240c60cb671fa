// squalld replicas sharing a --state-dir, no proxy: each names itself on every response; an eWave
// session created under a client-proposed id survives its replica's SIGTERM and continues on another
// replica bit for bit, and moves again to a joining replica by handover; a stored cloud volume renders
// the same image after its move; flags from SQUALL_* variables; an unwritable kernel cache is named; a drain
// that cannot checkpoint its sessions exits 5; one that cannot write its heartbeat turns NOT_SERVING.
#include <gtest/gtest.h>
#include <signal.h>

#include <atomic>
#include <filesystem>
#include <thread>
#include <vector>

#include "client/client.h"
#include "squall/v1/clouds.grpc.pb.h"
#include "squall/v1/ewave.grpc.pb.h"
#include "squall/v1/ocean.grpc.pb.h"
#include "support/daemon.h"

namespace squall {
namespace {

namespace v1 = squall::v1;
using test::Daemon;

std::string metadata(const grpc::ClientContext& context, const char* key) {
  auto it = context.GetServerInitialMetadata().find(key);
  return it == context.GetServerInitialMetadata().end() ? "" : std::string(it->second.data(), it->second.size());
}

// A client of `address` that makes `attempts` attempts of a call answered UNAVAILABLE.
client::ClientOptions options(const std::string& address, int attempts) {
  client::ClientOptions o{address, 30};
  o.attempts = attempts;
  return o;
}

// A replica's eWave and Clouds services through a client that makes `attempts` of each call (1: every status is
// the server's).
struct Replica {
  Replica(const std::string& name, const std::string& state_dir, int attempts = 1,
          std::vector<std::string> more_flags = {})
      : daemon(flags(name, state_dir, std::move(more_flags))),
        client(options(daemon.address(), attempts)),
        ewave(v1::EWave::NewStub(client.channel())),
        clouds(v1::Clouds::NewStub(client.channel())) {}
  static std::vector<std::string> flags(const std::string& name, const std::string& state_dir,
                                        std::vector<std::string> more) {
    more.insert(more.begin(), {"--fft", "vkfft", "--replica-id", name, "--state-dir", state_dir});
    more.insert(more.end(), {"--checkpoint-interval", "0", "--drain-wait", "3"});
    return more;
  }
  Daemon daemon;
  client::Client client;
  std::unique_ptr<v1::EWave::Stub> ewave;
  std::unique_ptr<v1::Clouds::Stub> clouds;
};

v1::EWaveCreateSessionRequest create_request() {
  v1::EWaveCreateSessionRequest request;
  auto* c = request.mutable_config();
  c->set_nx(64), c->set_ny(48), c->set_dx(0.01), c->set_dy(0.01);
  return request;
}

// Step n of a hull crossing the grid; the frame's height field as bytes.
v1::EWaveStepRequest step_request(const std::string& id, int n) {
  v1::EWaveStepRequest request;
  request.set_session_id(id);
  auto* in = request.mutable_inputs();
  in->set_dt(0.01);
  in->add_outputs(v1::EWAVE_OUTPUT_HEIGHT);
  auto* circle = in->add_shapes()->mutable_circle();
  circle->set_center_x(0.1 + 0.01 * n), circle->set_center_y(0.24), circle->set_radius(0.03);
  return request;
}

grpc::Status step(Replica& r, const std::string& id, int n, std::string* height, std::string* replica = nullptr) {
  auto context = r.client.context(id);
  v1::EWaveFrame frame;
  grpc::Status status = r.ewave->Step(context.get(), step_request(id, n), &frame);
  if (status.ok()) *height = frame.fields(0).SerializeAsString();
  if (replica) *replica = metadata(*context, "x-squall-replica");
  return status;
}

// A drain whose checkpoints cannot be written (the state directory moved away under the replica) loses
// what its sessions did since their last checkpoint: each is logged, and squalld exits 5, not 0.
TEST(Replicas, ADrainThatCannotCheckpointItsSessionsExitsFive) {
  const std::string root = test::temp_dir("replicas-unsaved"), state = root + "/state";
  Replica a("replica-a", state);
  v1::EWaveSessionResponse created;
  ASSERT_TRUE(
      a.ewave->CreateSession(a.client.context(client::propose_session_id()).get(), create_request(), &created).ok());
  std::filesystem::rename(state, root + "/moved");
  a.daemon.process().signal(SIGTERM);
  EXPECT_EQ(a.daemon.process().wait(30), 5) << a.daemon.process().log();
  EXPECT_NE(a.daemon.process().log().find("1 sessions could not be checkpointed"), std::string::npos);
}

// A replica that cannot write its heartbeat (its file replaced by a folder) is taken for dead by the others:
// it answers UNAVAILABLE for its sessions and turns NOT_SERVING, so that a balancer hashing sessions to it
// moves them; once the heartbeat is written again it serves them and turns SERVING.
TEST(Replicas, AReplicaThatCannotBeatTurnsNotServingUntilItBeatsAgain) {
  const std::string state = test::temp_dir("replicas-no-beat");
  Replica a("replica-a", state);
  const std::string id = client::propose_session_id();
  v1::EWaveSessionResponse created;
  ASSERT_TRUE(a.ewave->CreateSession(a.client.context(id).get(), create_request(), &created).ok());
  const std::string beat = state + "/replicas/replica-a";
  std::filesystem::remove(beat);
  std::filesystem::create_directory(beat);
  using Status = grpc::health::v1::HealthCheckResponse;
  auto becomes = [&](Status::ServingStatus want) {
    for (int i = 0; i < 100 && a.client.health() != want; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    return a.client.health() == want;
  };
  EXPECT_TRUE(becomes(Status::NOT_SERVING));
  std::string height;
  const grpc::Status refused = step(a, id, 0, &height);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::UNAVAILABLE) << refused.error_message();
  EXPECT_NE(refused.error_message().find("cannot write its heartbeat"), std::string::npos) << refused.error_message();
  std::filesystem::remove(beat);
  EXPECT_TRUE(becomes(Status::SERVING));
  EXPECT_TRUE(step(a, id, 0, &height).ok());
  EXPECT_NE(a.daemon.process().log().find("cannot write this replica's heartbeat"), std::string::npos);
}

TEST(Replicas, ASessionMovesToAnotherReplicaOnSigtermAndContinuesBitForBit) {
  const std::string state = test::temp_dir("replicas-state");
  Replica a("replica-a", state), b("replica-b", state);
  EXPECT_EQ(a.client.info().replica_id(), "replica-a");

  // The reference: the same steps on one session that never moves.
  v1::EWaveSessionResponse reference;
  ASSERT_TRUE(b.ewave->CreateSession(b.client.context().get(), create_request(), &reference).ok());
  std::vector<std::string> expected(9);
  for (int n = 0; n < 9; ++n) ASSERT_TRUE(step(b, reference.session_id(), n, &expected[n]).ok());

  const std::string id = client::propose_session_id();
  auto create = a.client.context(id);
  v1::EWaveSessionResponse created;
  ASSERT_TRUE(a.ewave->CreateSession(create.get(), create_request(), &created).ok());
  EXPECT_EQ(created.session_id(), id) << "the proposed id is the session's";
  EXPECT_EQ(metadata(*create, "x-squall-replica"), "replica-a");
  std::string height, replica;
  for (int n = 0; n < 3; ++n) {
    ASSERT_TRUE(step(a, id, n, &height, &replica).ok());
    EXPECT_EQ(height, expected[n]);
    EXPECT_EQ(replica, "replica-a");
  }

  a.daemon.process().signal(SIGTERM);
  for (int i = 0; i < 200 && a.daemon.process().log().find("checkpointed 1 sessions") == std::string::npos; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  // Within --drain-wait: answered, not cancelled. Released by the drain, the session is no longer held here,
  // so its call is refused as one of no session would be.
  grpc::Status moved = step(a, id, 3, &height);
  EXPECT_EQ(moved.error_code(), grpc::StatusCode::UNAVAILABLE) << moved.error_message();
  EXPECT_NE(moved.error_message().find("shutting down; retry on another replica"), std::string::npos)
      << moved.error_message();

  for (int n = 3; n < 6; ++n) {
    grpc::Status status = step(b, id, n, &height, &replica);
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_EQ(replica, "replica-b");
    EXPECT_EQ(height, expected[n]) << "step " << n << " after the move differs from the uninterrupted run";
  }
  EXPECT_EQ(a.daemon.process().wait(30), 0) << a.daemon.process().log();
  EXPECT_NE(b.daemon.process().log().find("resumed from the state directory"), std::string::npos);

  // A replica joins and a proxy now routes the session to it while b, its owner, lives: c asks b to hand
  // it over and answers UNAVAILABLE; the client's retry policy tries again and c resumes b's current
  // state (not a stale checkpoint: there is none newer than a's).
  Replica c("replica-c", state, 5);
  for (int n = 6; n < 9; ++n) {
    grpc::Status status = step(c, id, n, &height, &replica);
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_EQ(replica, "replica-c");
    EXPECT_EQ(height, expected[n]) << "step " << n << " after the handover differs from the uninterrupted run";
  }
  EXPECT_NE(b.daemon.process().log().find("handed over to the replica that asked for it"), std::string::npos);
  EXPECT_NE(c.daemon.process().log().find("asked to hand it over"), std::string::npos) << "the first try was refused";
}

// A session whose replica drained lives on in the state directory: another replica closes it there (the
// checkpoint removed, no session resumed), after which its id is NOT_FOUND everywhere.
TEST(Replicas, ASessionCheckpointedByADrainedReplicaClosesOnAnother) {
  const std::string state = test::temp_dir("replicas-close");
  const std::string id = client::propose_session_id();
  {
    Replica a("replica-a", state);
    v1::EWaveSessionResponse created;
    ASSERT_TRUE(a.ewave->CreateSession(a.client.context(id).get(), create_request(), &created).ok());
    std::string height;
    ASSERT_TRUE(step(a, id, 0, &height).ok());
    a.daemon.process().signal(SIGTERM);
    EXPECT_EQ(a.daemon.process().wait(30), 0) << a.daemon.process().log();
    EXPECT_NE(a.daemon.process().log().find("checkpointed 1 sessions"), std::string::npos);
  }
  Replica b("replica-b", state);
  v1::EWaveSessionRequest close;
  close.set_session_id(id);
  v1::EWaveCloseResponse closed;
  grpc::Status status = b.ewave->CloseSession(b.client.context(id).get(), close, &closed);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(b.daemon.process().log().find("resumed from the state directory"), std::string::npos)
      << "closing needs no resume";
  std::string height;
  EXPECT_EQ(step(b, id, 1, &height).error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(b.ewave->CloseSession(b.client.context(id).get(), close, &closed).error_code(),
            grpc::StatusCode::NOT_FOUND);
}

// Calls for one drained session reach two replicas at once (a proxy's ring changing while they are in
// flight): one resumes it and serves the step, the other answers UNAVAILABLE naming it, so that no step is
// served by a replica that would then let the session go. It fails when both resume it.
TEST(Replicas, TwoReplicasAskedForOneSessionAtOnceLeaveItToOne) {
  const std::string state = test::temp_dir("replicas-race");
  const std::string id = client::propose_session_id();
  {
    Replica a("replica-a", state);
    v1::EWaveSessionResponse created;
    ASSERT_TRUE(a.ewave->CreateSession(a.client.context(id).get(), create_request(), &created).ok());
    a.daemon.process().signal(SIGTERM);
    EXPECT_EQ(a.daemon.process().wait(30), 0) << a.daemon.process().log();
  }
  Replica b("replica-b", state), c("replica-c", state);
  grpc::Status status[2];
  std::string height[2], replica[2];
  std::atomic<int> ready = 0;
  std::vector<std::thread> calls;
  for (int i = 0; i < 2; ++i)
    calls.emplace_back([&, i] {
      for (++ready; ready < 2;) std::this_thread::yield();
      status[i] = step(i == 0 ? b : c, id, 0, &height[i], &replica[i]);
    });
  for (auto& t : calls) t.join();
  ASSERT_NE(status[0].ok(), status[1].ok()) << status[0].error_message() << " / " << status[1].error_message();
  const int served = status[0].ok() ? 0 : 1;
  EXPECT_EQ(status[1 - served].error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_NE(status[1 - served].error_message().find(replica[served]), std::string::npos)
      << status[1 - served].error_message();
}

v1::BuildVolumeRequest keep_a_sphere() {
  v1::BuildVolumeRequest request;
  auto* m = request.mutable_model();
  m->set_voxel_size(0.5), m->set_skin(1.0);
  m->add_spheres()->set_radius(4);
  auto* p = m->mutable_pyroclastic();
  p->set_layers(1), p->set_amplitude(1), p->mutable_noise()->set_frequency(0.3);
  request.set_keep(true);
  return request;
}

// The stored volume's image, as bytes.
grpc::Status render(Replica& r, const std::string& volume_id, std::string* image) {
  v1::RenderRequest request;
  request.set_volume_id(volume_id);
  auto* s = request.mutable_settings();
  auto* c = s->mutable_camera();
  c->mutable_eye()->set_y(-30), c->mutable_up()->set_z(1), c->set_width(24), c->set_height(16);
  s->set_step(0.25), s->add_wavelengths(550e-9), s->add_extinction(0.5);
  auto* light = s->add_lights();
  light->mutable_direction()->set_z(1), light->add_intensity(1000);
  v1::RenderResponse response;
  grpc::Status status = r.clouds->Render(r.client.context(volume_id).get(), request, &response);
  *image = response.image().SerializeAsString();
  return status;
}

TEST(Replicas, AStoredCloudVolumeMovesOnSigtermAndRendersTheSameImage) {
  const std::string state = test::temp_dir("replicas-clouds");
  Replica a("clouds-a", state), b("clouds-b", state);
  const std::string id = client::propose_session_id("cloud-");
  v1::BuildVolumeResponse built;
  ASSERT_TRUE(a.clouds->BuildVolume(a.client.context(id).get(), keep_a_sphere(), &built).ok());
  EXPECT_EQ(built.summary().volume_id(), id);
  std::string before, after;
  ASSERT_TRUE(render(a, id, &before).ok());

  a.daemon.process().signal(SIGTERM);
  EXPECT_EQ(a.daemon.process().wait(30), 0) << a.daemon.process().log();
  grpc::Status status = render(b, id, &after);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(after, before) << "the resumed volume renders bit for bit the same image";
  EXPECT_NE(b.daemon.process().log().find("stored volume " + id + " resumed"), std::string::npos);
}

// --max-sessions-per-client follows a client's sessions to the replica that resumes them: its eWave session
// and its stored volume, moved there by a drain, take its two places, so the move frees none for a third.
TEST(Replicas, AClientsMovedSessionsCountAgainstItsShareWhereTheyResume) {
  const std::string state = test::temp_dir("replicas-share");
  const std::vector<std::string> share = {"--max-sessions-per-client", "2"};
  Replica a("share-a", state, 1, share), b("share-b", state, 1, share);
  const std::string session = client::propose_session_id(), volume = client::propose_session_id("cloud-");
  v1::EWaveSessionResponse created;
  ASSERT_TRUE(a.ewave->CreateSession(a.client.context(session).get(), create_request(), &created).ok());
  v1::BuildVolumeResponse built;
  ASSERT_TRUE(a.clouds->BuildVolume(a.client.context(volume).get(), keep_a_sphere(), &built).ok());
  a.daemon.process().signal(SIGTERM);
  ASSERT_EQ(a.daemon.process().wait(30), 0) << a.daemon.process().log();

  std::string height, image;
  ASSERT_TRUE(step(b, session, 0, &height).ok());  // both resumed on b
  ASSERT_TRUE(render(b, volume, &image).ok());
  v1::EWaveSessionResponse third;
  grpc::Status refused = b.ewave->CreateSession(b.client.context().get(), create_request(), &third);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  EXPECT_NE(refused.error_message().find("2 already live, the limit is --max-sessions-per-client = 2"),
            std::string::npos)
      << refused.error_message();
  v1::EWaveSessionRequest close;
  close.set_session_id(session);
  v1::EWaveCloseResponse closed;
  ASSERT_TRUE(b.ewave->CloseSession(b.client.context(session).get(), close, &closed).ok());
  EXPECT_TRUE(b.ewave->CreateSession(b.client.context().get(), create_request(), &third).ok())
      << "closing the resumed session gave its place back";
}

TEST(Replicas, AStreamOfNoSessionEndsUnavailableWhenItsReplicaDrains) {
  Replica a("streams-a", test::temp_dir("replicas-streams"));
  v1::StreamTilesRequest request;
  auto* layer = request.mutable_tile()->add_layers();
  layer->set_extent_x(100), layer->set_extent_y(100), layer->set_nx(64), layer->set_ny(64);
  layer->set_spectrum(v1::SPECTRUM_MODEL_PIERSON_MOSKOWITZ), layer->set_wind_speed(10);
  layer->set_spreading(v1::SPREADING_MODEL_MITSUYASU), layer->set_dispersion(v1::DISPERSION_MODEL_DEEP);
  request.set_dt(0.1), request.set_frame_count(100000);
  request.add_outputs(v1::TILE_OUTPUT_HEIGHT);
  auto context = a.client.context();
  auto reader = v1::Ocean::NewStub(a.client.channel())->StreamTiles(context.get(), request);
  v1::TileChunk chunk;
  ASSERT_TRUE(reader->Read(&chunk));
  a.daemon.process().signal(SIGTERM);
  size_t more = 0;
  while (reader->Read(&chunk)) ++more;
  grpc::Status status = reader->Finish();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << status.error_message();
  EXPECT_NE(status.error_message().find("reopen the stream on another replica"), std::string::npos)
      << status.error_message();
  EXPECT_LT(more, 100000u);
  EXPECT_EQ(a.daemon.process().wait(30), 0) << a.daemon.process().log();
}

TEST(Replicas, FlagsComeFromSquallVariablesTooAndTheFlagWins) {
  std::string out;
  EXPECT_EQ(test::run({"/usr/bin/env", "SQUALL_MAX_STREAMS=0", test::squalld_path()}, &out), 2) << out;
  EXPECT_NE(out.find("SQUALL_MAX_STREAMS 0: must be an integer >= 1"), std::string::npos) << out;
  EXPECT_EQ(test::run({"/usr/bin/env", "SQUALL_LISTEN=0.0.0.0:0", test::squalld_path()}, &out), 2) << out;
  EXPECT_NE(out.find("--listen 0.0.0.0:0 is not a loopback address"), std::string::npos) << out;
  EXPECT_EQ(test::run({"/usr/bin/env", "SQUALL_MAX_STREAMS=0", test::squalld_path(), "--max-streams", "3", "--device",
                       "none"},
                      &out),
            2)
      << out;
  EXPECT_NE(out.find("--device none matches no OpenCL device"), std::string::npos) << "the flag overrode: " << out;
}

TEST(Replicas, AnUnwritableKernelCacheIsNamedAtStart) {
  std::string out;
  EXPECT_EQ(test::run({"/usr/bin/env", "-u", "POCL_CACHE_DIR", test::squalld_path(), "--listen", "127.0.0.1:0",
                       "--cache-dir", "/proc/squall-cache"},
                      &out),
            2)
      << out;
  EXPECT_NE(out.find("kernel cache /proc/squall-cache: cannot create the directory"), std::string::npos) << out;
}

}  // namespace
}  // namespace squall
