// squalld for real: started on a free localhost port, asked through the client library and the CLI,
// stopped with SIGTERM; and started wrongly, to see it refuse with the documented exit codes.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <signal.h>

#include <atomic>
#include <filesystem>
#include <algorithm>
#include <fstream>
#include <thread>
#include <tuple>

#include <grpcpp/generic/generic_stub.h>

#include "client/client.h"
#include "squall/v1/clouds.grpc.pb.h"
#include "squall/v1/ocean.grpc.pb.h"
#include "support/daemon.h"
#include "support/long_work.h"
#include "support/test_runtime.h"

namespace squall {
namespace {

using test::Daemon;
const std::string kSqualld = test::squalld_path();
const std::string kSquall = test::squall_path();

// One daemon for the tests that only talk to it (start-up builds kernels: do it once). A static
// object, so that its destructor stops the process when the test binary exits.
Daemon& shared_daemon() {
  static Daemon d({"--fft", "vkfft", "--max-sessions", "7", "--max-grid-cells", "123456"});
  return d;
}

TEST(Daemon, GetInfoThroughTheClientLibrary) {
  client::Client c({shared_daemon().address(), 10, "info-test-1"});
  auto info = c.info();
  EXPECT_TRUE(info.ready());
  EXPECT_EQ(info.version(), SQUALL_VERSION);
  EXPECT_EQ(info.fft_backend(), "vkfft");
  EXPECT_EQ(info.limits().max_sessions(), 7u);
  EXPECT_EQ(info.limits().max_grid_cells(), 123456u);
  EXPECT_EQ(info.limits().max_message_bytes(), 64u << 20);
  int selected = 0;
  for (const auto& d : info.devices()) selected += d.selected();
  EXPECT_EQ(selected, 1);
  bool selftest = false;
  for (const auto& k : info.kernels())
    selftest |= k.program() == "runtime/selftest.cl" && k.kernels_size() == 3;  // axpy, fill, count_ids
  EXPECT_TRUE(selftest);
  EXPECT_GT(info.uptime_seconds(), 0);
}

// The server as a whole, each service by its name and the liveness name (which the memory budget and a
// drain leave SERVING: tests/python/test_limits.py) all say SERVING once the kernels are built.
TEST(Daemon, HealthIsServing) {
  client::Client c({shared_daemon().address(), 10, ""});
  for (const char* service : {"", "squall.v1.Ocean", "squall.v1.EWave", "squall.v1.Clouds", "squall.v1.Textures",
                              "squall.v1.Server", "liveness"})
    EXPECT_EQ(c.health(service), grpc::health::v1::HealthCheckResponse::SERVING) << service;
  std::string out;
  EXPECT_EQ(test::run({kSquall, "--address", shared_daemon().address(), "health", "squall.v1.Ocean"}, &out), 0) << out;
  EXPECT_NE(out.find("SERVING"), std::string::npos) << out;
}

// Each health Watch holds a server thread and needs no token by default: at most 64 are open at once, and a
// closed one makes room for the next.
TEST(Daemon, HealthWatchStreamsAreBounded) {
  client::Client c({shared_daemon().address(), 10, ""});
  auto health = grpc::health::v1::Health::NewStub(c.channel());
  struct Watcher {
    std::unique_ptr<grpc::ClientContext> context = std::make_unique<grpc::ClientContext>();
    std::unique_ptr<grpc::ClientReader<grpc::health::v1::HealthCheckResponse>> reader;
  };
  auto open = [&] {
    Watcher w;
    w.reader = health->Watch(w.context.get(), grpc::health::v1::HealthCheckRequest());
    return w;
  };
  grpc::health::v1::HealthCheckResponse update;
  std::vector<Watcher> watchers;
  for (int i = 0; i < 64; ++i) {
    watchers.push_back(open());
    ASSERT_TRUE(watchers.back().reader->Read(&update)) << "watch " << i;
  }
  Watcher refused = open();
  EXPECT_FALSE(refused.reader->Read(&update));
  const grpc::Status status = refused.reader->Finish();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_NE(status.error_message().find("health Watch: 64 streams are open"), std::string::npos);
  watchers.back().context->TryCancel();
  watchers.back().reader->Finish();
  watchers.pop_back();
  bool reopened = false;
  for (int attempt = 0; attempt < 50 && !reopened; ++attempt) {  // the server sees the cancel within 200 ms
    Watcher again = open();
    reopened = again.reader->Read(&update);
    again.context->TryCancel();
    again.reader->Finish();
    if (!reopened) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_TRUE(reopened);
  for (Watcher& w : watchers) {
    w.context->TryCancel();
    w.reader->Finish();
  }
}

TEST(Daemon, LogsOneLinePerRequestWithIdMethodStatusAndDuration) {
  client::Client c({shared_daemon().address(), 10, "log-test-42"});
  c.info();
  std::string log;
  for (int i = 0; i < 50 && log.find("log-test-42") == std::string::npos; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    log = shared_daemon().process().log();
  }
  EXPECT_NE(log.find("request id=log-test-42 method=/squall.v1.Server/GetInfo status=OK duration_ms="),
            std::string::npos)
      << log;
}

// A request_id is the client's text: a newline in it must not start a second (forged) log line, and a
// long one is refused (server.proto: at most 128 characters) and cut in the log.
TEST(Daemon, ClientTextInTheLogIsEscapedAndCut) {
  auto stub = squall::v1::Server::NewStub(client::Client({shared_daemon().address(), 10, ""}).channel());
  grpc::ClientContext context;
  squall::v1::GetInfoRequest request;
  request.set_request_id("log-test-44\n2026-01-01T00:00:00Z INFO  request id=forged" + std::string(4000, 'y'));
  squall::v1::GetInfoResponse reply;
  const grpc::Status status = stub->GetInfo(&context, request, &reply);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_NE(status.error_message().find("request_id has 4056 bytes: at most 128"), std::string::npos)
      << status.error_message();
  std::string log;
  for (int i = 0; i < 50 && log.find("log-test-44") == std::string::npos; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    log = shared_daemon().process().log();
  }
  // Unquoted, the id is one word: its spaces escaped too, so that it adds no fields of its own.
  EXPECT_NE(log.find("request id=log-test-44\\x0a2026-01-01T00:00:00Z\\x20INFO\\x20\\x20request\\x20id=forged"),
            std::string::npos)
      << log;
  EXPECT_EQ(log.find("\n2026-01-01T00:00:00Z INFO  request id=forged"), std::string::npos) << log;
  EXPECT_EQ(log.find(std::string(200, 'y')), std::string::npos) << "cut to the metadata limit";
}

TEST(Daemon, TheLogLineNamesTheSessionTheClientSends) {
  auto stub = squall::v1::Server::NewStub(client::Client({shared_daemon().address(), 10, ""}).channel());
  grpc::ClientContext context;
  context.AddMetadata("x-request-id", "log-test-43");
  context.AddMetadata("x-squall-session", "0123abcd");
  squall::v1::GetInfoResponse reply;
  ASSERT_TRUE(stub->GetInfo(&context, squall::v1::GetInfoRequest(), &reply).ok());
  std::string log;
  for (int i = 0; i < 50 && log.find("log-test-43") == std::string::npos; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    log = shared_daemon().process().log();
  }
  EXPECT_NE(log.find("request id=log-test-43 method=/squall.v1.Server/GetInfo status=OK"), std::string::npos) << log;
  EXPECT_NE(log.find("session=0123abcd"), std::string::npos) << log;
}

// A reflection stream over a raw bidi call, with the request encoded by hand
// (ServerReflectionRequest{list_services: ""} is field 7, empty: bytes 0x3a 0x00). It stays open, holding
// the server's thread, until close().
class ReflectionStream {
 public:
  explicit ReflectionStream(const std::string& address) : client_({address, 10, ""}), generic_(client_.channel()) {
    ctx_.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
    call_ = generic_.PrepareCall(&ctx_, "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo", &cq_);
    call_->StartCall(tag(1));
    started_ = step(1);
  }
  ~ReflectionStream() { close(); }

  // The reply to list_services: "" where the stream failed.
  std::string list_services() {
    if (!started_) return "";
    const char request[] = {0x3a, 0x00};
    grpc::Slice slice(request, sizeof request);
    call_->Write(grpc::ByteBuffer(&slice, 1), tag(2));
    if (!step(2)) return "";
    grpc::ByteBuffer reply;
    call_->Read(&reply, tag(3));
    if (!step(3)) return "";
    std::vector<grpc::Slice> slices;
    reply.Dump(&slices);
    std::string bytes;
    for (const auto& sl : slices) bytes.append(reinterpret_cast<const char*>(sl.begin()), sl.size());
    return bytes;
  }

  void close() {
    if (!call_) return;
    call_->WritesDone(tag(4));
    step(4);
    grpc::Status status;
    call_->Finish(&status, tag(5));
    step(5);
    call_.reset();
    cq_.Shutdown();
    void* ignored;
    bool ok;
    while (cq_.Next(&ignored, &ok)) {
    }
  }

 private:
  static void* tag(intptr_t id) { return reinterpret_cast<void*>(id); }
  bool step(intptr_t id) {
    void* got;
    bool ok = false;
    return cq_.Next(&got, &ok) && got == tag(id) && ok;
  }

  client::Client client_;
  grpc::GenericStub generic_;  // calls by method name, the messages as bytes
  grpc::CompletionQueue cq_;
  grpc::ClientContext ctx_;
  std::unique_ptr<grpc::GenericClientAsyncReaderWriter> call_;
  bool started_ = false;
};

std::string reflection_list_services(const std::string& address) { return ReflectionStream(address).list_services(); }

TEST(Daemon, ReflectionListsTheServices) {
  std::string listed = reflection_list_services(shared_daemon().address());
  EXPECT_NE(listed.find("squall.v1.Server"), std::string::npos) << listed;
  EXPECT_NE(listed.find("grpc.health.v1.Health"), std::string::npos) << listed;
}

TEST(Daemon, ReflectionCanBeTurnedOff) {
  Daemon d({"--fft", "vkfft", "--reflection", "off"});
  EXPECT_EQ(reflection_list_services(d.address()).find("squall.v1.Server"), std::string::npos);
  client::Client c({d.address(), 10, ""});
  EXPECT_EQ(c.health(), grpc::health::v1::HealthCheckResponse::SERVING);
}

// Idle reflection streams each hold a server thread; past 16 (ReflectionLimitFactory::kMaxStreams) new ones
// are cancelled, so however many a client opens, the threads left for health checks and calls remain.
TEST(Daemon, IdleReflectionStreamsPastTheirLimitAreCancelledAndCallsGoOn) {
  Daemon d({"--fft", "vkfft", "--max-calls", "1", "--max-streams", "1", "--rpc-threads", "1"});
  std::vector<std::unique_ptr<ReflectionStream>> streams;
  int answered = 0;
  for (int i = 0; i < 200; ++i) {  // past the whole thread quota of this daemon (1 + 1 + 1 + 64 + 16 + 64)
    streams.push_back(std::make_unique<ReflectionStream>(d.address()));
    if (streams.back()->list_services().find("squall.v1.Server") != std::string::npos) ++answered;
  }
  EXPECT_EQ(answered, 16);
  client::Client c({d.address(), 10, ""});
  EXPECT_EQ(c.health(), grpc::health::v1::HealthCheckResponse::SERVING);
  EXPECT_TRUE(c.info().ready());
  EXPECT_NE(d.process().log().find("status=RESOURCE_EXHAUSTED"), std::string::npos);
  EXPECT_NE(d.process().log().find("error=\"reflection: 16 streams open, the most squalld serves at once\""),
            std::string::npos)
      << "the request log records each refusal";
  streams.clear();  // the places come back as the streams end
  EXPECT_NE(reflection_list_services(d.address()).find("squall.v1.Server"), std::string::npos);
}

// A CA, and a server (SAN IP 127.0.0.1) and a client certificate it signed, made by openssl (P-256 keys).
struct Certificates {
  std::string dir = test::temp_dir("tls");
  std::string ca = dir + "/ca.pem", server = dir + "/server.pem", server_key = dir + "/server.key";
  std::string client = dir + "/client.pem", client_key = dir + "/client.key";
  std::string stranger = dir + "/stranger.pem", stranger_key = dir + "/stranger.key";  // self-signed, not by ca

  Certificates() {
    std::string out;
    auto openssl = [&](std::vector<std::string> argv) {
      argv.insert(argv.begin(), "/usr/bin/openssl");  // Debian's openssl (deploy/install-deps.sh)
      ASSERT_EQ(test::run(argv, &out), 0) << out;
    };
    const std::vector<std::string> key = {"-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes"};
    auto with_key = [&](std::vector<std::string> argv) {
      argv.insert(argv.end(), key.begin(), key.end());
      openssl(argv);
    };
    with_key({"req", "-x509", "-keyout", dir + "/ca.key", "-out", ca, "-days", "1", "-subj", "/CN=squall test CA"});
    with_key({"req", "-x509", "-keyout", stranger_key, "-out", stranger, "-days", "1", "-subj", "/CN=stranger"});
    std::ofstream(dir + "/server.ext") << "subjectAltName=IP:127.0.0.1\n";
    for (auto [name, pem, subject] :
         {std::tuple{"server", server, "/CN=127.0.0.1"}, std::tuple{"client", client, "/CN=squall test client"}}) {
      std::string csr = dir + "/" + name + ".csr";
      with_key({"req", "-keyout", dir + "/" + name + ".key", "-out", csr, "-subj", subject});
      std::vector<std::string> sign = {
          "x509", "-req", "-in",   csr, "-CA", ca, "-CAkey", dir + "/ca.key", "-CAcreateserial",
          "-out", pem,    "-days", "1"};
      if (std::string(name) == "server") sign.insert(sign.end(), {"-extfile", dir + "/server.ext"});
      openssl(sign);
    }
  }
};

// --tls-cert / --tls-key: the CLI gets in with --tls-ca, and a plaintext client does not.
TEST(Tls, TheCliTalksTlsToADaemonThatServesIt) {
  Certificates c;
  client::ClientOptions probe;
  probe.tls_ca = c.ca;
  Daemon d({"--fft", "vkfft", "--tls-cert", c.server, "--tls-key", c.server_key}, 600, probe);
  std::string out;
  EXPECT_EQ(test::run({kSquall, "--address", d.address(), "--tls-ca", c.ca, "info"}, &out), 0) << out;
  EXPECT_NE(out.find("runtime/selftest.cl"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSquall, "--address", d.address(), "--timeout", "5", "info"}, &out), 3) << out;
  EXPECT_NE(d.process().log().find("(port " + d.address().substr(10) + ", TLS)"), std::string::npos);
}

// --tls-client-ca: only a client with a certificate that CA signed gets in.
TEST(Tls, MutualTlsRequiresTheClientsCertificate) {
  Certificates c;
  client::ClientOptions probe;
  probe.tls_ca = c.ca, probe.tls_cert = c.client, probe.tls_key = c.client_key;
  Daemon d({"--fft", "vkfft", "--tls-cert", c.server, "--tls-key", c.server_key, "--tls-client-ca", c.ca}, 600, probe);
  std::string out;
  EXPECT_EQ(test::run({kSquall, "--address", d.address(), "--tls-ca", c.ca, "--tls-cert", c.client, "--tls-key",
                       c.client_key, "health"},
                      &out),
            0)
      << out;
  EXPECT_EQ(test::run({kSquall, "--address", d.address(), "--timeout", "5", "--tls-ca", c.ca, "health"}, &out), 3)
      << out;
  // a certificate that the CA did not sign is refused too
  EXPECT_EQ(test::run({kSquall, "--address", d.address(), "--timeout", "5", "--tls-ca", c.ca, "--tls-cert", c.stranger,
                       "--tls-key", c.stranger_key, "health"},
                      &out),
            3)
      << out;
}

// An endless ocean stream of 256^2 heights (256 KiB a frame).
squall::v1::StreamTilesRequest endless_stream() {
  squall::v1::StreamTilesRequest request;
  auto* layer = request.mutable_tile()->add_layers();
  layer->set_extent_x(256);
  layer->set_extent_y(256);
  layer->set_nx(256);
  layer->set_ny(256);
  layer->set_spectrum(squall::v1::SPECTRUM_MODEL_JONSWAP);
  layer->set_spreading(squall::v1::SPREADING_MODEL_MITSUYASU);
  layer->set_dispersion(squall::v1::DISPERSION_MODEL_DEEP);
  layer->set_wind_speed(10);
  layer->set_fetch(50000);
  request.set_dt(0.1);
  request.add_outputs(squall::v1::TILE_OUTPUT_HEIGHT);
  return request;
}

// The certificate files are re-read (--tls-refresh): after they are replaced by a certificate from
// another CA, new connections get the new one, without a restart, and a stream opened before goes on.
TEST(Tls, ARenewedCertificateIsServedWithoutARestart) {
  Certificates first, second;
  client::ClientOptions probe;
  probe.tls_ca = first.ca;
  Daemon d({"--fft", "vkfft", "--tls-cert", first.server, "--tls-key", first.server_key, "--tls-refresh", "1"}, 600,
           probe);
  std::string out;
  EXPECT_EQ(test::run({kSquall, "--address", d.address(), "--tls-ca", first.ca, "health"}, &out), 0) << out;
  client::ClientOptions streaming = probe;
  streaming.address = d.address();
  streaming.timeout_seconds = 600;  // the stream outlives the renewal
  client::Client live(streaming);
  auto ocean = squall::v1::Ocean::NewStub(live.channel());
  auto context = live.context();
  auto stream = ocean->StreamTiles(context.get(), endless_stream());
  squall::v1::TileChunk chunk;
  ASSERT_TRUE(stream->Read(&chunk)) << "a frame before the renewal";
  std::filesystem::copy_file(second.server_key, first.server_key, std::filesystem::copy_options::overwrite_existing);
  std::filesystem::copy_file(second.server, first.server, std::filesystem::copy_options::overwrite_existing);
  int code = -1;
  for (int i = 0; i < 50 && code != 0; ++i) {  // the watcher looks every second
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    code = test::run({kSquall, "--address", d.address(), "--timeout", "5", "--tls-ca", second.ca, "health"}, &out);
  }
  EXPECT_EQ(code, 0) << out;
  EXPECT_EQ(test::run({kSquall, "--address", d.address(), "--timeout", "5", "--tls-ca", first.ca, "health"}, &out), 3)
      << out;
  // 10 MiB: more than the transport holds in flight, so most of these frames were sent after the renewal
  for (int frame = 0; frame < 40; ++frame) ASSERT_TRUE(stream->Read(&chunk)) << "frame " << frame << " after it";
  context->TryCancel();
  while (stream->Read(&chunk)) {
  }
  EXPECT_EQ(stream->Finish().error_code(), grpc::StatusCode::CANCELLED);
}

TEST(Tls, BadTlsFlagsExitTwo) {
  std::string out;
  EXPECT_EQ(test::run({kSqualld, "--listen", "127.0.0.1:0", "--tls-cert", "/nonexistent.pem"}, &out), 2) << out;
  EXPECT_NE(out.find("--tls-cert and --tls-key go together"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSqualld, "--listen", "127.0.0.1:0", "--tls-cert", "/nonexistent.pem", "--tls-key",
                       "/nonexistent.key"},
                      &out),
            2)
      << out;
  EXPECT_NE(out.find("--tls-key /nonexistent.key"), std::string::npos) << out;
}

// --auth-tokens: every squall call needs "authorization: Bearer <token>" with a token of the file;
// health stays open (balancers probe it), and reflection turns off with auto.
// --auth-exempt-health off: health checks need a token too (Check and Watch), for a balancer that sends one.
TEST(Auth, HealthNeedsTheTokenWhenNotExempt) {
  std::string dir = test::temp_dir("auth-health");
  std::ofstream(dir + "/tokens") << "s3cret-bob bob\n";
  std::ofstream(dir + "/bob") << "s3cret-bob\n";
  client::ClientOptions probe;
  probe.token = "s3cret-bob";
  Daemon d({"--fft", "vkfft", "--auth-tokens", dir + "/tokens", "--auth-exempt-health", "off"}, 600, probe);
  std::string out;
  EXPECT_EQ(test::run({kSquall, "--address", d.address(), "--token-file", dir + "/bob", "health"}, &out), 0) << out;
  EXPECT_NE(test::run({kSquall, "--address", d.address(), "health"}, &out), 0) << out;
  EXPECT_NE(out.find("UNAUTHENTICATED"), std::string::npos) << out;
  client::Client without_token({d.address(), 10});
  auto health = grpc::health::v1::Health::NewStub(without_token.channel());
  auto context = without_token.context();
  auto watch = health->Watch(context.get(), grpc::health::v1::HealthCheckRequest());
  grpc::health::v1::HealthCheckResponse update;
  EXPECT_FALSE(watch->Read(&update));
  EXPECT_EQ(watch->Finish().error_code(), grpc::StatusCode::UNAUTHENTICATED);
}

TEST(Client, LoopbackAddressesAreThoseOfThisMachineOnly) {
  for (const char* address :
       {"127.0.0.1:50051", "127.8.9.10:1", "localhost:50051", "[::1]:50051", "ipv4:127.0.0.1:1", "ipv6:[::1]:1",
        "dns:///localhost:1", "unix:/run/squalld.sock", "ipv4:127.0.0.1:1,127.0.0.2:1"})
    EXPECT_TRUE(client::is_loopback_address(address)) << address;
  for (const char* address :
       {"192.0.2.1:50051", "0.0.0.0:1", "squalld.example:50051", "[2001:db8::1]:1", "dns:///squalld.example:1",
        "128.0.0.1:1", "[::ffff:192.0.2.1]:1", "ipv6:[::1]:1,[2001:db8::1]:1", "[::1"})
    EXPECT_FALSE(client::is_loopback_address(address)) << address;
}

TEST(Auth, BearerTokensAreRequiredAndHealthStaysOpen) {
  std::string dir = test::temp_dir("auth");
  std::ofstream(dir + "/tokens") << "# squalld tokens\n\ns3cret-alice alice\nother-token\n";
  std::ofstream(dir + "/alice") << "s3cret-alice\n";
  std::ofstream(dir + "/wrong") << "s3cret-alicf\n";
  Daemon d({"--fft", "vkfft", "--auth-tokens", dir + "/tokens"});
  std::string out;
  EXPECT_EQ(test::run({kSquall, "--address", d.address(), "--token-file", dir + "/alice", "info"}, &out), 0) << out;
  EXPECT_EQ(out.find("in plaintext"), std::string::npos) << "a token to loopback is no warning: " << out;
  // 0.0.0.0 reaches this machine too, but names no loopback address: the CLI warns, and goes on.
  const std::string any = "0.0.0.0:" + d.address().substr(d.address().rfind(':') + 1);
  EXPECT_EQ(test::run({kSquall, "--address", any, "--token-file", dir + "/alice", "info"}, &out), 0) << out;
  EXPECT_NE(out.find("squall: warning: the bearer token goes to " + any + " in plaintext"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSquall, "--address", d.address(), "info"}, &out), 4) << out;
  EXPECT_NE(out.find("UNAUTHENTICATED: a valid bearer token is required"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSquall, "--address", d.address(), "--token-file", dir + "/wrong", "info"}, &out), 4) << out;
  EXPECT_EQ(test::run({kSquall, "--address", d.address(), "health"}, &out), 0) << out;
  EXPECT_EQ(reflection_list_services(d.address()).find("squall.v1.Server"), std::string::npos);

  client::ClientOptions options{d.address(), 10, ""};
  auto stub = squall::v1::Ocean::NewStub(client::Client(options).channel());  // a stream, without a token
  grpc::ClientContext context;
  squall::v1::StreamTilesRequest request;
  auto reader = stub->StreamTiles(&context, request);
  squall::v1::TileChunk chunk;
  while (reader->Read(&chunk)) {
  }
  EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::UNAUTHENTICATED);

  // The scheme's case does not matter (RFC 7235 sec. 2.1); the token's does.
  auto server = squall::v1::Server::NewStub(client::Client(options).channel());
  for (const char* header : {"bearer s3cret-alice", "BEARER s3cret-alice", "Bearer S3CRET-alice"}) {
    grpc::ClientContext call;
    call.AddMetadata("authorization", header);
    squall::v1::GetInfoResponse info;
    const bool same_token = std::string(header).ends_with("s3cret-alice");
    EXPECT_EQ(server->GetInfo(&call, squall::v1::GetInfoRequest(), &info).ok(), same_token) << header;
  }
}

