#include "client/ewave_cli.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <thread>

#include "client/cli.h"
#include "client/cli_flags.h"
#include "client/image_io.h"
#include "server/common/field_codec.h"
#include "squall/v1/ewave.grpc.pb.h"

namespace squall::cli::ewave {

const char* const kVerbUsage =
    "ewave wake ...    a hull moving through an eWave session (Run stream) -> EXR + PNG frames; "
    "`squall ewave help` lists the flags";

namespace {

namespace v1 = squall::v1;

const char* const kHelp = R"(usage:
  squall ewave wake [FLAGS] -o DIR
A hull (an obstruction that is also a height source S0 (1 - O); Tessendorf 2017, Gilligan, eq 75)
moves along +x through the middle of the grid at constant speed, one Run-stream step per frame; each
written frame is DIR/frame_NNNNN.exr (the requested fields as FLOAT channels, the parameters as
attributes) and DIR/frame_NNNNN.png (the height, or the first field asked without it, 8-bit grey).
  --speed V             hull speed, m/s (default 0.2)
  --hull NAME           ellipse | box | circle (default ellipse)
  --length L            hull length along the track, m (default 0.24; circle: the diameter)
  --beam B              hull width, m (default 0.08)
  --steps N             steps (frames) to run, >= 1 (default 200)
  --grid NXxNY          session grid (default 256x128)
  --spacing D           cell size, m (default 0.01)
  --dt S                time step, s (default: spacing / speed, one cell per step, at most the
                        session's longest step: the period of its shortest wave)
  --source-scale S0     m/s (default 1)
  --dispersion NAME     deep | shallow | capillary | combined (default deep)
  --depth H             m (shallow/combined)   --capillary-length L  m (capillary/combined)
  --trim-alpha A        edge taper exponent (default 0.05)
  --every K             write every K-th frame and the last (default 1)
  --outputs A,B,...     height displacement_x displacement_y normal_x normal_y normal_z phi (default height)
  --dtype float32|float16  transfer type (default float32); files are always 32-bit float
The Run stream's deadline is --timeout times the number of steps.
)";

const std::map<std::string, v1::EWaveOutput> kOutputs = {{"height", v1::EWAVE_OUTPUT_HEIGHT},
                                                         {"displacement_x", v1::EWAVE_OUTPUT_DISPLACEMENT_X},
                                                         {"displacement_y", v1::EWAVE_OUTPUT_DISPLACEMENT_Y},
                                                         {"normal_x", v1::EWAVE_OUTPUT_NORMAL_X},
                                                         {"normal_y", v1::EWAVE_OUTPUT_NORMAL_Y},
                                                         {"normal_z", v1::EWAVE_OUTPUT_NORMAL_Z},
                                                         {"phi", v1::EWAVE_OUTPUT_PHI}};

// --dt: seconds > 0 (unset: one cell per step).
double positive_dt(const std::string& flag, const std::string& value) {
  const double dt = number(flag, value, "s");
  if (!(dt > 0)) throw UsageError(flag + " " + value + ": must be > 0 s");
  return dt;
}

struct Wake {
  v1::EWaveConfig config;
  std::string hull = "ellipse";
  double speed = 0.2, length = 0.24, beam = 0.08, dt = 0;  // dt 0: one cell per step (--dt not given)
  uint64_t steps = 200, every = 1;
  std::vector<v1::EWaveOutput> outputs = {v1::EWAVE_OUTPUT_HEIGHT};
  v1::DType dtype = v1::DTYPE_FLOAT32;
  std::string out;
  std::vector<std::pair<std::string, std::string>> flags;  // as given, for the EXR attributes
};

void grid_flag(const std::string& value, v1::EWaveConfig& c) {
  size_t x = value.find_first_of("x,");
  if (x == std::string::npos || value.find_first_of("x,", x + 1) != std::string::npos)
    throw UsageError("--grid " + value + ": must be NXxNY");
  c.set_nx(integer32("--grid", value.substr(0, x), 1));
  c.set_ny(integer32("--grid", value.substr(x + 1), 1));
}

void apply(const std::string& flag, const std::string& value, Wake& w) {
  v1::EWaveConfig& c = w.config;
  if (flag == "--speed")
    w.speed = number(flag, value, "m/s");
  else if (flag == "--hull")
    w.hull = named(flag, value,
                   std::map<std::string, std::string>{{"ellipse", "ellipse"}, {"box", "box"}, {"circle", "circle"}});
  else if (flag == "--length")
    w.length = number(flag, value, "m");
  else if (flag == "--beam")
    w.beam = number(flag, value, "m");
  else if (flag == "--steps")
    w.steps = integer(flag, value, 1);
  else if (flag == "--grid")
    grid_flag(value, c);
  else if (flag == "--spacing")
    c.set_dx(number(flag, value, "m")), c.set_dy(c.dx());
  else if (flag == "--dt")
    w.dt = positive_dt(flag, value);
  else if (flag == "--source-scale")
    c.set_source_scale(number(flag, value, "m/s"));
  else if (flag == "--dispersion")
    c.set_dispersion(named(flag, value,
                           std::map<std::string, v1::DispersionModel>{{"deep", v1::DISPERSION_MODEL_DEEP},
                                                                      {"shallow", v1::DISPERSION_MODEL_SHALLOW},
                                                                      {"capillary", v1::DISPERSION_MODEL_CAPILLARY},
                                                                      {"combined", v1::DISPERSION_MODEL_COMBINED}}));
  else if (flag == "--depth")
    c.set_depth(number(flag, value, "m"));
  else if (flag == "--capillary-length")
    c.set_capillary_length(number(flag, value, "m"));
  else if (flag == "--trim-alpha")
    c.set_trim_alpha(number(flag, value, "1"));
  else if (flag == "--every")
    w.every = integer(flag, value, 1);
  else if (flag == "--dtype")
    w.dtype = named(flag, value,
                    std::map<std::string, v1::DType>{{"float32", v1::DTYPE_FLOAT32}, {"float16", v1::DTYPE_FLOAT16}});
  else if (flag == "--outputs") {
    w.outputs.clear();
    for (const std::string& name : items(flag, value)) w.outputs.push_back(named(flag, name, kOutputs));
  } else if (flag == "-o" || flag == "--output")
    w.out = value;
  else
    throw UsageError("unknown flag " + flag);
  w.flags.emplace_back(flag, value);
}

Wake parse(const std::vector<std::string>& args) {
  Wake w;
  w.config.set_nx(256), w.config.set_ny(128), w.config.set_dx(0.01), w.config.set_dy(0.01);
  w.config.set_source_scale(1.0);
  for (size_t i = 1; i < args.size(); i += 2) {
    if (i + 1 >= args.size()) throw UsageError(args[i] + " needs a value (or is unknown)");
    apply(args[i], args[i + 1], w);
  }
  if (w.out.empty()) throw UsageError("-o DIR is required");
  if (!(w.speed > 0)) throw UsageError("--speed must be > 0");
  if (w.hull == "circle" && given(w.flags, "--beam"))
    throw UsageError("--beam is not a flag of a circle hull: its size is --length, the diameter");
  return w;
}

// The hull at step n (after n + 1 steps of dt), starting 10% into the grid on its middle row.
v1::EWaveShape hull(const Wake& w, uint64_t n) {
  const double x = 0.1 * w.config.nx() * w.config.dx() + w.speed * w.dt * double(n + 1);
  const double y = 0.5 * w.config.ny() * w.config.dy();
  v1::EWaveShape s;
  if (w.hull == "circle") {
    auto* c = s.mutable_circle();
    c->set_center_x(x), c->set_center_y(y), c->set_radius(0.5 * w.length);
  } else if (w.hull == "box") {
    auto* b = s.mutable_box();
    b->set_center_x(x), b->set_center_y(y), b->set_half_length(0.5 * w.length), b->set_half_width(0.5 * w.beam);
  } else {
    auto* e = s.mutable_ellipse();
    e->set_center_x(x), e->set_center_y(y), e->set_semi_axis_a(0.5 * w.length), e->set_semi_axis_b(0.5 * w.beam);
  }
  return s;
}

void write_frame(const Wake& w, const v1::EWaveFrame& frame) {
  client::Image image;
  for (const auto& f : frame.fields()) {
    image.nx = int(f.nx()), image.ny = int(f.ny());
    image.channels.push_back({f.name(), squall::field::decode(f, "frame.fields." + f.name())});
    image.attributes.emplace_back(
        "squall.field." + f.name(),
        f.unit() + "; spacing " + std::to_string(f.spacing().x()) + " " + std::to_string(f.spacing().y()) + " m");
  }
  for (const auto& [flag, value] : w.flags)
    image.attributes.emplace_back(attribute_name("squall.ewave.wake", flag), value);
  client::add_time_attribute(image, frame.time().seconds());
  image.attributes.emplace_back("squall.step", std::to_string(frame.step()));
  char name[32];
  std::snprintf(name, sizeof name, "/frame_%05llu", static_cast<unsigned long long>(frame.step()));
  client::write_exr(w.out + name + ".exr", image);
  const auto height = std::find_if(image.channels.begin(), image.channels.end(),
                                   [](const client::Channel& c) { return c.name == "height"; });
  const auto& preview = height != image.channels.end() ? *height : image.channels.front();
  client::write_png_preview(w.out + name + ".png", image.nx, image.ny, preview.values);
}

// Streams the steps: a writer thread sends the requests (gRPC flow control holds it back when the
// server falls behind) while this thread reads the frames and writes the files.
int stream(client::Client& client, const Wake& w, const std::string& id, v1::EWave::Stub& stub) {
  auto context = client.context(id, double(w.steps));
  auto call = stub.Run(context.get());
  std::thread writer([&] {
    v1::EWaveStepRequest request;
    request.set_session_id(id);
    auto* in = request.mutable_inputs();
    in->set_dt(w.dt);
    in->set_dtype(w.dtype);
    for (auto o : w.outputs) in->add_outputs(o);
    for (uint64_t n = 0; n < w.steps; ++n) {
      in->clear_shapes();
      *in->add_shapes() = hull(w, n);
      if (!call->Write(request)) break;
    }
    call->WritesDone();
  });
  v1::EWaveFrame frame;
  uint64_t read = 0, written = 0;
  int rc = kOk;
  try {
    while (call->Read(&frame)) {
      ++read;
      if (read % w.every == 0 || read == w.steps) write_frame(w, frame), ++written;
    }
  } catch (const std::exception& e) {
    std::cerr << "squall: " << e.what() << "\n";
    context->TryCancel();
    rc = kLocalError;
  }
  writer.join();
  grpc::Status status = call->Finish();
  if (rc != kOk) return rc;
  client::check(status, "EWave.Run");
  std::cout << "wrote " << written << " frames of " << read << " steps to " << w.out << "\n";
  return kOk;
}

int wake(client::Client& client, const Wake& w) {
  const OutputFolder folder(w.out);
  auto stub = v1::EWave::NewStub(client.channel());
  v1::EWaveCreateSessionRequest create;
  *create.mutable_config() = w.config;
  v1::EWaveSessionResponse session;
  auto close = [&](const std::unique_ptr<grpc::ClientContext>& context, const std::string& id) {
    v1::EWaveSessionRequest request;
    request.set_session_id(id);
    v1::EWaveCloseResponse closed;
    return stub->CloseSession(context.get(), request, &closed);
  };
  auto make = [&](const std::string& proposed) {
    return stub->CreateSession(client.context(proposed).get(), create, &session);
  };
  auto undo = [&](const std::string& proposed) { return close(client.undo_context(proposed), proposed); };
  std::string id;
  client::check(client::create_session("", make, undo, &id), "EWave.CreateSession");
  Wake run = w;  // default dt: one cell per step, within the session's longest step
  if (run.dt == 0) run.dt = std::min(run.config.dx() / run.speed, session.max_dt());
  int rc = kOk;
  try {
    rc = stream(client, run, session.session_id(), *stub);
  } catch (...) {
    close(client.context(id), session.session_id());
    throw;
  }
  client::check(close(client.context(id), session.session_id()), "EWave.CloseSession");
  return rc;
}

}  // namespace

int run(client::Client& client, const std::vector<std::string>& args) {
  return run_verb("ewave", kHelp, args, [&] {
    if (args[0] != "wake") throw UsageError("unknown ewave command " + args[0] + " (wake)");
    return wake(client, parse(args));
  });
}

}  // namespace squall::cli::ewave
