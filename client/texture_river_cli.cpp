// `squall texture river`: a procedural river's velocity on a grid (Textures.BakeVelocity) -> EXR.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>

#include "client/cli.h"
#include "client/cli_flags.h"
#include "client/image_io.h"
#include "client/texture_cli_flags.h"
#include "client/texture_verbs.h"
#include "server/common/field_codec.h"
#include "squall/v1/textures.grpc.pb.h"

namespace squall::cli::texture {

const char* const kRiverHelp = R"(
  squall texture river --river FILE.json [FLAGS] --out FILE.exr
A river's velocity (Yu, Neyret, Bruneton, Holzschuch, "Scalable Real-Time Animation of Rivers",
Eurographics 2009): the stream function psi is constant on each bank and island, differs across a channel
by its flow rate, and is interpolated in between; v = curl psi. FILE.json is a squall.v1.RiverVelocity in
protobuf's JSON mapping (channels with leftBank / rightBank point lists drawn downstream, flowRate,
junctions with upstream / downstream channel indices, obstacles with outline points, p, searchRadius).
Writes FILE.exr (channels u, v, fluid, and psi with --psi; nodes at the region's corners and evenly
between) and prints the flow rates and the psi of every boundary.
  --size NXxNY           nodes (default 256x256)
  --region X0,Y0,X1,Y1   du (default: the river's bounding box)
  --psi                  also the stream function
The same file drives an advection: squall texture advect --velocity river:FILE.json ...
)";

namespace {

namespace v1 = squall::v1;

struct River {
  v1::BakeVelocityRequest request;
  std::string out;
};

// The bounding box of every point of the river.
void bounding_region(const v1::RiverVelocity& river, v1::TextureRegion* region) {
  double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
  auto add = [&](const v1::Polyline& line) {
    for (const v1::Vec2& p : line.points())
      x0 = std::min(x0, p.x()), y0 = std::min(y0, p.y()), x1 = std::max(x1, p.x()), y1 = std::max(y1, p.y());
  };
  for (const v1::RiverChannel& c : river.channels()) add(c.left_bank()), add(c.right_bank());
  for (const v1::RiverObstacle& o : river.obstacles()) add(o.outline());
  if (!(x1 > x0 && y1 > y0)) throw UsageError("--river: the river has no extent; give --region");
  region->set_x0(x0), region->set_y0(y0), region->set_x1(x1), region->set_y1(y1);
}

River parse(const std::vector<std::string>& args) {
  River r;
  r.request.set_nx(256);
  r.request.set_ny(256);
  bool has_river = false;
  for (size_t i = 1; i < args.size(); ++i) {
    const std::string& flag = args[i];
    if (flag == "--psi") {
      r.request.set_psi(true);
      continue;
    }
    if (i + 1 >= args.size()) throw UsageError(flag + " needs a value (or is unknown)");
    const std::string& value = args[++i];
    if (flag == "--river") {
      *r.request.mutable_river() = river_file(flag, value), has_river = true;
    } else if (flag == "--size") {
      const auto [nx, ny] = extent(flag, value, 2);
      r.request.set_nx(nx), r.request.set_ny(ny);
    } else if (flag == "--region") {
      const std::vector<double> v = numbers(flag, value, {4});
      auto* region = r.request.mutable_region();
      region->set_x0(v[0]), region->set_y0(v[1]), region->set_x1(v[2]), region->set_y1(v[3]);
    } else if (flag == "--out" || flag == "-o") {
      r.out = value;
    } else {
      throw UsageError("unknown flag " + flag);
    }
  }
  if (!has_river) throw UsageError("--river FILE.json is required");
  if (r.out.empty()) throw UsageError("--out FILE.exr is required");
  if (!r.request.has_region()) bounding_region(r.request.river(), r.request.mutable_region());
  return r;
}

void print_boundaries(const v1::BakeVelocityReply& reply) {
  for (int c = 0; c < reply.flow_rates_size(); ++c)
    std::cout << "channel " << c << ": Q = " << reply.flow_rates(c) << " du^2/s, psi left " << reply.left_psi(c)
              << ", right " << reply.right_psi(c) << "\n";
  for (int o = 0; o < reply.obstacle_psi_size(); ++o)
    std::cout << "obstacle " << o << ": psi = " << reply.obstacle_psi(o) << "\n";
  if (reply.undefined_nodes() > 0)
    std::cout << reply.undefined_nodes() << " water nodes beyond the search radius of every boundary (v = 0)\n";
}

}  // namespace

int river(client::Client& client, const std::vector<std::string>& args) {
  const River r = parse(args);
  auto service = v1::Textures::NewStub(client.channel());
  auto context = client.context();
  v1::BakeVelocityReply reply;
  client::check(service->BakeVelocity(context.get(), r.request, &reply), "Textures.BakeVelocity");
  client::Image image;
  image.nx = int(reply.u().nx()), image.ny = int(reply.u().ny());
  for (const v1::Field* f : {&reply.u(), &reply.v(), &reply.fluid(), &reply.psi()})
    if (f->nx() > 0) image.channels.push_back({f->name(), field::decode(*f, "reply." + f->name())});
  image.attributes.emplace_back("squall.request.region", r.request.region().ShortDebugString());
  try {
    client::write_exr(r.out, image);
  } catch (const std::exception& e) {
    std::cerr << "squall texture river: " << e.what() << "\n";
    return kLocalError;
  }
  print_boundaries(reply);
  std::cout << "wrote " << r.out << " (" << image.nx << " x " << image.ny << " nodes)\n";
  return kOk;
}

}  // namespace squall::cli::texture
