// The C++ clients of bench/load_bench.py: `--clients` threads, each a squall::client::Client with its own
// TCP connection and eWave session, call in turn Ocean.GetTile, EWave.Step and Clouds.Render with the
// requests load_bench.py wrote (serialized protobuf), for `--seconds` after all of them are ready. A
// C++ client spends little CPU per call, so on a machine whose cores the clients share with squalld the
// latencies measure the server rather than the clients.
//
//   build/bench/load_client --address HOST:PORT --requests DIR --clients N --seconds S
//   DIR: tile.pb (GetTileRequest), session.pb (EWaveCreateSessionRequest), step.pb (EWaveStepRequest, its
//        session id set per client) and render.pb (RenderRequest)
//   prints, per method: "<method> <latency in us> ...", then one "error <method>: <message>" per failure
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <latch>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "bench_util.h"
#include "client/client.h"
#include "squall/v1/clouds.grpc.pb.h"
#include "squall/v1/ewave.grpc.pb.h"
#include "squall/v1/ocean.grpc.pb.h"

namespace v1 = squall::v1;

namespace {

constexpr const char* kMethods[] = {"GetTile", "Step", "Render"};

template <typename Message>
Message read_message(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  Message m;
  if (!in || !m.ParseFromString(bytes.str())) throw std::runtime_error("cannot read a request from " + path);
  return m;
}

struct Requests {
  v1::GetTileRequest tile;
  v1::EWaveCreateSessionRequest session;
  v1::EWaveStepRequest step;
  v1::RenderRequest render;
};

// One client's calls: latencies (us) per method, and its errors.
struct Record {
  std::vector<double> latencies[3];
  std::vector<std::string> errors;
};

void client(const std::string& address, const Requests& requests, double seconds, std::latch& ready, Record& record) {
  squall::client::ClientOptions options{address, 600};
  options.own_connection = true;  // as a remote client has
  squall::client::Client client(options);
  // Each service is called through its generated gRPC client class, over the connection this client owns.
  // A failed call is recorded in `record.errors` and the benchmark goes on, so check() is not used.
  auto ocean = v1::Ocean::NewStub(client.channel());
  auto ewave = v1::EWave::NewStub(client.channel());
  auto clouds = v1::Clouds::NewStub(client.channel());
  v1::EWaveSessionResponse session;
  const grpc::Status created =
      ewave->CreateSession(client.context(squall::client::propose_session_id()).get(), requests.session, &session);
  ready.arrive_and_wait();
  if (!created.ok()) {
    record.errors.push_back("CreateSession: " + created.error_message());
    return;
  }
  v1::EWaveStepRequest step = requests.step;
  step.set_session_id(session.session_id());
  v1::GetTileResponse tile;
  v1::EWaveFrame frame;
  v1::RenderResponse image;
  const std::function<grpc::Status()> calls[] = {
      [&] { return ocean->GetTile(client.context().get(), requests.tile, &tile); },
      [&] { return ewave->Step(client.context(session.session_id()).get(), step, &frame); },
      [&] { return clouds->Render(client.context().get(), requests.render, &image); },
  };
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  for (size_t n = 0; std::chrono::steady_clock::now() < deadline; ++n) {
    const size_t m = n % 3;
    const auto start = std::chrono::steady_clock::now();
    const grpc::Status status = calls[m]();
    const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count();
    if (status.ok())
      record.latencies[m].push_back(us);
    else
      record.errors.push_back(std::string(kMethods[m]) + ": " + status.error_message());
  }
  v1::EWaveSessionRequest close;
  close.set_session_id(session.session_id());
  v1::EWaveCloseResponse closed;
  const grpc::Status ended = ewave->CloseSession(client.context(session.session_id()).get(), close, &closed);
  if (!ended.ok()) record.errors.push_back("CloseSession: " + ended.error_message());
}

}  // namespace

int main(int argc, char** argv) {
  squall::bench::keep_freed_memory();  // 100 000 page faults a second at 8 clients without it
  squall::bench::skip_lock_order_checks();
  std::string address, dir;
  int clients = 1;
  double seconds = 5;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--address")) address = argv[i + 1];
    if (!std::strcmp(argv[i], "--requests")) dir = argv[i + 1];
    if (!std::strcmp(argv[i], "--clients")) clients = std::stoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--seconds")) seconds = std::stod(argv[i + 1]);
  }
  if (address.empty() || dir.empty() || clients < 1 || !(seconds > 0)) {
    std::fprintf(stderr, "usage: load_client --address HOST:PORT --requests DIR --clients N --seconds S\n");
    return 2;
  }
  try {
    const Requests requests{read_message<v1::GetTileRequest>(dir + "/tile.pb"),
                            read_message<v1::EWaveCreateSessionRequest>(dir + "/session.pb"),
                            read_message<v1::EWaveStepRequest>(dir + "/step.pb"),
                            read_message<v1::RenderRequest>(dir + "/render.pb")};
    std::vector<Record> records(static_cast<size_t>(clients));
    std::latch ready(clients);
    std::vector<std::thread> threads;
    for (auto& record : records)
      threads.emplace_back(client, address, std::cref(requests), seconds, std::ref(ready), std::ref(record));
    for (auto& t : threads) t.join();
    for (size_t m = 0; m < 3; ++m) {
      std::printf("%s", kMethods[m]);
      for (const auto& record : records)
        for (double us : record.latencies[m]) std::printf(" %.1f", us);
      std::printf("\n");
    }
    for (const auto& record : records)
      for (const auto& e : record.errors) std::printf("error %s\n", e.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "load_client: %s\n", e.what());
    return 1;
  }
  return 0;
}
