// Textures, part two, in one run on this machine's device:
//   (a) a river's velocity baked on 128^2 .. 1024^2 nodes (Q. Yu, F. Neyret, E. Bruneton, N. Holzschuch,
//       "Scalable Real-Time Animation of Rivers", Eurographics 2009, sec. 4: a Y junction with an island),
//       against the same equations 1-3 evaluated on the host in double precision, one thread, every wall
//       segment visited (the reference, also checked for agreement);
//   (b) content-aware deformation frames (G. Guingo et al., "Content-aware texture deformation with dynamic
//       control", Computers & Graphics 2020) at the texel counts of its Table 1 (0.32, 1 and 3.24 million),
//       1 and 10 Euler sub-steps per frame (the flow solve capped at 200 iterations: a frame's cost does not
//       depend on the flow's accuracy), one colour plane read back each frame; in process, and through
//       squall.v1.Textures/DeformTexture against a squalld (--address) with the colour plane streamed.
//
//   build/bench/river_deform_bench [--device auto|cpu|gpu|NAME] [--seconds S] [--address HOST:PORT]
#include <grpcpp/grpcpp.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "bench_util.h"
#include "common/field_codec.h"
#include "runtime/runtime.h"
#include "squall/v1/textures.grpc.pb.h"
#include "textures/deform.h"
#include "textures/river.h"

using namespace squall;
using namespace squall::textures;
using Clock = std::chrono::steady_clock;

