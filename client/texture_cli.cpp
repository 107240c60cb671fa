#include "client/texture_cli.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>

#include "client/cli.h"
#include "client/cli_flags.h"
#include "client/texture_cli_flags.h"
#include "client/texture_verbs.h"
#include "client/image_io.h"
#include "server/common/field_codec.h"
#include "squall/v1/textures.grpc.pb.h"

namespace squall::cli::texture {

const char* const kVerbUsage =
    "texture advect|river|deform ...  advected textures, river velocities, content-aware deformation -> EXR "
    "(+ PNG); `squall texture help` lists the flags";

namespace {

namespace v1 = squall::v1;

const char* const kHelp = R"(usage:
  squall texture advect [FLAGS] --out DIR
A reference texture (gradient noise bands, or an image) carried by a velocity field over the region
[0, 1]^2 (domain units du, seconds), one frame every dt: Lagrangian grids (Yu, Neyret, Bruneton,
Holzschuch, "Lagrangian Texture Advection", IEEE TVCG 2011), Eulerian multi-layer (Neyret, "Advected
Textures", SCA 2003), a two-phase flow map or naive advection. Each frame is DIR/frame_NNNN.exr (every
returned plane as a FLOAT channel, the request's parameters as attributes) and DIR/frame_NNNN.png (the
first final plane, 8-bit grey).
  --method NAME          lagrangian | eulerian | flowmap | naive (default lagrangian)
  --velocity KIND:ARGS   (default uniform:0.1,0)
      uniform:VX,VY               du/s
      rotation:OMEGA[,CX,CY]      rad/s about (CX, CY) (default 0.5,0.5)
      shear:RATE[,Y0]             1/s, v = (RATE (y - Y0), 0)
      sink:SPEED[,CX,CY[,EPS]]    du/s toward (CX, CY), softened by EPS du
      vortex:GAMMA[,CX,CY[,R]]    Rankine vortex: circulation du^2/s, core radius R du
      taylor-green:U,PERIOD       du/s, du
      channel:UMAX[,Y0,HALF]      Poiseuille channel: axis speed du/s, axis y, half width du
      cylinder:U[,CX,CY[,R]]      potential flow at U du/s past a cylinder of radius R du
      ewave:SESSION_ID            the surface current of a live eWave session, read before each step
                                  (du = m; step the session from another client, e.g. squall ewave wake)
      river:FILE.json             a procedural river (see `squall texture river`), baked on 128 x 128
                                  nodes over the output region unless the file says otherwise
  --noise BANDS[,CELLS[,SEED]]  gradient noise: bands 1..8, lattice cells per period 1..64 (default 4,4,1)
  --spin W               flow noise: band 0 turns at W rad/s (default: still noise)
  --image FILE           an image texture instead (no --noise, --spin): FILE.exr (its R, G, B, A
                         channels first, at most 8) or FILE.png (decoded by squalld)
  --final NAME           identity | sum | turbulence | ridged (default identity)
  --scale S              texture periods per du (default 4)
  --size WxH             output pixels (default 256x256)
  --region X0,Y0,X1,Y1   sampled region, du (default 0,0,1,1)
  --planes A,B,...       final raw weight_sum weight_sq_sum coverage layer uv (default final)
  --frames N             frames to stream, >= 1 (default 30)
  --dt S                 seconds between frames (default 1/30)
  --d D                  Lagrangian Poisson radius, du (default 0.1)
  --seed N               Lagrangian particle placement seed (default 1)
  --out DIR              output folder (created)
The stream's deadline is --timeout times the number of frames.
)";

const std::map<std::string, v1::TextureMethod> kMethods = {{"lagrangian", v1::TEXTURE_METHOD_LAGRANGIAN_GRIDS},
                                                           {"eulerian", v1::TEXTURE_METHOD_EULERIAN_MULTILAYER},
                                                           {"flowmap", v1::TEXTURE_METHOD_TWO_PHASE_FLOW_MAP},
                                                           {"naive", v1::TEXTURE_METHOD_NAIVE}};
const std::map<std::string, v1::FinalFunction> kFinals = {{"identity", v1::FINAL_FUNCTION_IDENTITY},
                                                          {"sum", v1::FINAL_FUNCTION_SUM_BANDS},
                                                          {"turbulence", v1::FINAL_FUNCTION_TURBULENCE},
                                                          {"ridged", v1::FINAL_FUNCTION_RIDGED}};
const std::map<std::string, v1::TexturePlane> kPlanes = {{"final", v1::TEXTURE_PLANE_FINAL},
                                                         {"raw", v1::TEXTURE_PLANE_RAW},
                                                         {"weight_sum", v1::TEXTURE_PLANE_WEIGHT_SUM},
                                                         {"weight_sq_sum", v1::TEXTURE_PLANE_WEIGHT_SQ_SUM},
                                                         {"coverage", v1::TEXTURE_PLANE_COVERAGE},
                                                         {"layer", v1::TEXTURE_PLANE_LAYER},
                                                         {"uv", v1::TEXTURE_PLANE_UV}};

struct Advect {
  v1::AdvectTextureRequest request;
  std::string out;
  std::vector<std::pair<std::string, std::string>> flags;  // as given, for the EXR attributes
};

// The centre (x, y) at v[at], v[at + 1] when given.
void center(const std::vector<double>& v, size_t at, v1::AnalyticVelocity* a) {
  if (v.size() < at + 2) return;
  a->mutable_center()->set_x(v[at]);
  a->mutable_center()->set_y(v[at + 1]);
}

void velocity_flag(const std::string& value, v1::AnalyticVelocity* a) {
  const size_t colon = value.find(':');
  const std::string kind = value.substr(0, colon), args = colon == std::string::npos ? "" : value.substr(colon + 1);
  const std::string flag = "--velocity " + kind;  // the numbers' messages name the kind: "--velocity uniform: ..."
  if (kind == "uniform") {
    auto v = numbers(flag, args, {2});
    a->set_kind(v1::AnalyticVelocity::KIND_UNIFORM), a->set_velocity_x(v[0]), a->set_velocity_y(v[1]);
  } else if (kind == "rotation") {
    auto v = numbers(flag, args, {1, 3});
    a->set_kind(v1::AnalyticVelocity::KIND_ROTATION), a->set_angular_velocity(v[0]), center(v, 1, a);
  } else if (kind == "shear") {
    auto v = numbers(flag, args, {1, 2});
    a->set_kind(v1::AnalyticVelocity::KIND_SHEAR), a->set_shear_rate(v[0]);
    if (v.size() == 2) a->set_y0(v[1]);
  } else if (kind == "sink") {
    auto v = numbers(flag, args, {1, 3, 4});
    a->set_kind(v1::AnalyticVelocity::KIND_SINK), a->set_speed(v[0]), center(v, 1, a);
    if (v.size() == 4) a->set_epsilon(v[3]);
  } else if (kind == "vortex") {
    auto v = numbers(flag, args, {1, 3, 4});
    a->set_kind(v1::AnalyticVelocity::KIND_RANKINE_VORTEX), a->set_circulation(v[0]), center(v, 1, a);
    if (v.size() == 4) a->set_core_radius(v[3]);
  } else if (kind == "taylor-green") {
    auto v = numbers(flag, args, {2});
    a->set_kind(v1::AnalyticVelocity::KIND_TAYLOR_GREEN), a->set_speed(v[0]), a->set_period(v[1]);
  } else if (kind == "channel") {
    auto v = numbers(flag, args, {1, 3});
    a->set_kind(v1::AnalyticVelocity::KIND_POISEUILLE_CHANNEL), a->set_speed(v[0]);
    if (v.size() == 3) a->set_y0(v[1]), a->set_half_width(v[2]);
  } else if (kind == "cylinder") {
    auto v = numbers(flag, args, {1, 3, 4});
    a->set_kind(v1::AnalyticVelocity::KIND_CYLINDER), a->set_speed(v[0]), center(v, 1, a);
    if (v.size() == 4) a->set_radius(v[3]);
  } else {
    throw UsageError("--velocity " + value +
                     ": uniform, rotation, shear, sink, vortex, taylor-green, channel or cylinder (KIND:ARGS)");
  }
}

void noise_flag(const std::string& value, v1::NoiseTexture* n) {
  auto v = items("--noise", value);
  if (v.empty() || v.size() > 3) throw UsageError("--noise " + value + ": BANDS[,CELLS[,SEED]]");
  n->set_bands(integer32("--noise", v[0], 1));
  if (v.size() > 1) n->set_base_cells(integer32("--noise", v[1], 1));
  if (v.size() > 2) n->set_seed(integer32("--noise", v[2]));
}

void size_flag(const std::string& value, v1::TextureOutput* o) {
  const auto [w, h] = extent("--size", value, 1);
  o->set_width(w);
  o->set_height(h);
}

bool texture_flag(const std::string& flag, const std::string& value, v1::AdvectTextureRequest& r) {
  auto* t = r.mutable_texture();
  if (flag == "--noise")
    noise_flag(value, t->mutable_noise());
  else if (flag == "--spin")
    t->mutable_noise()->set_spin(number(flag, value, "rad/s")), t->mutable_noise()->set_time_varying(true);
  else if (flag == "--image")
    image_flag(flag, value, t->mutable_image());
  else if (flag == "--final")
    t->set_final_function(named(flag, value, kFinals));
  else if (flag == "--scale")
    t->set_scale(number(flag, value, "periods per du"));
  else
    return false;
  return true;
}

bool output_flag(const std::string& flag, const std::string& value, v1::AdvectTextureRequest& r) {
  auto* o = r.mutable_output();
  if (flag == "--size") {
    size_flag(value, o);
  } else if (flag == "--region") {
    auto v = numbers(flag, value, {4});
    auto* region = o->mutable_region();
    region->set_x0(v[0]), region->set_y0(v[1]), region->set_x1(v[2]), region->set_y1(v[3]);
  } else if (flag == "--planes") {
    o->clear_planes();
    for (const std::string& name : items(flag, value)) o->add_planes(named(flag, name, kPlanes));
  } else {
    return false;
  }
  return true;
}

void apply(const std::string& flag, const std::string& value, Advect& a) {
  v1::AdvectTextureRequest& r = a.request;
  if (flag == "--method")
    r.set_method(named(flag, value, kMethods));
  else if (flag == "--velocity" && value.rfind("ewave:", 0) == 0)
    r.mutable_velocity()->set_ewave_session(value.substr(6));
  else if (flag == "--velocity" && value.rfind("river:", 0) == 0)
    *r.mutable_velocity()->mutable_river() = river_file(flag, value.substr(6));
  else if (flag == "--velocity")
    velocity_flag(value, r.mutable_velocity()->mutable_named());
  else if (flag == "--frames")
    r.set_frames(integer32(flag, value, 1));
  else if (flag == "--dt")
    r.set_dt(number(flag, value, "s"));
  else if (flag == "--d")
    r.mutable_lagrangian()->set_d(number(flag, value, "du"));
  else if (flag == "--seed")
    r.set_seed(integer(flag, value));
  else if (flag == "--out" || flag == "-o")
    a.out = value;
  else if (!texture_flag(flag, value, r) && !output_flag(flag, value, r))
    throw UsageError("unknown flag " + flag);
  a.flags.emplace_back(flag, value);
}

Advect parse(const std::vector<std::string>& args) {
  Advect a;
  auto* v = a.request.mutable_velocity()->mutable_named();
  v->set_kind(v1::AnalyticVelocity::KIND_UNIFORM);
  v->set_velocity_x(0.1);
  a.request.mutable_output()->set_width(256);
  a.request.mutable_output()->set_height(256);
  a.request.set_frames(30);
  for (size_t i = 1; i < args.size(); i += 2) {
    if (i + 1 >= args.size()) throw UsageError(args[i] + " needs a value (or is unknown)");
    apply(args[i], args[i + 1], a);
  }
  if (a.out.empty()) throw UsageError("--out DIR is required");
  const auto method = a.request.method();
  if (method != v1::TEXTURE_METHOD_UNSPECIFIED && method != v1::TEXTURE_METHOD_LAGRANGIAN_GRIDS) {
    const std::string name =
        std::find_if(kMethods.begin(), kMethods.end(), [&](const auto& m) { return m.second == method; })->first;
    if (given(a.flags, "--d"))
      throw UsageError("--d is the Lagrangian grids' Poisson radius: not a flag of --method " + name);
    if (given(a.flags, "--seed"))
      throw UsageError("--seed places the Lagrangian grids: not a flag of --method " + name);
  }
  if (given(a.flags, "--image") && (given(a.flags, "--noise") || given(a.flags, "--spin")))
    throw UsageError("--image is the texture: --noise and --spin are flags of a noise texture");
  return a;
}

// The request as text for the EXR header, its image bytes left out.
std::string describe(const v1::AdvectTextureRequest& request) {
  v1::AdvectTextureRequest copy = request;
  if (copy.texture().has_image()) {
    auto* image = copy.mutable_texture()->mutable_image();
    for (auto& c : *image->mutable_channels()) c.clear_data();
    image->clear_png();
  }
  return copy.ShortDebugString();
}

// The first final plane (the one the preview shows), else the first plane.
const client::Channel& preview_channel(const client::Image& image) {
  for (const auto& c : image.channels)
    if (c.name == "final" || c.name.rfind("final_", 0) == 0) return c;
  return image.channels.front();
}

void write_frame(const Advect& a, const std::string& request_text, const v1::TextureFrame& frame) {
  client::Image image;
  for (const auto& f : frame.planes()) {
    image.nx = int(f.nx()), image.ny = int(f.ny());
    image.channels.push_back({f.name(), squall::field::decode(f, "frame.planes." + f.name())});
  }
  if (image.channels.empty()) throw std::runtime_error("frame " + std::to_string(frame.index()) + " has no planes");
  image.attributes.emplace_back("squall.request", request_text);
  for (const auto& [flag, value] : a.flags)
    image.attributes.emplace_back(attribute_name("squall.texture.advect", flag), value);
  client::add_time_attribute(image, frame.time());
  image.attributes.emplace_back("squall.frame", std::to_string(frame.index()));
  char name[32];
  std::snprintf(name, sizeof name, "/frame_%04u", frame.index());
  client::write_exr(a.out + name + ".exr", image);
  const client::Channel& preview = preview_channel(image);
  client::write_png_preview(a.out + name + ".png", image.nx, image.ny, preview.values);
}

int advect(client::Client& client, const Advect& a) {
  const OutputFolder folder(a.out);
  auto service = v1::Textures::NewStub(client.channel());
  // A texture that follows an eWave session names it (x-squall-session), so that a session-affine proxy
  // routes the stream to the replica holding that session.
  auto context = client.context(a.request.velocity().ewave_session(), double(a.request.frames()));
  auto reader = service->AdvectTexture(context.get(), a.request);
  const std::string request_text = describe(a.request);
  v1::TextureFrame frame;
  uint32_t written = 0;
  try {
    for (; reader->Read(&frame); ++written) write_frame(a, request_text, frame);
  } catch (const std::exception& e) {
    std::cerr << "squall texture: " << e.what() << "\n";
    context->TryCancel();
    reader->Finish();
    return kLocalError;
  }
  client::check(reader->Finish(), "Textures.AdvectTexture");
  std::cout << "wrote " << written << " frames to " << a.out << "\n";
  return kOk;
}

}  // namespace

int run(client::Client& client, const std::vector<std::string>& args) {
  static const std::string help = std::string(kHelp) + kRiverHelp + kDeformHelp;
  return run_verb("texture", help.c_str(), args, [&] {
    if (args[0] == "river") return river(client, args);
    if (args[0] == "deform") return deform(client, args);
    if (args[0] != "advect") throw UsageError("unknown texture command " + args[0] + " (advect, river, deform)");
    return advect(client, parse(args));
  });
}

}  // namespace squall::cli::texture
