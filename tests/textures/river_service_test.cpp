// Procedural rivers through a real squalld: BakeVelocity returns the engine's bake bit for bit; a river with
// a junction and an island drives AdvectTexture end to end (the texture coordinates move with the baked
// flow); an obstacle moved between messages of AdvectInteractive takes effect at the next frame without a
// restart; bad rivers get INVALID_ARGUMENT naming the field; a bake whose call expired stops using the cores.
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "common/field_codec.h"
#include "service_support.h"
#include "support/expect_error.h"
#include "support/process.h"
#include "support/test_runtime.h"
#include "textures/river.h"
#include "textures/river_request.h"
#include "textures/textures_request.h"

namespace squall {
namespace {

using namespace squall::textures_test;
constexpr double kPi = 3.14159265358979323846;

textures::RiverEngine& rivers() {
  static LimitGate gate{Limits{}};
  static textures::RiverEngine engine(test::runtime(), gate);
  return engine;
}

void polyline(v1::Polyline* line, std::vector<std::pair<double, double>> points) {
  for (auto [x, y] : points) {
    v1::Vec2* p = line->add_points();
    p->set_x(x);
    p->set_y(y);
  }
}

// Channel 0 (2 du wide, Q = 3 du^2/s) with a round island at `island`, splitting at x = 2 into two branches
// 1 du wide (left: to the upper right, right: to the lower right).
v1::RiverVelocity y_river(double island_x = 1, double island_y = 1) {
  v1::RiverVelocity r;
  auto channel = [&](std::vector<std::pair<double, double>> left, std::vector<std::pair<double, double>> right) {
    v1::RiverChannel* c = r.add_channels();
    polyline(c->mutable_left_bank(), left);
    polyline(c->mutable_right_bank(), right);
    return c;
  };
  channel({{0, 2}, {2, 2}}, {{0, 0}, {2, 0}})->set_flow_rate(3);
  channel({{2, 2}, {5, 3.5}}, {{2, 1}, {5, 2.5}});
  channel({{2, 1}, {5, -0.5}}, {{2, 0}, {5, -1.5}});
  v1::RiverJunction* j = r.add_junctions();
  j->add_upstream(0);
  j->add_downstream(1);
  j->add_downstream(2);
  std::vector<std::pair<double, double>> circle;
  for (int k = 0; k < 32; ++k)
    circle.push_back({island_x + 0.25 * std::cos(2 * kPi * k / 32), island_y + 0.25 * std::sin(2 * kPi * k / 32)});
  polyline(r.add_obstacles()->mutable_outline(), circle);
  r.set_search_radius(2);
  r.set_bake_nx(96);
  r.set_bake_ny(96);
  return r;
}

// The naive method (texture coordinates advected, never regenerated) over [0, 5] x [-1.5, 3.5], 64 x 64
// pixels, noise bands summed, the final and uv planes, 2 periods per du, dt 0.1 s in 2 substeps: the
// strain at the island's shore turns a texel by 2.5 rad in 0.1 s, past the 2 one substep may.
v1::AdvectTextureRequest river_request(uint32_t frames) {
  v1::AdvectTextureRequest r;
  r.set_method(v1::TEXTURE_METHOD_NAIVE);
  *r.mutable_velocity()->mutable_river() = y_river();
  r.mutable_texture()->set_scale(2);
  r.mutable_texture()->set_final_function(v1::FINAL_FUNCTION_SUM_BANDS);
  r.mutable_output()->set_width(64);
  r.mutable_output()->set_height(64);
  auto* region = r.mutable_output()->mutable_region();
  region->set_x0(0);
  region->set_y0(-1.5);
  region->set_x1(5);
  region->set_y1(3.5);
  r.mutable_output()->add_planes(v1::TEXTURE_PLANE_FINAL);
  r.mutable_output()->add_planes(v1::TEXTURE_PLANE_UV);
  r.mutable_eulerian()->set_grid_nx(96);
  r.mutable_eulerian()->set_grid_ny(96);
  r.set_dt(0.1);
  r.set_substeps(2);
  r.set_frames(frames);
  return r;
}

// BakeVelocity's reply, or its status thrown as the engine error it carries.
v1::BakeVelocityReply bake_velocity(const v1::BakeVelocityRequest& request,
                                    const std::string& address = daemon().address()) {
  client::Client client({address, 300, ""});
  auto service = v1::Textures::NewStub(client.channel());
  auto context = client.context();
  v1::BakeVelocityReply reply;
  throw_status(service->BakeVelocity(context.get(), request, &reply));
  return reply;
}

// The request's advection in this process, on the river baked here.
textures::AdvectSpec in_process_spec(const v1::AdvectTextureRequest& request, const v1::RiverVelocity& river) {
  textures::AdvectSpec spec = translated(request);
  spec.velocity = textures::velocity_grid(
      rivers().bake(textures::rpc::river(river), textures::rpc::bake_grid(river, spec.output), "river"), "river");
  engine().validate(spec, "request");
  return spec;
}

std::vector<float> plane_named(const v1::TextureFrame& frame, const std::string& name) {
  for (const v1::Field& plane : frame.planes())
    if (plane.name() == name) return field::decode(plane, name);
  ADD_FAILURE() << "no plane " << name;
  return {};
}

void expect_same_planes(const v1::TextureFrame& got, const textures::TextureFrame& want,
                        const textures::AdvectSpec& spec, const v1::TextureOutput& output) {
  v1::TextureFrame encoded;
  textures::rpc::fill_frame(want, spec, textures::rpc::planes(output), &encoded);
  ASSERT_EQ(got.planes_size(), encoded.planes_size());
  for (int k = 0; k < got.planes_size(); ++k) EXPECT_EQ(got.planes(k).data(), encoded.planes(k).data()) << k;
}

// The y river baked on nx x ny nodes over [0, 5] x [-1.5, 3.5] du, with psi.
v1::BakeVelocityRequest y_river_bake(uint32_t nx, uint32_t ny) {
  v1::BakeVelocityRequest request;
  *request.mutable_river() = y_river();
  request.set_nx(nx);
  request.set_ny(ny);
  auto* region = request.mutable_region();
  region->set_x0(0);
  region->set_y0(-1.5);
  region->set_x1(5);
  region->set_y1(3.5);
  request.set_psi(true);
  return request;
}

TEST(TexturesRiver, BakeVelocityEqualsTheEngine) {
  const v1::BakeVelocityRequest request = y_river_bake(80, 72);
  const v1::BakeVelocityReply reply = bake_velocity(request);
  const textures::RiverBake want =
      rivers().bake(textures::rpc::river(request.river()), textures::rpc::bake_grid(request), "river");
  EXPECT_EQ(field::decode(reply.u(), "u"), want.u);
  EXPECT_EQ(field::decode(reply.v(), "v"), want.v);
  EXPECT_EQ(field::decode(reply.psi(), "psi"), want.psi);
  EXPECT_EQ(field::decode(reply.fluid(), "fluid"), want.fluid);
  EXPECT_EQ(reply.u().nx(), 80u);
  EXPECT_NEAR(reply.u().spacing().x(), 5.0 / 79, 1e-12);
  ASSERT_EQ(reply.flow_rates_size(), 3);
  EXPECT_DOUBLE_EQ(reply.flow_rates(1), 1.5);  // equal cross-sections: half of Q each
  EXPECT_DOUBLE_EQ(reply.flow_rates(2), 1.5);
  EXPECT_DOUBLE_EQ(reply.left_psi(0) - reply.right_psi(0), 3);
  ASSERT_EQ(reply.obstacle_psi_size(), 1);
  EXPECT_NEAR(reply.obstacle_psi(0), reply.right_psi(0) + 1.5, 0.05);  // the island sits on the axis
  EXPECT_EQ(reply.undefined_nodes(), 0);
}

TEST(TexturesRiver, JunctionAndIslandDriveAnAdvectedTexture) {
  const v1::AdvectTextureRequest request = river_request(6);
  const Streamed got = advect(request);
  ASSERT_TRUE(got.status.ok()) << got.status.error_message();
  ASSERT_EQ(got.frames.size(), 6u);
  const textures::AdvectSpec spec = in_process_spec(request, request.velocity().river());
  auto advection = engine().start(spec);
  for (const v1::TextureFrame& frame : got.frames) expect_same_planes(frame, advection->next(), spec, request.output());
  // The texture moves with the water: at pixel (column 20, row 24), in the main channel below the island,
  // the naive method's coordinate after 0.5 s is S X0 with X0 where the water there was at t = 0 (traced
  // back through the river with RK2 steps of 0.01 s).
  const textures::RiverSpec river = textures::rpc::river(request.velocity().river());
  auto velocity = [&](textures::Point2 p) {
    const textures::RiverSample s = rivers().sample(river, {p}, "river")[0];
    EXPECT_TRUE(s.fluid);
    return textures::Point2{s.u, s.v};
  };
  const textures::Point2 here{20.5 * 5 / 64, -1.5 + 24.5 * 5 / 64};
  textures::Point2 foot = here;
  for (int k = 0; k < 50; ++k) {
    const textures::Point2 v1 = velocity(foot);
    const textures::Point2 v2 = velocity({foot.x - 0.005 * v1.x, foot.y - 0.005 * v1.y});
    foot = {foot.x - 0.01 * v2.x, foot.y - 0.01 * v2.y};
  }
  EXPECT_GT(here.x - foot.x, 0.6);  // it came about 0.75 du from upstream
  const int pixel = 24 * 64 + 20;
  const std::vector<float> uv0 = plane_named(got.frames[0], "uv_x"), uv5 = plane_named(got.frames[5], "uv_x");
  EXPECT_NEAR(uv5[pixel] - uv0[pixel], 2 * (foot.x - here.x), 0.1 * 2 * (here.x - foot.x));
}

TEST(TexturesRiver, ObstacleMovedBetweenMessagesTakesEffectWithoutRestart) {
  v1::AdvectTextureRequest request = river_request(0);
  Interactive call;
  ASSERT_TRUE(call.send(start(request, 3), 3));
  v1::TextureControl moved = more(3);
  *moved.mutable_velocity()->mutable_river() = y_river(1.2, 0.7);  // the island moved downstream and down
  ASSERT_TRUE(call.send(moved, 3));
  ASSERT_TRUE(call.finish().ok());
  ASSERT_EQ(call.frames().size(), 6u);
  for (uint32_t i = 0; i < 6; ++i) EXPECT_EQ(call.frames()[i].index(), i);  // one stream, no restart

  request.set_frames(1);
  const textures::AdvectSpec before = in_process_spec(request, y_river());
  const textures::AdvectSpec after = in_process_spec(request, y_river(1.2, 0.7));
  auto advection = engine().start(before), unmoved = engine().start(before);
  for (int i = 0; i < 3; ++i) {
    const textures::TextureFrame frame = advection->next();
    unmoved->next();
    expect_same_planes(call.frames()[i], frame, before, request.output());
  }
  engine().steer(*advection, after);
  double changed = 0;
  for (int i = 3; i < 6; ++i) {
    const textures::TextureFrame frame = advection->next(), still = unmoved->next();
    expect_same_planes(call.frames()[i], frame, after, request.output());
    for (size_t k = 0; k < frame.planes.size(); ++k)
      changed = std::max(changed, double(std::abs(frame.planes[k] - still.planes[k])));
  }
  EXPECT_GT(changed, 0.01) << "the moved island changed the flow";
}

TEST(TexturesRiver, BadRiversNameTheField) {
  auto bake = [](const v1::BakeVelocityRequest& request) { bake_velocity(request); };
  v1::BakeVelocityRequest request;
  *request.mutable_river() = y_river();
  request.set_nx(16);
  request.set_ny(16);
  test::expect_error(Code::InvalidArgument, "request.region is unset", [&] { bake(request); });
  request.mutable_region()->set_x1(1);
  request.mutable_region()->set_y1(1);
  request.mutable_river()->mutable_channels(1)->mutable_left_bank()->mutable_points(1)->set_x(NAN);
  test::expect_error(Code::InvalidArgument, "request.river.channels[1].left_bank.points[1].x", [&] { bake(request); });
  *request.mutable_river() = y_river();
  request.mutable_river()->mutable_channels(0)->clear_flow_rate();
  test::expect_error(Code::InvalidArgument, "request.river.channels[0].flow_rate is unset", [&] { bake(request); });
  *request.mutable_river() = y_river();
  request.set_nx(5000);
  test::expect_error(Code::InvalidArgument, "request.nx", [&] { bake(request); });

  v1::AdvectTextureRequest advect_request = river_request(2);
  advect_request.mutable_velocity()->mutable_river()->set_bake_nx(1);
  test::expect_error(Code::InvalidArgument, "request.velocity.river.bake_nx", [&] { advect_or_throw(advect_request); });
  advect_request = river_request(2);
  advect_request.mutable_velocity()->mutable_river()->mutable_junctions(0)->add_downstream(9);
  test::expect_error(Code::InvalidArgument, "request.velocity.river.junctions[0].downstream[2] = 9",
                     [&] { advect_or_throw(advect_request); });
  // With no bake_region of its own the river bakes over the output's region, which is checked first, under
  // its own name; a bake grid too fine for it says where its region came from.
  advect_request = river_request(2);
  advect_request.mutable_output()->mutable_region()->set_x0(-2e7);
  test::expect_error(Code::InvalidArgument, "request.output.region.x0 = -20000000",
                     [&] { advect_or_throw(advect_request); });
  advect_request = river_request(2);
  advect_request.mutable_output()->mutable_region()->set_x1(1e-4);
  advect_request.mutable_velocity()->mutable_river()->set_bake_nx(4096);
  const std::string fine = test::expect_error(Code::InvalidArgument, "request.velocity.river.bake_region spans",
                                              [&] { advect_or_throw(advect_request); });
  EXPECT_NE(fine.find("bake_region is unset: it is the output's region"), std::string::npos) << fine;
}

// A slip river (p = 0.01: the speed grows as d^(p - 1) toward a wall) of the largest flow rate whose right
// bank passes 1e-36 below a row of nodes bakes finite speeds everywhere; a texture advected by a river whose
// speeds pass what an advection takes (1e9 du/s through a channel 0.8 wide) is refused naming the river, as
// the baked grid is no field of the request.
TEST(TexturesRiver, ASlipRiverGrazingTheNodesBakesFiniteSpeedsAndTooFastOnesNameTheRiver) {
  v1::RiverVelocity river;
  v1::RiverChannel* channel = river.add_channels();
  polyline(channel->mutable_left_bank(), {{-0.1, 0.8}, {1.1, 0.8}});
  polyline(channel->mutable_right_bank(), {{-0.1, -1e-36}, {1.1, -1e-36}});
  channel->set_flow_rate(1e9);
  river.set_p(0.01);
  v1::BakeVelocityRequest request;
  *request.mutable_river() = river;
  request.set_nx(33);
  request.set_ny(33);
  request.mutable_region()->set_y0(-1);
  request.mutable_region()->set_x1(1);
  request.mutable_region()->set_y1(1);
  const v1::BakeVelocityReply reply = bake_velocity(request);
  for (const auto* plane : {&reply.u(), &reply.v()})
    for (float c : field::decode(*plane, "u or v")) ASSERT_TRUE(std::isfinite(c));

  v1::AdvectTextureRequest advect = river_request(2);
  v1::RiverVelocity& fast = *advect.mutable_velocity()->mutable_river();
  fast.Clear();
  v1::RiverChannel* straight = fast.add_channels();
  polyline(straight->mutable_left_bank(), {{-0.1, 0.8}, {5.1, 0.8}});
  polyline(straight->mutable_right_bank(), {{-0.1, 0}, {5.1, 0}});
  straight->set_flow_rate(1e9);
  test::expect_error(Code::InvalidArgument, "request.velocity.river bakes speeds up to ",
                     [&] { advect_or_throw(advect); });
}

// A channel whose banks ripple through 4096 points each, baked on 4096 x 2048 nodes over a region whose
// lower 70% is land far from it (cheap nodes, baked first) and whose upper 30% has the channel's walls within
// the search radius (each node scans thousands of segments, and in the channel tests its 8192 edges: seconds
// of the two cores).
v1::AdvectTextureRequest expensive_river_request() {
  v1::AdvectTextureRequest r = river_request(1);
  v1::RiverVelocity& river = *r.mutable_velocity()->mutable_river();
  river = v1::RiverVelocity();
  v1::RiverChannel* channel = river.add_channels();
  std::vector<std::pair<double, double>> left, right;
  for (int k = 0; k < 4096; ++k) {
    const double x = 10.0 * k / 4095, ripple = 0.01 * std::sin(0.37 * k);
    left.push_back({x, 1 + ripple});
    right.push_back({x, ripple});
  }
  polyline(channel->mutable_left_bank(), left);
  polyline(channel->mutable_right_bank(), right);
  channel->set_flow_rate(1);
  river.set_bake_nx(4096);
  river.set_bake_ny(2048);
  auto* region = r.mutable_output()->mutable_region();
  region->set_x0(0);
  region->set_y0(-9);
  region->set_x1(10);
  region->set_y1(1);
  return r;
}

// The advection of expensive_river_request() under a 1 s deadline: squalld stops baking within a second of
// the deadline, between two slices, although slices sized on the cheap nodes' pace alone would hold the
// costly ones for seconds.
TEST(TexturesRiver, AnExpiredBakeStopsUsingTheCores) {
  if (test::runtime().device_info().type != "cpu") GTEST_SKIP() << "the bake is sized for a CPU device's pace";
  const grpc::Status expired = advect(expensive_river_request(), daemon().address(), 1).status;
  EXPECT_EQ(expired.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED) << expired.error_message();
  expect_daemon_stops("baking the expired river");
}

// A bake holds its result on the device, read back and as planes (48 bytes a node), and its reply: 2048^2
// nodes are 201 MB and 34 MB of float16 planes, refused under a 128 MiB budget; 256^2 nodes are baked.
TEST(TexturesRiver, ABakeCountsInTheMemoryBudget) {
  test::Daemon d({"--memory-budget", std::to_string(1ull << 27)});
  v1::BakeVelocityRequest request = y_river_bake(2048, 2048);
  request.set_dtype(v1::DTYPE_FLOAT16);
  test::expect_error(Code::ResourceExhausted, "BakeVelocity's bake and reply",
                     [&] { bake_velocity(request, d.address()); });
  request.set_nx(256);
  request.set_ny(256);
  EXPECT_EQ(bake_velocity(request, d.address()).u().nx(), 256u);
}

// The rest of an advection is validated before its river is baked: expensive_river_request() with a
// Lagrangian grid spacing d of -1 is refused naming d in 0.4 s, where baking first took 24 s on two CPU cores.
TEST(TexturesRiver, ABadAdvectionIsRefusedBeforeItsRiverIsBaked) {
  v1::AdvectTextureRequest r = expensive_river_request();
  r.set_method(v1::TEXTURE_METHOD_LAGRANGIAN_GRIDS);
  r.mutable_lagrangian()->set_d(-1);
  const auto start = std::chrono::steady_clock::now();
  const grpc::Status refused = advect(r, daemon().address(), 60).status;
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << refused.error_message();
  EXPECT_NE(refused.error_message().find("request.lagrangian.d"), std::string::npos) << refused.error_message();
  EXPECT_LT(seconds, 3) << "the river was baked before the request was refused";
}

// A bad river is refused for what it is, INVALID_ARGUMENT naming it, even when every stream slot is taken:
// a river is checked (its bake grid, its flow rates solved through the junctions) before its stream asks for
// a slot, and baked only once it has one.
TEST(TexturesRiver, ABadRiverIsInvalidEvenWhenTheStreamsAreFull) {
  test::Daemon d({"--max-streams", "1"});
  Interactive held(d.address());  // the one slot, for as long as it is open
  ASSERT_TRUE(held.send(start(river_request(2), 1), 1));
  v1::AdvectTextureRequest coarse = river_request(2), unbalanced = river_request(2);
  coarse.mutable_velocity()->mutable_river()->set_bake_nx(1);
  for (int c : {1, 2})  // 3 du^2/s in, 1 + 1 out
    unbalanced.mutable_velocity()->mutable_river()->mutable_channels(c)->set_flow_rate(1);
  for (const auto& [bad, field] :
       {std::pair{coarse, "request.velocity.river.bake_nx"}, std::pair{unbalanced, "flow in 3 du^2/s != flow out 2"}}) {
    const grpc::Status status = advect(bad, d.address()).status;
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_NE(status.error_message().find(field), std::string::npos) << status.error_message();
  }
  EXPECT_TRUE(held.finish().ok());
}

// A bake's work is estimated before it runs (each node tests the wall segments within the search radius and
// the points of the polygons around it) and refused past --max-bake-work: under 1e7 tests the Y river bakes
// on 64 x 64 nodes, and on 1024 x 1024 it is refused naming the bake and the flag. The pass that finds the
// obstacles' values at their centres (RIV09 sec. 4.3) is estimated too, before it runs: 64 islands of 4096
// points within the search radius of each other's centres make 1.7e7 tests.
TEST(TexturesRiver, ABakePastMaxBakeWorkIsRefusedBeforeItRuns) {
  test::Daemon d({"--max-bake-work", "1e7"});
  EXPECT_EQ(bake_velocity(y_river_bake(64, 64), d.address()).u().nx(), 64u);
  const std::string refused =
      test::expect_error(Code::ResourceExhausted, "request.river: the bake of 1024 x 1024 nodes",
                         [&] { bake_velocity(y_river_bake(1024, 1024), d.address()); });
  EXPECT_NE(refused.find("more than --max-bake-work = 10000000"), std::string::npos) << refused;
  v1::BakeVelocityRequest islands = y_river_bake(2, 2);
  islands.mutable_river()->clear_obstacles();
  for (int o = 0; o < 64; ++o) {
    std::vector<std::pair<double, double>> circle;
    for (int k = 0; k < 4096; ++k)
      circle.push_back({1 + 0.01 * o + 0.005 * std::cos(2 * kPi * k / 4096), 1 + 0.005 * std::sin(2 * kPi * k / 4096)});
    polyline(islands.mutable_river()->add_obstacles()->mutable_outline(), circle);
  }
  test::expect_error(Code::ResourceExhausted, "request.river: the pass over the obstacles' centres makes",
                     [&] { bake_velocity(islands, d.address()); });
}

// A river's wall bins are counted before they are stored and held in the memory budget: a bank zigzagging
// ten times across a region 2e7 du long (a request of a few hundred bytes) crosses 1e7 bins of 20 du, 80 MB
// of entries on the host and the device, refused under a 64 MiB budget naming them.
TEST(TexturesRiver, AWallsBinsCountInTheMemoryBudget) {
  test::Daemon d({"--memory-budget", std::to_string(64 << 20)});
  v1::BakeVelocityRequest request = y_river_bake(2, 2);
  v1::RiverVelocity& river = *request.mutable_river();
  river = v1::RiverVelocity();
  v1::RiverChannel* channel = river.add_channels();
  std::vector<std::pair<double, double>> zigzag;
  for (int k = 0; k <= 10; ++k) zigzag.push_back({k % 2 ? 1e7 : -1e7, 1 + 0.01 * k});
  polyline(channel->mutable_left_bank(), zigzag);
  polyline(channel->mutable_right_bank(), {{-1e7, 0}, {1e7, 0}});
  channel->set_flow_rate(1);
  river.set_search_radius(1);
  test::expect_error(Code::ResourceExhausted, "request.river's wall bins",
                     [&] { bake_velocity(request, d.address()); });
}

// A river's walls and polygons are counted before they are made, on the host and the device: 160 channels
// with banks of 4096 points (a 27 MB request) are 73 MB of segments and polygon points, refused under a
// 64 MiB budget naming them.
TEST(TexturesRiver, AWallsSegmentsAndPolygonsCountInTheMemoryBudget) {
  test::Daemon d({"--memory-budget", std::to_string(64 << 20)});
  v1::BakeVelocityRequest request = y_river_bake(2, 2);
  v1::RiverVelocity& river = *request.mutable_river();
  river = v1::RiverVelocity();
  for (int c = 0; c < 160; ++c) {
    v1::RiverChannel* channel = river.add_channels();
    std::vector<std::pair<double, double>> left, right;
    for (int k = 0; k < 4096; ++k) {
      left.push_back({1e-3 * k, 2.0 * c + 1});
      right.push_back({1e-3 * k, 2.0 * c});
    }
    polyline(channel->mutable_left_bank(), left);
    polyline(channel->mutable_right_bank(), right);
    channel->set_flow_rate(1);
  }
  test::expect_error(Code::ResourceExhausted, "request.river's walls and polygons",
                     [&] { bake_velocity(request, d.address()); });
}

// `squall texture river` writes the bake as an EXR (the reply's values) and prints the flow rates;
// `squall texture advect --velocity river:FILE.json` streams frames driven by the same file.
TEST(TexturesRiver, CommandLine) {
  const std::string dir = test::temp_dir("textures-river-cli");
  std::string json;
  ASSERT_TRUE(google::protobuf::util::MessageToJsonString(y_river(), &json).ok());
  std::ofstream(dir + "/river.json") << json;
  std::string out;
  ASSERT_EQ(test::run({test::squall_path(), "--address", daemon().address(), "texture", "river", "--river",
                       dir + "/river.json", "--size", "40x32", "--region", "0,-1.5,5,3.5", "--psi", "--out",
                       dir + "/river.exr"},
                      &out),
            0)
      << out;
  EXPECT_NE(out.find("channel 1: Q = 1.5 du^2/s"), std::string::npos) << out;
  EXPECT_NE(out.find("obstacle 0: psi = "), std::string::npos) << out;
  v1::BakeVelocityRequest request;
  *request.mutable_river() = y_river();
  request.set_nx(40);
  request.set_ny(32);
  request.mutable_region()->set_x0(0), request.mutable_region()->set_y0(-1.5);
  request.mutable_region()->set_x1(5), request.mutable_region()->set_y1(3.5);
  const v1::BakeVelocityReply reply = bake_velocity(request);
  Imf::InputFile file((dir + "/river.exr").c_str());
  std::vector<float> u(40 * 32);
  for (const char* name : {"u", "v", "fluid", "psi"})
    EXPECT_NE(file.header().channels().findChannel(name), nullptr) << name;
  Imf::FrameBuffer frame;
  frame.insert("u", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(u.data()), 4, 4 * 40));
  file.setFrameBuffer(frame);
  file.readPixels(file.header().dataWindow().min.y, file.header().dataWindow().max.y);
  EXPECT_EQ(u, field::decode(reply.u(), "u"));

  ASSERT_EQ(test::run({test::squall_path(), "--address", daemon().address(), "texture", "advect", "--method", "naive",
                       "--velocity", "river:" + dir + "/river.json", "--region", "0,-1.5,5,3.5", "--size", "32x32",
                       "--frames", "2", "--out", dir + "/frames"},
                      &out),
            0)
      << out;
  EXPECT_TRUE(std::filesystem::exists(dir + "/frames/frame_0001.exr")) << out;
  // The README's example river.
  ASSERT_EQ(test::run({test::squall_path(), "--address", daemon().address(), "texture", "river", "--river",
                       std::string(SQUALL_SOURCE_DIR) + "/docs/examples/river.json", "--size", "32x32", "--out",
                       dir + "/example.exr"},
                      &out),
            0)
      << out;
  EXPECT_NE(out.find("channel 2: Q = 1.5 du^2/s"), std::string::npos) << out;
  EXPECT_EQ(test::run({test::squall_path(), "--address", daemon().address(), "texture", "river", "--river",
                       dir + "/missing.json", "--out", dir + "/x.exr"},
                      &out),
            2)
      << out;
}

}  // namespace
}  // namespace squall