// SIGHUP re-reads --auth-tokens: a token taken out is refused from then on, a new one accepted; a file
// that cannot be read leaves the tokens in force.
TEST(Auth, SighupReloadsTheTokens) {
  std::string dir = test::temp_dir("auth-reload");
  std::ofstream(dir + "/tokens") << "old-token\n";
  std::ofstream(dir + "/old") << "old-token\n";
  std::ofstream(dir + "/new") << "new-token\n";
  Daemon d({"--fft", "vkfft", "--auth-tokens", dir + "/tokens"});
  auto info_with = [&](const std::string& token_file) {
    std::string out;
    return test::run({kSquall, "--address", d.address(), "--token-file", dir + "/" + token_file, "info"}, &out);
  };
  auto count = [&](const std::string& text) {  // occurrences of `text` in the daemon's log
    std::string log = d.process().log();
    size_t n = 0;
    for (size_t at = log.find(text); at != std::string::npos; at = log.find(text, at + 1)) ++n;
    return n;
  };
  auto reload = [&](const std::string& logged) {  // SIGHUP, then wait until the log says it once more
    const size_t before = count(logged);
    d.process().signal(SIGHUP);
    for (int i = 0; i < 200 && count(logged) == before; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    ASSERT_GT(count(logged), before) << d.process().log();
  };
  ASSERT_EQ(info_with("old"), 0);
  ASSERT_EQ(info_with("new"), 4);
  std::ofstream(dir + "/tokens") << "new-token\n";
  reload("bearer tokens from");
  EXPECT_EQ(info_with("new"), 0);
  EXPECT_EQ(info_with("old"), 4) << "a token taken out of the file is refused after SIGHUP";
  std::filesystem::remove(dir + "/tokens");
  reload("the tokens in force stay");
  EXPECT_EQ(info_with("new"), 0) << "an unreadable file keeps the tokens in force";
  // A FIFO in the file's place is refused at once (its open(2) would wait for a writer, and the signals
  // with it); a file saved with a UTF-8 byte order mark keeps its first token.
  ASSERT_EQ(::mkfifo((dir + "/tokens").c_str(), 0600), 0);
  reload("not a regular file; the tokens in force stay");
  EXPECT_EQ(info_with("new"), 0);
  std::filesystem::remove(dir + "/tokens");
  std::ofstream(dir + "/tokens") << "\xEF\xBB\xBFold-token\n";
  reload("bearer tokens from");
  EXPECT_EQ(info_with("old"), 0) << "the byte order mark is no part of the token";
  EXPECT_TRUE(d.running());
}

TEST(Cli, InfoAndHealthExitZero) {
  std::string out;
  EXPECT_EQ(test::run({kSquall, "--address", shared_daemon().address(), "info"}, &out), 0) << out;
  EXPECT_NE(out.find("runtime/selftest.cl"), std::string::npos) << out;
  EXPECT_NE(out.find("max_sessions=7"), std::string::npos) << out;
  EXPECT_NE(out.find("stream_idle_timeout_seconds=600"), std::string::npos) << out;
  EXPECT_NE(out.find("\nreplica: "), std::string::npos) << out;  // the name x-squall-replica carries
  EXPECT_EQ(test::run({kSquall, "--address", shared_daemon().address(), "health"}, &out), 0) << out;
  EXPECT_EQ(out, "SERVING\n");
}

TEST(Cli, ExitCodesSayWhatWentWrong) {
  std::string out;
  // Nothing listens on port 1.
  EXPECT_EQ(test::run({kSquall, "--address", "127.0.0.1:1", "--timeout", "2", "info"}, &out), 3) << out;
  EXPECT_NE(out.find("UNAVAILABLE"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSquall, "frobnicate"}, &out), 2) << out;
  EXPECT_NE(out.find("unknown verb frobnicate"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSquall, "--timeout", "-1", "info"}, &out), 2) << out;
  // gRPC aborts the process on a metadata value that is not printable ASCII: refused first, naming it.
  EXPECT_EQ(test::run({kSquall, "--request-id", "caf\xc3\xa9", "info"}, &out), 2) << out;
  EXPECT_NE(out.find("--request-id holds the byte \\xc3"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSquall, "--request-id", "a\nb", "info"}, &out), 2) << out;
  EXPECT_NE(out.find("--request-id holds the byte \\x0a"), std::string::npos) << out;
  // A request id past GetInfo.request_id's 128 bytes goes as x-request-id only, as on every other call.
  EXPECT_EQ(
      test::run({kSquall, "--address", shared_daemon().address(), "--request-id", std::string(300, 'r'), "info"}, &out),
      0)
      << out;
  // Files named by flags that cannot be read (missing, a folder): a bad command line, whichever flag names
  // them; so are a certificate without its key, an empty address, and arguments info and health do not take.
  for (const char* flag : {"--token-file", "--tls-ca", "--tls-cert", "--tls-key"}) {
    EXPECT_EQ(test::run({kSquall, flag, "/nonexistent.pem", "info"}, &out), 2) << flag << ": " << out;
    EXPECT_NE(out.find(std::string(flag) + " /nonexistent.pem: cannot read"), std::string::npos) << out;
  }
  EXPECT_EQ(test::run({kSquall, "--tls-ca", "/tmp", "info"}, &out), 2) << out;
  EXPECT_NE(out.find("--tls-ca /tmp: cannot read"), std::string::npos) << out;
  // A FIFO, whose open(2) would wait for a writer, is refused at once like a folder.
  const std::string fifo = test::temp_dir("cli-fifo") + "/fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  for (const char* flag : {"--token-file", "--tls-ca"}) {
    EXPECT_EQ(test::run({kSquall, flag, fifo, "info"}, &out), 2) << flag << ": " << out;
    EXPECT_NE(out.find(std::string(flag) + " " + fifo + ": cannot read"), std::string::npos) << out;
  }
  EXPECT_EQ(test::run({kSquall, "ocean", "sample", "--points-file", fifo}, &out), 2) << out;
  EXPECT_NE(out.find("--points-file " + fifo + ": cannot read it"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSquall, "--tls-cert", "/proc/self/status", "info"}, &out), 2) << out;
  EXPECT_NE(out.find("--tls-cert and --tls-key go together"), std::string::npos) << out;
  // A file that is no PEM file (which gRPC would take, every call then failing as if squalld were away).
  for (const char* flag : {"--tls-ca", "--tls-cert", "--tls-key"}) {
    const std::string pem = test::temp_dir("cli-pem") + "/pem", text = "/proc/self/status";
    std::ofstream(pem) << "-----BEGIN CERTIFICATE-----\nAAAA\n-----END CERTIFICATE-----\n";
    std::vector<std::string> args = {kSquall, "--tls-ca", pem, "--tls-cert", pem, "--tls-key", pem, "info"};
    *(std::find(args.begin(), args.end(), flag) + 1) = text;
    EXPECT_EQ(test::run(args, &out), 2) << flag << ": " << out;
    EXPECT_NE(out.find(std::string(flag) + " " + text + ": no PEM block (-----BEGIN ...) in the file"),
              std::string::npos)
        << out;
  }
  EXPECT_EQ(test::run({kSquall, "--address", "", "info"}, &out), 2) << out;
  EXPECT_EQ(test::run({kSquall, "info", "--address", "127.0.0.1:2"}, &out), 2) << out;
  EXPECT_NE(out.find("--address is a flag of squall itself"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSquall, "health", "a", "b"}, &out), 2) << out;
  EXPECT_NE(out.find("unexpected b"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSquall, "ocean", "--timeout", "5", "tile"}, &out), 2) << out;
  EXPECT_NE(out.find("--timeout is a flag of squall itself"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSquall, "ocean", "tile", "help"}, &out), 0) << out;  // help below the verb too
  EXPECT_NE(out.find("usage:"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSquall, "--address", "127.0.0.1:99999", "info"}, &out), 2) << out;
  EXPECT_NE(out.find("--address 127.0.0.1:99999: the port must be in 1..65535"), std::string::npos) << out;
  // A deadline past what the clock holds is held to 1e9 s, not wrapped into one already past.
  EXPECT_EQ(test::run({kSquall, "--address", shared_daemon().address(), "--timeout", "1e300", "health"}, &out), 0)
      << out;
  for (const char* target : {"[::1]:1", "dns:127.0.0.1:1", "ipv4:127.0.0.1:1"})  // dialed: nothing listens there
    EXPECT_EQ(test::run({kSquall, "--address", target, "--timeout", "1", "info"}, &out), 3) << target << ": " << out;
  // The server answers NOT_FOUND for a service it does not know: refused, not unreachable.
  EXPECT_EQ(test::run({kSquall, "--address", shared_daemon().address(), "health", "no.such.Service"}, &out), 4) << out;
}

