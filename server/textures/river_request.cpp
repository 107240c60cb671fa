#include "textures/river_request.h"

#include "common/error.h"
#include "common/field_codec.h"

namespace squall::textures::rpc {
namespace {

namespace v1 = squall::v1;

std::vector<Point2> points(const v1::Polyline& line) {
  std::vector<Point2> out;
  for (const v1::Vec2& p : line.points()) out.push_back({p.x(), p.y()});
  return out;
}

BakeGrid region_grid(uint32_t nx, uint32_t ny, const v1::TextureRegion& r) {
  return {nx, ny, r.x0(), r.y0(), r.x1(), r.y1()};
}

}  // namespace

RiverSpec river(const v1::RiverVelocity& r) {
  RiverSpec spec;
  for (const v1::RiverChannel& c : r.channels()) {
    RiverChannelSpec channel;
    channel.left = points(c.left_bank());
    channel.right = points(c.right_bank());
    if (c.has_flow_rate()) channel.flow_rate = c.flow_rate();
    if (c.has_cross_section()) channel.cross_section = c.cross_section();
    spec.channels.push_back(std::move(channel));
  }
  auto indices = [](const auto& repeated) { return std::vector<uint32_t>(repeated.begin(), repeated.end()); };
  for (const v1::RiverJunction& j : r.junctions())
    spec.junctions.push_back({indices(j.upstream()), indices(j.downstream())});
  for (const v1::RiverObstacle& o : r.obstacles()) {
    RiverObstacleSpec obstacle{points(o.outline()), {}};
    if (o.has_search_radius()) obstacle.search_radius = o.search_radius();
    spec.obstacles.push_back(std::move(obstacle));
  }
  if (r.has_p()) spec.p = r.p();
  if (r.has_search_radius()) spec.search_radius = r.search_radius();
  return spec;
}

BakeGrid bake_grid(const v1::BakeVelocityRequest& request, const std::string& path) {
  if (!request.has_region()) fail(Code::InvalidArgument, path + ".region is unset: give the grid's extent (du)");
  return region_grid(request.nx(), request.ny(), request.region());
}

BakeGrid bake_grid(const v1::RiverVelocity& river, const OutputSpec& output) {
  const uint32_t nx = river.has_bake_nx() ? river.bake_nx() : 128, ny = river.has_bake_ny() ? river.bake_ny() : 128;
  if (river.has_bake_region()) return region_grid(nx, ny, river.bake_region());
  v1::TextureRegion r;
  r.set_x0(output.x0);
  r.set_y0(output.y0);
  r.set_x1(output.x1);
  r.set_y1(output.y1);
  return region_grid(nx, ny, r);
}

void fill_bake(const RiverBake& bake, const v1::BakeVelocityRequest& request, v1::BakeVelocityReply* reply) {
  const BakeGrid& g = bake.grid;
  const double hx = (g.x1 - g.x0) / (g.nx - 1), hy = (g.y1 - g.y0) / (g.ny - 1);
  const v1::DType dtype = field::dtype(request.dtype(), "request.dtype");
  auto encode = [&](const std::string& name, const char* unit, const std::vector<float>& values, v1::Field* out) {
    field::encode({name, unit, uint32_t(g.nx), uint32_t(g.ny), 0, dtype}, values.data(), values.size(), out);
    out->mutable_spacing()->set_x(hx);
    out->mutable_spacing()->set_y(hy);
    out->mutable_origin()->set_x(g.x0);
    out->mutable_origin()->set_y(g.y0);
  };
  encode("u", "du/s", bake.u, reply->mutable_u());
  encode("v", "du/s", bake.v, reply->mutable_v());
  if (request.psi()) encode("psi", "du^2/s", bake.psi, reply->mutable_psi());
  encode("fluid", "1", bake.fluid, reply->mutable_fluid());
  reply->set_undefined_nodes(bake.undefined);
  for (double q : bake.network.flow_rate) reply->add_flow_rates(q);
  for (double psi : bake.network.left_psi) reply->add_left_psi(psi);
  for (double psi : bake.network.right_psi) reply->add_right_psi(psi);
  for (double psi : bake.obstacle_psi) reply->add_obstacle_psi(psi);
}

}  // namespace squall::textures::rpc
