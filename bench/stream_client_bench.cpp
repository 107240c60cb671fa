// StreamTiles frames per second as the C++ client receives them from a running squalld: one call of
// `frames` frames, timed from the call to the last frame reassembled (FrameAssembler) and decoded to
// floats, after a one-frame warm-up call. bench/python_client_bench.py runs it beside the Python
// client against the same daemon and prints the ratio.
//
//   build/bench/stream_client_bench --address HOST:PORT [--n 512] [--frames 40] [--fields 9|1]
//   prints: frames_per_second <rate>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>

#include "bench_util.h"
#include "client/client.h"
#include "client/ocean_frames.h"

namespace v1 = squall::v1;

namespace {

// One JONSWAP layer of 1 km with n x n cells, choppy (as bench/ocean_bench.cpp and the Python bench).
v1::StreamTilesRequest request(int n, int frames, int fields) {
  v1::StreamTilesRequest r;
  auto* l = r.mutable_tile()->add_layers();
  l->set_extent_x(1000), l->set_extent_y(1000), l->set_nx(n), l->set_ny(n);
  l->set_spectrum(v1::SPECTRUM_MODEL_JONSWAP), l->set_spreading(v1::SPREADING_MODEL_MITSUYASU);
  l->set_dispersion(v1::DISPERSION_MODEL_DEEP), l->set_wind_speed(12), l->set_fetch(100000), l->set_seed(1);
  r.mutable_tile()->set_choppiness(1);
  r.set_dt(1.0 / 30);
  r.set_frame_count(uint32_t(frames));
  const v1::TileOutput all[] = {
      v1::TILE_OUTPUT_HEIGHT,   v1::TILE_OUTPUT_DISPLACEMENT_X, v1::TILE_OUTPUT_DISPLACEMENT_Y,
      v1::TILE_OUTPUT_NORMAL_X, v1::TILE_OUTPUT_NORMAL_Y,       v1::TILE_OUTPUT_NORMAL_Z,
      v1::TILE_OUTPUT_JACOBIAN, v1::TILE_OUTPUT_JACOBIAN_MINUS, v1::TILE_OUTPUT_JACOBIAN_PLUS};
  for (int i = 0; i < fields; ++i) r.add_outputs(all[i]);
  return r;
}

// Frames per second of one StreamTiles call; every field of every frame decoded to floats.
double stream_rate(squall::client::Client& client, const v1::StreamTilesRequest& r) {
  auto service = v1::Ocean::NewStub(client.channel());
  auto context = client.context();
  auto start = std::chrono::steady_clock::now();
  auto reader = service->StreamTiles(context.get(), r);
  squall::client::ocean::FrameAssembler assembler;
  v1::TileChunk chunk;
  size_t frames = 0, values = 0;
  while (reader->Read(&chunk)) {
    auto frame = assembler.add(chunk);
    if (!frame) continue;
    ++frames;
    for (const auto& f : frame->fields()) values += squall::client::ocean::values(f).size();
  }
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  squall::client::check(reader->Finish(), "Ocean.StreamTiles");
  if (frames != r.frame_count() || values == 0) throw std::runtime_error("stream ended early");
  return double(frames) / seconds;
}

}  // namespace

int main(int argc, char** argv) {
  squall::bench::keep_freed_memory();  // a frame's memory is not faulted in anew for each frame
  squall::bench::skip_lock_order_checks();
  squall::client::ClientOptions options;
  options.timeout_seconds = 600;
  int n = 512, frames = 40, fields = 9;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--address")) options.address = argv[i + 1];
    if (!std::strcmp(argv[i], "--n")) n = std::stoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--frames")) frames = std::stoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--fields")) fields = std::stoi(argv[i + 1]);
  }
  if (fields < 1 || fields > 9 || frames < 1) {
    std::fprintf(stderr, "--fields 1..9, --frames >= 1\n");
    return 2;
  }
  try {
    squall::client::Client client(options);
    if (!client.wait_until_serving(300)) throw std::runtime_error(options.address + " never turned SERVING");
    stream_rate(client, request(n, 1, fields));  // warm-up: connection, h0 spectrum, plans
    std::printf("frames_per_second %.4f\n", stream_rate(client, request(n, frames, fields)));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "stream_client_bench: %s\n", e.what());
    return 1;
  }
}