// With a cold kernel cache the build takes minutes on PoCL; SIGINT during it ends squalld at once (exit 0),
// not after the build.
TEST(Daemon, SigintDuringTheKernelBuildExitsAtOnce) {
  const std::string dir = test::temp_dir("cold-start");
  test::Process p({kSqualld, "--listen", "127.0.0.1:0", "--fft", "vkfft", "--cache-dir", dir + "/cache"},
                  dir + "/squalld.log");
  for (int i = 0; i < 600 && p.log().find("NOT_SERVING until kernels are built") == std::string::npos; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  ASSERT_NE(p.log().find("NOT_SERVING until kernels are built"), std::string::npos) << p.log();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // into the build
  p.signal(SIGINT);
  EXPECT_EQ(p.wait(5), 0) << p.log();
  EXPECT_NE(p.log().find("while starting: exiting"), std::string::npos) << p.log();
  EXPECT_EQ(p.log().find("SERVING\n"), std::string::npos) << "it stopped before the build ended";
}

// SIGTERM: health turns NOT_SERVING for the server and each service while 'liveness' stays SERVING
// through the drain (--drain-wait), so that a liveness probe does not restart a draining replica.
TEST(Daemon, SigtermDrainsAndExitsZero) {
  Daemon d({"--fft", "auto", "--grace-period", "5", "--drain-wait", "2"});
  client::Client c({d.address(), 10, ""});
  auto info = c.info();
  EXPECT_TRUE(info.fft_backend() == "vkfft" || info.fft_backend() == "clfft" || info.fft_backend() == "fftw");
  EXPECT_NE(info.fft_selection().find("measured at start-up"), std::string::npos) << info.fft_selection();
  for (const auto& device : info.devices()) {  // a CPU device also times the fftw backend
    if (device.selected() && device.type() == "cpu") {
      EXPECT_NE(info.fft_selection().find(", fftw "), std::string::npos) << info.fft_selection();
    }
  }
  d.process().signal(SIGTERM);
  for (int i = 0; i < 100 && c.health() == grpc::health::v1::HealthCheckResponse::SERVING; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_EQ(c.health(), grpc::health::v1::HealthCheckResponse::NOT_SERVING);
  EXPECT_EQ(c.health("squall.v1.EWave"), grpc::health::v1::HealthCheckResponse::NOT_SERVING);
  EXPECT_EQ(c.health("liveness"), grpc::health::v1::HealthCheckResponse::SERVING);
  EXPECT_EQ(d.process().wait(30), 0) << d.process().log();
  std::string log = d.process().log();
  EXPECT_NE(log.find("draining"), std::string::npos) << log;
  EXPECT_NE(log.find("stopped"), std::string::npos) << log;
  EXPECT_THROW(c.info(), client::RpcError);
}

// SIGTERM while a render of minutes runs: the render is cancelled when the grace period ends and stops
// within a slice, so squalld exits 0 by --grace-period + --shutdown-bound (5 s) (it used to run until the
// render ended, and only SIGKILL stopped it).
TEST(Daemon, SigtermWithALongRenderInFlightExitsByTheGracePeriodAndBound) {
  Daemon d({"--fft", "vkfft", "--grace-period", "2", "--drain-wait", "0"});
  client::Client c({d.address(), 600, ""});
  grpc::Status rendered;
  std::thread render([&] {
    v1::RenderRequest request;
    *request.mutable_model() = test::long_work_sphere();
    *request.mutable_settings() = test::long_render_settings();
    v1::RenderResponse response;
    auto context = c.context();
    rendered = v1::Clouds::NewStub(c.channel())->Render(context.get(), request, &response);
  });
  std::this_thread::sleep_for(std::chrono::seconds(3));  // the model is built (about a second), the render runs
  const auto start = std::chrono::steady_clock::now();
  d.process().signal(SIGTERM);
  EXPECT_EQ(d.process().wait(2 + 5 + 5), 0) << d.process().log();
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 2 + 5);
  render.join();
  // Cancelled by the shutdown (or cut with the connection), never finished.
  EXPECT_TRUE(rendered.error_code() == grpc::StatusCode::CANCELLED ||
              rendered.error_code() == grpc::StatusCode::UNAVAILABLE)
      << rendered.error_code() << ": " << rendered.error_message();
}

// SIGTERM while a call is stuck where no cancellation can cut it: FFTW measuring the plan of a 4096^2 transform
// that no wisdom holds (seconds on 2 CPU cores; the layer's spectrum before it stops at its cancellation).
// The watchdog ends squalld at --grace-period + --shutdown-bound, exit code 4 (it used to wait for the job,
// or forever).
TEST(Daemon, SigtermWithAStuckCallExitsFourByTheGracePeriodAndBound) {
  std::string info;
  ASSERT_EQ(test::run({kSquall, "--address", shared_daemon().address(), "info"}, &info), 0) << info;
  if (info.find("(cpu,") == std::string::npos) GTEST_SKIP() << "--fft fftw runs on CPU devices only: " << info;
  Daemon d({"--fft", "fftw", "--fft-wisdom", "none", "--log-level", "debug", "--grace-period", "1", "--drain-wait", "0",
            "--shutdown-bound", "1"});
  std::atomic<bool> sampled{false};
  int sample_code = -1;
  std::string sample_out;
  std::thread sample([&] {
    sample_code = test::run({kSquall, "--address", d.address(), "--timeout", "120", "ocean", "sample", "--grid", "4096",
                             "--seed", "77", "--point", "1,2"},
                            &sample_out, 120);
    sampled = true;
  });
  const auto planning = [&] { return d.process().log().find("fftw: planning 4096x4096") != std::string::npos; };
  for (int i = 0; i < 600 && !sampled && !planning(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // into the planner
  if (sampled) {
    sample.join();
    ASSERT_EQ(sample_code, 0) << "the call ended before SIGTERM, but not with its sample: " << sample_out;
    GTEST_SKIP() << "this machine planned the 4096^2 transform at once: no call stays stuck long enough";
  }
  ASSERT_TRUE(planning()) << d.process().log();
  const auto start = std::chrono::steady_clock::now();
  d.process().signal(SIGTERM);
  EXPECT_EQ(d.process().wait(30), 4) << "exit code 4: the drain overran" << d.process().log();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_LT(seconds, 1 + 1 + 1.5) << "the watchdog fires at grace + bound";
  EXPECT_NE(d.process().log().find("after the grace period ended: exiting without it"), std::string::npos)
      << d.process().log();
  sample.join();
}

TEST(Daemon, ProfileModeLogsTheDeviceTimeOfEachKernelAtShutdown) {
  Daemon d({"--fft", "vkfft", "--profile-kernels", "on"});
  std::string out;
  ASSERT_EQ(test::run({kSquall, "--address", d.address(), "ocean", "sample", "--grid", "32", "--point", "1,2"}, &out),
            0)
      << out;
  d.process().signal(SIGTERM);
  EXPECT_EQ(d.process().wait(30), 0) << d.process().log();
  std::string log = d.process().log();
  const size_t table = log.find("device time per kernel");
  ASSERT_NE(table, std::string::npos) << log;
  EXPECT_NE(log.find("ocean_", table), std::string::npos) << "the ocean kernels the call ran are listed: " << log;
  std::string refused;
  EXPECT_EQ(test::run({test::squalld_path(), "--profile-kernels", "maybe"}, &refused), 2) << refused;
  EXPECT_NE(refused.find("--profile-kernels maybe: must be on or off"), std::string::npos) << refused;
}

// --fft-wisdom: the plans a call's transforms measured are in that directory when it returns, and the
// next daemon on it loads them (and says so; a file FFTW cannot read would be logged as ignored).
TEST(Daemon, FftwWisdomIsKeptInTheFftWisdomDirectoryForTheNextStart) {
  std::string info;
  ASSERT_EQ(test::run({kSquall, "--address", shared_daemon().address(), "info"}, &info), 0) << info;
  if (info.find("(cpu,") == std::string::npos) GTEST_SKIP() << "--fft fftw runs on CPU devices only: " << info;
  const std::filesystem::path dir = std::filesystem::path(testing::TempDir()) / "squall-daemon-wisdom";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  auto sample = [&](int round) {
    Daemon d({"--fft", "fftw", "--fft-wisdom", dir.string()});
    std::string out;
    EXPECT_EQ(test::run({kSquall, "--address", d.address(), "ocean", "sample", "--grid", "44", "--point", "1,2"}, &out),
              0)
        << out;
    d.process().signal(SIGTERM);
    EXPECT_EQ(d.process().wait(30), 0) << d.process().log();
    const std::string log = d.process().log();
    EXPECT_EQ(log.find("ignored the wisdom"), std::string::npos) << "round " << round << ": " << log;
    EXPECT_EQ(log.find("cannot write wisdom"), std::string::npos) << "round " << round << ": " << log;
    EXPECT_EQ(log.find("fftw: loaded the wisdom in " + dir.string()) != std::string::npos, round == 2)
        << "round " << round << ": " << log;
  };
  sample(1);
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    if (entry.file_size() > 0) files.push_back(entry.path().filename().string());
  ASSERT_EQ(files.size(), 1u) << "one file of single-precision wisdom";
  EXPECT_EQ(files[0].rfind("fftw-wisdom-", 0), 0u) << files[0];
  EXPECT_EQ(files[0].substr(files[0].size() - 4), ".f32") << files[0];
  sample(2);
  std::filesystem::remove_all(dir);
}

TEST(Daemon, DrainingTurnsNotServingForWatchersAndEndsTheirStreams) {
  Daemon d({"--fft", "vkfft", "--grace-period", "2"});
  auto stub = grpc::health::v1::Health::NewStub(client::Client({d.address(), 60, ""}).channel());
  grpc::ClientContext ctx;
  auto watch = stub->Watch(&ctx, grpc::health::v1::HealthCheckRequest());
  grpc::health::v1::HealthCheckResponse update;
  ASSERT_TRUE(watch->Read(&update));
  EXPECT_EQ(update.status(), grpc::health::v1::HealthCheckResponse::SERVING);
  auto start = std::chrono::steady_clock::now();
  d.process().signal(SIGTERM);
  ASSERT_TRUE(watch->Read(&update));
  EXPECT_EQ(update.status(), grpc::health::v1::HealthCheckResponse::NOT_SERVING);
  while (watch->Read(&update)) {  // the server ends it after the drain wait, min(--drain-wait 2, grace / 2) = 1 s
  }
  const double ended = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const grpc::Status finished = watch->Finish();  // CANCELLED if the grace period's end had cut it
  EXPECT_TRUE(finished.ok()) << finished.error_code() << ": " << finished.error_message();
  EXPECT_LT(ended, 1.9) << "the watch ended at the end of the grace period, not after the drain wait";
  EXPECT_EQ(d.process().wait(30), 0) << d.process().log();
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_LT(seconds, 2 + 5) << "shutdown took longer than --grace-period allows";
}

TEST(Daemon, SigintAlsoStopsCleanly) {
  Daemon d({"--fft", "clfft"});
  d.process().signal(SIGINT);
  EXPECT_EQ(d.process().wait(30), 0) << d.process().log();
}

// --cpu-buffers device makes a CPU device's buffers as a GPU's are, read and written by commands, where by
// default the device computes in their host memory; the start-up log says which.
TEST(Daemon, TheLogSaysWhetherTheDeviceComputesInHostMemory) {
  Daemon d({"--fft", "vkfft", "--cpu-buffers", "device"});
  EXPECT_NE(d.process().log().find("buffers: read and written by commands"), std::string::npos) << d.process().log();
  const std::string log = shared_daemon().process().log();
  if (log.find("(cpu)") != std::string::npos && test::host_buffers_on_cpu()) {
    EXPECT_NE(log.find("buffers: the device computes in their host memory"), std::string::npos) << log;
  }
}

TEST(Daemon, BrokenKernelPrintsBuildLogAndExitsNonZero) {
  std::string dir = test::temp_dir("broken-kernels");
  std::filesystem::create_directories(dir + "/runtime");
  std::ofstream(dir + "/runtime/selftest.cl") << "__kernel void k(__global float* o) { o[0] = not_declared; }\n";
  std::string out;
  EXPECT_EQ(test::run({kSqualld, "--listen", "127.0.0.1:0", "--kernel-dir", dir}, &out, 120), 1) << out;
  EXPECT_NE(out.find("runtime/selftest.cl failed to build"), std::string::npos) << out;
  EXPECT_NE(out.find("not_declared"), std::string::npos) << out;
}

TEST(Daemon, BadFlagsAndUnknownDeviceExitTwo) {
  std::string out;
  EXPECT_EQ(test::run({kSqualld, "--max-streams", "0"}, &out), 2) << out;
  EXPECT_NE(out.find("--max-streams 0: must be an integer >= 1"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSqualld, "--rpc-threads", "1025"}, &out), 2) << out;
  EXPECT_NE(out.find("--rpc-threads 1025: must be 1 to 1024"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSqualld, "--max-calls", "16385"}, &out), 2) << out;  // each running call holds a thread
  EXPECT_NE(out.find("--max-calls 16385: must be 1 to 16384"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSqualld, "--max-calls", "0"}, &out), 2) << out;
  EXPECT_EQ(test::run({kSqualld, "--no-such-flag", "1"}, &out), 2) << out;
  EXPECT_EQ(test::run({kSqualld, "--cpu-buffers", "pinned"}, &out), 2) << out;
  EXPECT_NE(out.find("--cpu-buffers pinned: must be host or device"), std::string::npos) << out;
  // The sample budgets take the exponent notation their --help defaults are written in, and whole numbers only.
  EXPECT_EQ(test::run({kSqualld, "--max-render-samples", "4e11", "--max-advection-samples", "1e9", "--max-bake-work",
                       "1e12", "--help"},
                      &out),
            0)
      << out;
  EXPECT_EQ(test::run({kSqualld, "--max-render-samples", "1.5"}, &out), 2) << out;
  EXPECT_NE(out.find("--max-render-samples 1.5: must be a whole number >= 1"), std::string::npos) << out;
  // Durations within 1e9 s: a deadline that far ahead still fits the clocks.
  for (const char* flag : {"--grace-period", "--session-ttl", "--checkpoint-interval", "--drain-wait"}) {
    EXPECT_EQ(test::run({kSqualld, flag, "1e10"}, &out), 2) << out;
    EXPECT_NE(out.find(std::string(flag) + " 1e10: must be a number of seconds in "), std::string::npos) << out;
  }
  EXPECT_EQ(test::run({kSqualld, "--keepalive", "2e6"}, &out), 2) << out;  // its milliseconds are an int
  EXPECT_NE(out.find("--keepalive 2e6: must be a number of seconds in [0.1, 1000000]"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSqualld, "--keepalive", "1e-4"}, &out), 2) << out;
  // A stream's idle timeout: none (0), or long enough for the watch that looks four times per timeout.
  EXPECT_EQ(test::run({kSqualld, "--stream-idle-timeout", "1e-9"}, &out), 2) << out;
  EXPECT_NE(out.find("--stream-idle-timeout 1e-9: must be 0 (no limit) or a number of seconds in [0.1, 1e+09]"),
            std::string::npos)
      << out;
  EXPECT_EQ(test::run({kSqualld, "--stream-idle-timeout", "0", "--help"}, &out), 0) << out;
  // Numbers as the flags are written: no hex, no empty text, and a message rather than the parser's name.
  for (const char* bad : {"0x10", "", "inf", "1e5x"}) {
    EXPECT_EQ(test::run({kSqualld, "--stream-idle-timeout", bad}, &out), 2) << out;
    EXPECT_NE(out.find("--stream-idle-timeout " + std::string(bad) + ": must be a number of seconds in [0, 1e+09]"),
              std::string::npos)
        << out;
  }
  // Grids past 2^26 cells would overflow the kernels' 32-bit indices into a buffer of their planes.
  EXPECT_EQ(test::run({kSqualld, "--max-grid-cells", "67108865"}, &out), 2) << out;
  EXPECT_NE(out.find("--max-grid-cells 67108865: must be 1 to 67108864"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSqualld, "--max-grid-cells", "67108864", "--help"}, &out), 0) << out;
  // Counts are 32-bit and gRPC's messages at most 2^31 - 1 bytes: larger values are refused, not wrapped.
  EXPECT_EQ(test::run({kSqualld, "--max-streams", "4294967296"}, &out), 2) << out;
  EXPECT_NE(out.find("--max-streams 4294967296: must be 1 to 4294967295"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSqualld, "--max-sessions", "4294967296"}, &out), 2) << out;
  EXPECT_EQ(test::run({kSqualld, "--tls-refresh", "100000"}, &out), 2) << out;  // refused, not cut to a day
  EXPECT_NE(out.find("--tls-refresh 100000: must be 1 to 86400"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSqualld, "--max-message-bytes", "3000000000"}, &out), 2) << out;
  EXPECT_NE(out.find("--max-message-bytes 3000000000: must be 1 to 2147483647 (gRPC's largest message)"),
            std::string::npos)
      << out;
  EXPECT_EQ(test::run({kSqualld, "--max-streams", ""}, &out), 2) << out;
  EXPECT_NE(out.find("--max-streams : must be an integer >= 1"), std::string::npos) << out;
  // The replica id is every reply's metadata value: printable ASCII only.
  EXPECT_EQ(test::run({kSqualld, "--replica-id", "r\xc3\xa9plica"}, &out), 2) << out;
  EXPECT_NE(out.find("must be printable ASCII, with no spaces"), std::string::npos) << out;
  EXPECT_EQ(test::run({kSqualld, "--listen", "127.0.0.1:0", "--device", "no-such-device"}, &out), 2) << out;
  EXPECT_NE(out.find("--device no-such-device matches no OpenCL device"), std::string::npos) << out;
  // a non-loopback address without TLS or tokens is refused before anything listens
  EXPECT_EQ(test::run({kSqualld, "--listen", "0.0.0.0:0"}, &out), 2) << out;
  EXPECT_NE(out.find("--listen 0.0.0.0:0 is not a loopback address"), std::string::npos) << out;
  // reflection would answer without a token
  EXPECT_EQ(test::run({kSqualld, "--reflection", "on", "--auth-tokens", "/dev/null"}, &out), 2) << out;
  EXPECT_NE(out.find("--reflection on with --auth-tokens"), std::string::npos) << out;
}

TEST(Daemon, BusyPortExitsThree) {
  std::string out;
  std::string busy = shared_daemon().address();
  EXPECT_EQ(test::run({kSqualld, "--listen", busy, "--fft", "vkfft"}, &out, 120), 3) << out;
}

}  // namespace
}  // namespace squall