namespace {

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

std::vector<Point2> line(Point2 a, Point2 b) { return {a, b}; }

// Channel 0 (2 du wide, Q = 3) with an island, splitting at x = 2 into two branches 1 du wide.
RiverSpec y_river() {
  RiverSpec river;
  RiverChannelSpec main, left, right;
  main.left = line({0, 2}, {2, 2});
  main.right = line({0, 0}, {2, 0});
  main.flow_rate = 3;
  left.left = line({2, 2}, {5, 3.5});
  left.right = line({2, 1}, {5, 2.5});
  right.left = line({2, 1}, {5, -0.5});
  right.right = line({2, 0}, {5, -1.5});
  river.channels = {main, left, right};
  river.junctions.push_back({{0}, {1, 2}});
  RiverObstacleSpec island;
  for (int k = 0; k < 64; ++k)
    island.outline.push_back({1 + 0.25 * std::cos(2 * M_PI * k / 64), 1 + 0.25 * std::sin(2 * M_PI * k / 64)});
  river.obstacles.push_back(island);
  river.search_radius = 2;
  return river;
}

// Eqs. 1-3 at P in double, every segment visited: returns psi (the reference for the bake's psi).
struct Wall {
  Point2 a, b;
  int boundary;
};

double host_psi(Point2 P, const std::vector<Wall>& walls, const std::vector<double>& psi, double s, double p) {
  std::vector<double> d(psi.size(), INFINITY);
  for (const Wall& w : walls) {
    const double ux = w.b.x - w.a.x, uy = w.b.y - w.a.y, len2 = ux * ux + uy * uy;
    const double t = std::clamp(((P.x - w.a.x) * ux + (P.y - w.a.y) * uy) / len2, 0.0, 1.0);
    d[w.boundary] = std::min(d[w.boundary], std::hypot(P.x - w.a.x - t * ux, P.y - w.a.y - t * uy));
  }
  double sum_w = 0, sum = 0;
  for (size_t i = 0; i < d.size(); ++i) {
    if (!(d[i] <= s)) continue;
    const double t = 1 - d[i] / s, w = std::pow(d[i], -p) * t * t * t * (t * (6 * t - 15) + 10);
    sum_w += w, sum += w * psi[i];
  }
  return sum_w > 0 ? sum / sum_w : 0;
}

void bench_river(RiverEngine& engine) {
  const RiverSpec river = y_river();
  const RiverBake probe = engine.bake(river, {2, 2, 0, -1.5, 5, 3.5}, "river");
  std::vector<Wall> walls;
  for (size_t c = 0; c < river.channels.size(); ++c) {
    for (int side = 0; side < 2; ++side) {
      const auto& bank = side == 0 ? river.channels[c].left : river.channels[c].right;
      for (size_t k = 0; k + 1 < bank.size(); ++k)
        walls.push_back({bank[k], bank[k + 1], probe.network.boundary_of[2 * c + side]});
    }
  }
  std::vector<double> psi = probe.network.boundary_psi;
  const auto& outline = river.obstacles[0].outline;
  for (size_t k = 0; k < outline.size(); ++k)
    walls.push_back({outline[k], outline[(k + 1) % outline.size()], int(psi.size())});
  psi.push_back(probe.obstacle_psi[0]);

  std::printf("river bake (Y junction + island, s = 2 du): device against the host reference\n");
  std::printf("%-8s %12s %12s %12s %14s\n", "nodes", "device ms", "host ms", "host/device", "max |dpsi|/Q");
  for (int n : {128, 256, 512, 1024}) {
    const BakeGrid grid{n, n, 0, -1.5, 5, 3.5};
    RiverBake bake;
    const double device = bench::median_seconds([&] { bake = engine.bake(river, grid, "river"); }, 5);
    const int stride = n >= 512 ? n / 256 : 1;  // the host reference on every stride-th node, scaled
    double worst = 0;
    auto start = Clock::now();
    size_t evaluated = 0;
    for (int j = 0; j < n; j += stride) {
      for (int i = 0; i < n; i += stride, ++evaluated) {
        const Point2 P{grid.x0 + i * (grid.x1 - grid.x0) / (n - 1), grid.y0 + j * (grid.y1 - grid.y0) / (n - 1)};
        const double ref = host_psi(P, walls, psi, 2.0, river.p);
        if (bake.fluid[size_t(j) * n + i] != 0)
          worst = std::max(worst, std::abs(ref - bake.psi[size_t(j) * n + i]) / 3);
      }
    }
    const double host = seconds_since(start) * double(size_t(n) * n) / double(evaluated);
    std::printf("%-8d %12.2f %12.1f %12.1f %14.2e\n", n * n, device * 1e3, host * 1e3, host / device, worst);
  }
}

DeformSpec deform_spec(int width, int height, int substeps) {
  DeformSpec spec;
  spec.width = width, spec.height = height, spec.channels = 1;
  spec.pixels.resize(size_t(width) * height);
  spec.rigidity.resize(size_t(width) * height);
  for (int j = 0; j < height; ++j) {
    for (int i = 0; i < width; ++i) {
      const size_t k = size_t(j) * width + i;
      spec.pixels[k] = float(0.5 + 0.5 * std::sin(0.2 * i) * std::cos(0.15 * j));
      const double dx = i - width / 2.0, dy = j - height / 2.0, r = 0.2 * std::min(width, height);
      spec.rigidity[k] = dx * dx + dy * dy < r * r ? 1.0f : -1.0f;  // a rigid disk in a stretchable ground
    }
  }
  spec.control.kind = DeformControlKind::Constant;
  spec.control.d_mu = 0.01;
  spec.frames = 1000000;
  spec.substeps = substeps;
  spec.max_iterations = 200;  // the frame's cost does not depend on the flow's accuracy
  return spec;
}

// The same deformation as a DeformTexture request (float32 colour plane).
squall::v1::DeformTextureRequest deform_request(const DeformSpec& spec, uint32_t frames) {
  squall::v1::DeformTextureRequest r;
  const uint32_t w = uint32_t(spec.width), h = uint32_t(spec.height);
  field::encode({"c", "1", w, h, 0, squall::v1::DTYPE_FLOAT32}, spec.pixels, r.mutable_texture()->add_channels());
  field::encode({"R", "1", w, h, 0, squall::v1::DTYPE_FLOAT32}, spec.rigidity, r.mutable_rigidity());
  r.set_control(squall::v1::DEFORM_CONTROL_CONSTANT);
  r.set_d_mu(spec.control.d_mu);
  r.set_frames(frames);
  r.set_substeps(uint32_t(spec.substeps));
  r.set_max_iterations(uint32_t(spec.max_iterations));
  return r;
}

// Frames/s of a DeformTexture stream from its third frame on (the first two hold the flow solve).
double through_stream(squall::v1::Textures::Stub* textures, const DeformSpec& spec, double expected_fps,
                      double budget) {
  if (!textures) return 0;
  const int timed = std::max(3, int(expected_fps * budget));
  grpc::ClientContext context;
  auto reader = textures->DeformTexture(&context, deform_request(spec, uint32_t(2 + timed)));
  squall::v1::DeformFrame frame;
  int read = 0;
  Clock::time_point start;
  while (reader->Read(&frame))
    if (++read == 2) start = Clock::now();
  const grpc::Status status = reader->Finish();
  if (!status.ok() || read != 2 + timed) {
    std::fprintf(stderr, "DeformTexture failed: %s (%d frames)\n", status.error_message().c_str(), read);
    return 0;
  }
  return timed / seconds_since(start);
}

void bench_deform(DeformEngine& engine, squall::v1::Textures::Stub* textures, double budget) {
  std::printf("\ndeform frames (constant d mu, one colour plane read back each frame)\n");
  std::printf("%-10s %8s %10s %10s %12s %11s %9s   %s\n", "texels", "substeps", "frame ms", "frames/s", "ms/Mtexel",
              "stream f/s", "str/proc", "flow solve (first start of the size)");
  const std::pair<int, int> sizes[] = {{566, 566}, {1000, 1000}, {1800, 1800}};  // 0.32, 1, 3.24 M texels
  for (auto [w, h] : sizes) {
    for (int substeps : {1, 10}) {
      const DeformSpec spec = deform_spec(w, h, substeps);
      auto start = Clock::now();
      auto deformation = engine.start(spec);  // solves the flow, or reuses the size's solve
      const double solve = seconds_since(start);
      for (int i = 0; i < 3; ++i) deformation->next({});  // frame 0, then two steps: allocation, compilation
      int frames = 0;
      start = Clock::now();
      while (frames < 3 || seconds_since(start) < budget) deformation->next({}), ++frames;
      const double frame = seconds_since(start) / frames;
      const double stream = through_stream(textures, spec, 1 / frame, budget);
      char solved[96] = "";
      if (substeps == 1)
        std::snprintf(solved, sizeof solved, "%d iterations, %.2f ms each", deformation->flow().iterations,
                      solve * 1e3 / std::max(1, deformation->flow().iterations));
      std::printf("%-10d %8d %10.1f %10.2f %12.1f %11.2f %9.2f   %s\n", w * h, substeps, frame * 1e3, 1 / frame,
                  frame * 1e3 / (w * h * 1e-6), stream, stream * frame, solved);
    }
  }
}

}  // namespace

