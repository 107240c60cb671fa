#include "client/cloud_cli.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>

#include "client/cli.h"
#include "client/cli_flags.h"
#include "client/image_io.h"
#include "client/replacing_file.h"
#include "server/common/field_codec.h"
#include "squall/v1/clouds.grpc.pb.h"

namespace squall::cli::cloud {

const char* const kVerbUsage =
    "cloud build|render ...  sparse cloud volumes (.vdb) and ray-marched images (EXR + PNG); "
    "`squall cloud help` lists the flags";

namespace {

namespace v1 = squall::v1;

const char* const kHelp = R"(usage:
  squall cloud build  [MODEL FLAGS] [--keep] -o CLOUD.vdb
  squall cloud render (--volume ID | [MODEL FLAGS]) [RENDER FLAGS] -o IMAGE.exr [--preview FILE.png|none]
model flags (SI units; z is up):
  --voxel-size M            m (default 1)
  --skin M                  skin thickness of the density ramp, m (default 2 voxel sizes)
  --sphere X,Y,Z,R          a base sphere (repeatable)
  --ellipsoid X,Y,Z,RX,RY,RZ  a base ellipsoid (repeatable)
  --mesh FILE.obj           a closed triangle mesh (repeatable)
  --pyro LAYERS,AMP,FREQ[,GAMMA]  pyroclastic displacement: layers, amplitude m, noise frequency 1/m
  --particle X,Y,Z,R        a noise-stamped particle (repeatable)
  --advect SPEED,TIME[,SUBSTEPS[,sl|mm]]  noise-velocity advection, m/s and s
  --temperature T0,LAPSE    temperature field: K at z = 0, K/m
  --max-voxels N            active-voxel budget
render flags:
  --eye X,Y,Z  --look-at X,Y,Z  --up X,Y,Z   camera, m (default eye 0,-100,0 at the origin, up +z)
  --fov DEG                 vertical field of view (default 40)
  --size WxH                pixels (default 256x256)
  --step M                  ray-march step, m (default: 1)
  --wavelengths L1,L2,...   m (default 550e-9)
  --extinction K            1/m per unit density, for every wavelength (default 0.1)
  --albedo A                for every wavelength (default 0.9)
  --sun DX,DY,DZ,E          directional light, DX,DY,DZ pointing from the scene to it (DZ > 0: above the horizon),
                            irradiance E for every wavelength (repeatable)
  --lamp X,Y,Z,I            point light at X,Y,Z (m), intensity I W sr^-1 m^-1 for every wavelength; its irradiance
                            I / d^2 is held at its value at half a voxel within that distance (repeatable)
  --phase uniform|hg:G|dhg:G1,G2,W|ff:N,MU   (default hg:0.8)
  --shadow none|direct|dsm  (default dsm)
  --shadow-step M           step of the marches toward the lights, m (default: 3 steps)
  --shadow-trilinear        trilinear density on those marches (default nearest voxel)
  --trilinear               trilinear density (default nearest voxel)
  --min-transmittance T     primary and shadow marches end where the transmittance falls below T, in [0, 1)
                            (default 1e-4; vdb_render's -cutoff C ends them at sqrt(C / 3) in a grey medium)
)";

std::vector<double> numbers(const std::string& flag, const std::string& text, size_t min, size_t max) {
  const std::vector<double> out = number_list(flag, text);
  if (out.size() < min || out.size() > max)
    throw UsageError(flag + " " + text + ": needs " +
                     (min == max ? std::to_string(min) : std::to_string(min) + ".." + std::to_string(max)) +
                     (max == 1 ? " number" : " numbers"));
  return out;
}

// A count given among a flag's numbers (--pyro's layers, --advect's substeps): a whole number in [0, 2^32 - 1].
uint32_t count(const std::string& flag, const std::string& text, double v) {
  if (!(v >= 0 && v <= UINT32_MAX && v == std::floor(v)))
    throw UsageError(flag + " " + text + ": " + (std::ostringstream() << v).str() +
                     " is no count (a whole number >= 0)");
  return uint32_t(v);
}

void vec(const std::vector<double>& v, size_t at, v1::Vec3* out) {
  out->set_x(v[at]);
  out->set_y(v[at + 1]);
  out->set_z(v[at + 2]);
}

struct Request {
  v1::CloudModel model;
  v1::RenderSettings settings;
  std::string volume_id, output, preview;
  bool keep = false, has_shape = false;
  std::vector<std::string> model_flags, image_flags;  // as given: the model's, and those only render reads
};

bool model_flag(const std::string& flag, const std::string& value, Request& r) {
  auto& m = r.model;
  if (flag == "--voxel-size")
    m.set_voxel_size(numbers(flag, value, 1, 1)[0]);
  else if (flag == "--skin")
    m.set_skin(numbers(flag, value, 1, 1)[0]);
  else if (flag == "--sphere") {
    auto v = numbers(flag, value, 4, 4);
    auto* s = m.add_spheres();
    vec(v, 0, s->mutable_center());
    s->set_radius(v[3]);
  } else if (flag == "--ellipsoid") {
    auto v = numbers(flag, value, 6, 6);
    auto* e = m.add_ellipsoids();
    vec(v, 0, e->mutable_center());
    vec(v, 3, e->mutable_radii());
  } else if (flag == "--mesh")
    m.add_meshes()->set_obj(read_bytes(flag, value));
  else if (flag == "--pyro") {
    auto v = numbers(flag, value, 3, 4);
    auto* p = m.mutable_pyroclastic();
    p->set_layers(count(flag, value, v[0]));
    p->set_amplitude(v[1]);
    p->mutable_noise()->set_frequency(v[2]);
    if (v.size() == 4) p->set_gamma(v[3]);
  } else if (flag == "--particle") {
    auto v = numbers(flag, value, 4, 4);
    auto* p = m.add_particles();
    vec(v, 0, p->mutable_center());
    p->set_radius(v[3]);
  } else if (flag == "--advect") {
    std::string scheme;
    std::string nums = value;
    if (auto c = value.rfind(',');
        c != std::string::npos && (value.substr(c + 1) == "sl" || value.substr(c + 1) == "mm")) {
      scheme = value.substr(c + 1);
      nums = value.substr(0, c);
    }
    auto v = numbers(flag, nums, 2, 3);
    auto* a = m.mutable_advection();
    a->set_speed(v[0]);
    a->set_time(v[1]);
    if (v.size() == 3) a->set_substeps(count(flag, value, v[2]));
    a->set_scheme(scheme == "sl" ? v1::ADVECTION_SCHEME_SEMI_LAGRANGIAN : v1::ADVECTION_SCHEME_MODIFIED_MACCORMACK);
  } else if (flag == "--temperature") {
    auto v = numbers(flag, value, 2, 2);
    auto* t = m.mutable_temperature();
    t->set_enabled(true);
    t->set_surface(v[0]);
    t->set_lapse_rate(v[1]);
  } else if (flag == "--max-voxels")
    m.set_max_active_voxels(integer(flag, value, 1));
  else
    return false;
  if (flag == "--sphere" || flag == "--ellipsoid" || flag == "--mesh" || flag == "--particle") r.has_shape = true;
  return true;
}

bool render_flag(const std::string& flag, const std::string& value, Request& r) {
  auto& s = r.settings;
  auto* c = s.mutable_camera();
  if (flag == "--eye")
    vec(numbers(flag, value, 3, 3), 0, c->mutable_eye());
  else if (flag == "--look-at")
    vec(numbers(flag, value, 3, 3), 0, c->mutable_look_at());
  else if (flag == "--up")
    vec(numbers(flag, value, 3, 3), 0, c->mutable_up());
  else if (flag == "--fov")
    c->set_vertical_fov_deg(numbers(flag, value, 1, 1)[0]);
  else if (flag == "--size") {
    const auto [w, h] = extent(flag, value, 1);
    c->set_width(w);
    c->set_height(h);
  } else if (flag == "--step")
    s.set_step(numbers(flag, value, 1, 1)[0]);
  else if (flag == "--shadow-step")
    s.set_shadow_step(numbers(flag, value, 1, 1)[0]);
  else if (flag == "--min-transmittance")
    s.set_min_transmittance(numbers(flag, value, 1, 1)[0]);
  else if (flag == "--wavelengths") {
    s.clear_wavelengths();
    for (double l : numbers(flag, value, 1, 8)) s.add_wavelengths(l);
  } else if (flag == "--extinction")
    s.add_extinction(numbers(flag, value, 1, 1)[0]);
  else if (flag == "--albedo")
    s.add_albedo(numbers(flag, value, 1, 1)[0]);
  else if (flag == "--sun") {
    auto v = numbers(flag, value, 4, 4);
    auto* l = s.add_lights();
    l->set_kind(v1::LIGHT_KIND_DIRECTIONAL);
    vec(v, 0, l->mutable_direction());
    l->add_intensity(v[3]);  // expanded to every wavelength below
  } else if (flag == "--lamp") {
    auto v = numbers(flag, value, 4, 4);
    auto* l = s.add_lights();
    l->set_kind(v1::LIGHT_KIND_POINT);
    vec(v, 0, l->mutable_position());
    l->add_intensity(v[3]);  // as the sun's
  } else if (flag == "--phase") {
    auto* p = s.mutable_phase();
    auto colon = value.find(':');
    std::string kind = value.substr(0, colon), args = colon == std::string::npos ? "" : value.substr(colon + 1);
    const std::string usage = "--phase " + value + ": uniform, hg:G, dhg:G1,G2,W or ff:N,MU";
    if (kind == "uniform" ? colon != std::string::npos : args.empty()) throw UsageError(usage);
    auto parameters = [&](size_t n) {  // checked against the usage, which names the whole value
      std::vector<double> v = number_list(flag, args);
      if (v.size() != n) throw UsageError(usage);
      return v;
    };
    if (kind == "uniform")
      p->set_kind(v1::PHASE_KIND_UNIFORM);
    else if (kind == "hg") {
      p->set_kind(v1::PHASE_KIND_HENYEY_GREENSTEIN);
      p->set_g1(parameters(1)[0]);
    } else if (kind == "dhg") {
      auto v = parameters(3);
      p->set_kind(v1::PHASE_KIND_DOUBLE_HENYEY_GREENSTEIN);
      p->set_g1(v[0]);
      p->set_g2(v[1]);
      p->set_weight(v[2]);
    } else if (kind == "ff") {
      auto v = parameters(2);
      p->set_kind(v1::PHASE_KIND_FOURNIER_FORAND);
      p->set_ff_n(v[0]);
      p->set_ff_mu(v[1]);
    } else
      throw UsageError(usage);
  } else if (flag == "--shadow") {
    if (value == "none")
      s.set_shadow(v1::SHADOW_MODE_NONE);
    else if (value == "direct")
      s.set_shadow(v1::SHADOW_MODE_DIRECT);
    else if (value == "dsm")
      s.set_shadow(v1::SHADOW_MODE_DEEP_SHADOW_MAP);
    else
      throw UsageError("--shadow " + value + ": none, direct or dsm");
  } else
    return false;
  return true;
}

Request parse(const std::vector<std::string>& args) {
  Request r;
  r.model.set_voxel_size(1);
  auto* c = r.settings.mutable_camera();
  c->mutable_eye()->set_y(-100);
  c->mutable_up()->set_z(1);
  c->set_width(256);
  c->set_height(256);
  r.settings.set_step(1);
  r.settings.add_wavelengths(550e-9);
  for (size_t i = 1; i < args.size(); ++i) {
    const std::string& flag = args[i];
    if (flag == "--keep") {
      r.keep = true;
      continue;
    }
    if (flag == "--trilinear" || flag == "--shadow-trilinear") {
      if (flag == "--trilinear")
        r.settings.set_trilinear(true);
      else
        r.settings.set_shadow_trilinear(true);
      r.image_flags.push_back(flag);
      continue;
    }
    if (i + 1 >= args.size()) throw UsageError(flag + " needs a value (or is unknown)");
    const std::string& value = args[++i];
    if (flag == "-o") {
      r.output = value;
    } else if (flag == "--preview" || flag == "--volume") {
      (flag == "--preview" ? r.preview : r.volume_id) = value;
      r.image_flags.push_back(flag);
    } else if (model_flag(flag, value, r)) {
      r.model_flags.push_back(flag);
    } else if (render_flag(flag, value, r)) {
      r.image_flags.push_back(flag);
    } else {
      throw UsageError("unknown flag " + flag);
    }
  }
  // One extinction, albedo and light intensity for every wavelength.
  auto& s = r.settings;
  int nw = s.wavelengths_size();
  // The last --extinction and --albedo given.
  double k = s.extinction_size() ? *s.extinction().rbegin() : 0.1, a = s.albedo_size() ? *s.albedo().rbegin() : 0.9;
  s.clear_extinction();
  s.clear_albedo();
  for (int w = 0; w < nw; ++w) {
    s.add_extinction(k);
    s.add_albedo(a);
  }
  for (auto& l : *s.mutable_lights()) {
    double e = l.intensity(0);
    l.clear_intensity();
    for (int w = 0; w < nw; ++w) l.add_intensity(e);
  }
  if (r.output.empty()) throw UsageError("-o FILE is required");
  auto given = [&](const char* flag) {
    return std::find(r.image_flags.begin(), r.image_flags.end(), flag) != r.image_flags.end();
  };
  if (s.shadow() == v1::SHADOW_MODE_NONE && (given("--shadow-step") || given("--shadow-trilinear")))
    throw UsageError(
        "--shadow-step and --shadow-trilinear shape the marches toward the lights: not flags of "
        "--shadow none");
  return r;
}

using client::check;

void print_summary(const v1::VolumeSummary& s) {
  std::cout << (s.volume_id().empty() ? "" : "volume_id " + s.volume_id() + "\n") << "active voxels "
            << s.active_voxels() << ", " << s.bytes() << " bytes sparse vs " << s.dense_bytes() << " dense (ratio "
            << s.fill_ratio() << "), " << s.device_bytes() << " bytes on the device\n";
}

int build(client::Client& client, const Request& r) {
  auto stub = v1::Clouds::NewStub(client.channel());
  v1::BuildVolumeRequest request;
  *request.mutable_model() = r.model;
  request.set_keep(r.keep);
  request.set_return_vdb(true);
  v1::BuildVolumeResponse response;
  auto build = [&](const std::string& proposed) {
    return stub->BuildVolume(client.context(proposed).get(), request, &response);
  };
  auto release = [&](const std::string& proposed) {
    v1::ReleaseVolumeRequest volume;
    volume.set_volume_id(proposed);
    v1::ReleaseVolumeResponse released;
    return stub->ReleaseVolume(client.undo_context(proposed).get(), volume, &released);
  };
  std::string id;
  check(r.keep ? client::create_session("cloud-", build, release, &id) : build(""), "Clouds.BuildVolume");
  client::ReplacingFile file(r.output);
  std::ofstream out(file.temp(), std::ios::binary);
  out << response.vdb();
  out.close();  // a full disk shows here, not at the write
  if (out.fail() || !file.commit()) {
    std::cerr << "squall cloud: cannot write " << r.output
              << (response.summary().volume_id().empty()
                      ? ""
                      : " (the volume is kept: volume_id " + response.summary().volume_id() + ")")
              << "\n";
    return kLocalError;
  }
  print_summary(response.summary());
  return kOk;
}

int render(client::Client& client, const Request& r) {
  auto stub = v1::Clouds::NewStub(client.channel());
  auto context = client.context(r.volume_id);
  v1::RenderRequest request;
  if (!r.volume_id.empty())
    request.set_volume_id(r.volume_id);
  else
    *request.mutable_model() = r.model;
  *request.mutable_settings() = r.settings;
  v1::RenderResponse response;
  check(stub->Render(context.get(), request, &response), "Clouds.Render");
  const auto& img = response.image();
  client::Image image;
  image.nx = int(img.width());
  image.ny = int(img.height());
  size_t plane = size_t(img.width()) * img.height();
  const std::vector<float> values = squall::field::decode_bytes(
      img.data(), plane * img.channels_size(), v1::DTYPE_FLOAT32, "image.data", "width * height * channels");
  for (int c = 0; c < img.channels_size(); ++c)
    image.channels.push_back(
        {img.channels(c), std::vector<float>(values.begin() + c * plane, values.begin() + (c + 1) * plane)});
  try {
    const std::string preview = r.preview.empty() ? client::preview_beside(r.output) : r.preview;
    client::write_exr_and_preview(r.output, image, preview == "none" ? "" : preview, client::Tone::Radiance);
  } catch (const std::exception& e) {
    std::cerr << "squall cloud: " << e.what() << "\n";
    return kLocalError;
  }
  print_summary(response.summary());
  return kOk;
}

}  // namespace

int run(client::Client& client, const std::vector<std::string>& args) {
  return run_verb("cloud", kHelp, args, [&] {
    if (args[0] != "build" && args[0] != "render")
      throw UsageError("unknown cloud verb " + args[0] + " (build or render)");
    Request r = parse(args);
    if (args[0] == "build") {
      refuse_unused("cloud build", r.image_flags, {});  // it makes no image
      if (!r.has_shape) throw UsageError("build needs at least one --sphere, --ellipsoid, --mesh or --particle");
      require_extension(r.output, ".vdb", "an OpenVDB grid file");
      return build(client, r);
    }
    if (r.keep)
      throw UsageError("--keep is not a flag of `squall cloud render` (`cloud build --keep` stores a volume)");
    if (!r.volume_id.empty() && !r.model_flags.empty())
      throw UsageError(r.model_flags.front() + ": `cloud render --volume ID` renders the stored volume, not a model");
    if (r.volume_id.empty() && !r.has_shape) throw UsageError("render needs --volume ID or a model (--sphere ...)");
    require_extension(r.output, ".exr", "OpenEXR (its PNG preview beside it)");
    check_preview(r.output, r.preview);
    return render(client, r);
  });
}

}  // namespace squall::cli::cloud