int bench_main(int argc, char** argv) {
  RuntimeOptions options;
  options.program_prefixes = {"runtime/", "textures/river", "textures/deform"};
  double budget = 2;
  std::string address;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--device")) options.device = argv[i + 1];
    if (!std::strcmp(argv[i], "--seconds")) budget = std::stod(argv[i + 1]);
    if (!std::strcmp(argv[i], "--address")) address = argv[i + 1];
  }
  configure_kernel_cache();
  Runtime runtime(options);
  runtime.build_programs();
  LimitGate gate{Limits{}};
  RiverEngine rivers(runtime, gate);
  DeformEngine deform(runtime, gate);
  std::unique_ptr<squall::v1::Textures::Stub> textures;
  if (!address.empty()) {
    grpc::ChannelArguments args;
    args.SetMaxReceiveMessageSize(-1);
    textures =
        squall::v1::Textures::NewStub(grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args));
  }
  std::printf("device: %s; squalld: %s\n\n", describe(runtime.device_info()).c_str(),
              address.empty() ? "none (--address not given)" : address.c_str());
  bench_river(rivers);
  bench_deform(deform, textures.get(), budget);
  if (runtime.profiling())
    std::printf("\nkernel device time (SQUALL_PROFILE_KERNELS=1)\n%s",
                format_kernel_timings(runtime.kernel_timings()).c_str());
  return 0;
}

int main(int argc, char** argv) {
  return squall::bench::guarded_main(argv[0], [&] { return bench_main(argc, argv); });
}
