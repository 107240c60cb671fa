// `squall texture deform`: content-aware deformation of a texture (Textures.DeformTexture) -> EXR + PNG frames.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>

#include "client/cli.h"
#include "client/cli_flags.h"
#include "client/image_io.h"
#include "client/texture_cli_flags.h"
#include "client/texture_verbs.h"
#include "server/common/field_codec.h"
#include "squall/v1/textures.grpc.pb.h"

namespace squall::cli::texture {

const char* const kDeformHelp = R"(
  squall texture deform --image FILE --rigidity FILE.exr|VALUE [FLAGS] --out DIR
Content-aware deformation (Guingo, Larue, Sauvage, Lutz, Dischler, Cani, "Content-aware texture
deformation with dynamic control", Computers & Graphics 2020): a flow field v is solved from the rigidity
map R (div v = R, least squares), then every texel's warp moves along v by its d mu each frame; for d mu > 0
the pattern shrinks where R > 0 (rigid) and stretches where R < 0. Each frame is DIR/frame_NNNN.exr (every
returned plane, the frame's time as squall.time_seconds) and DIR/frame_NNNN.png (the first returned plane:
color_0 unless --planes leaves it out).
  --image FILE           the texture: .exr (R, G, B, A first, at most 8 channels) or .png
  --rigidity FILE|R      R in [-1, 1]: an .exr (its first channel, the texture's size) or one value
  --chart FILE.exr       nonzero inside the chart (first channel); texels outside stay fixed
  --control KIND:ARGS    (default constant:0.1)
      constant:DMU                    d mu per frame, every texel
      map:FILE.exr                    d mu per texel (first channel), times --kappa
      isotropic:XX,XY,YX,YY           the surface's deformation gradient at the last frame (identity at
                                      frame 0): d mu = kappa (|A_now| - |A_before|) (eq. 7)
      anisotropic:XX,XY,YX,YY         the same, d mu = kappa log(v^T T v / |v|^2) (eq. 8)
      brush:X,Y,RADIUS,STRENGTH[/...] Gaussian strokes (texels), every frame
  --kappa K              scale of d mu of map, isotropic and anisotropic (default 1)
  --frames N             frames, frame 0 the undeformed texture (default 30)
  --dt S                 seconds between frames (default 1/30)
  --substeps N           Euler sub-steps per frame (default 10)
  --stack L              resampling stack of 2 L + 1 levels (default 0: none)
  --planes A,B,...       color warp reference level flow (default color)
  --out DIR              output folder (created)
)";

namespace {

namespace v1 = squall::v1;

const std::map<std::string, v1::DeformPlane> kPlanes = {{"color", v1::DEFORM_PLANE_COLOR},
                                                        {"warp", v1::DEFORM_PLANE_WARP},
                                                        {"reference", v1::DEFORM_PLANE_REFERENCE},
                                                        {"level", v1::DEFORM_PLANE_LEVEL},
                                                        {"flow", v1::DEFORM_PLANE_FLOW}};

struct Deform {
  v1::DeformTextureRequest request;
  std::string out;
  std::string rigidity;  // a file or a value, resolved once the texture's size is known
};

// The first channel of an EXR file as a Field.
v1::Field exr_plane(const std::string& flag, const std::string& path) {
  v1::ImageTexture image;
  image_flag(flag, path, &image);
  if (image.channels_size() == 0) throw UsageError(flag + " " + path + ": must be an .exr file");
  return image.channels(0);
}

void tensor(const std::string& flag, const std::string& args, v1::Tensor2* t) {
  const std::vector<double> v = numbers(flag, args, {4});
  t->set_xx(v[0]), t->set_xy(v[1]), t->set_yx(v[2]), t->set_yy(v[3]);
}

void control_flag(const std::string& value, v1::DeformTextureRequest& r) {
  const std::string flag = "--control";
  const size_t colon = value.find(':');
  const std::string kind = value.substr(0, colon), args = colon == std::string::npos ? "" : value.substr(colon + 1);
  if (kind == "constant") {
    r.set_control(v1::DEFORM_CONTROL_CONSTANT), r.set_d_mu(numbers(flag, args, {1})[0]);
  } else if (kind == "map") {
    r.set_control(v1::DEFORM_CONTROL_MAP), *r.mutable_d_mu_map() = exr_plane(flag, args);
  } else if (kind == "isotropic" || kind == "anisotropic") {
    r.set_control(kind == "isotropic" ? v1::DEFORM_CONTROL_ISOTROPIC : v1::DEFORM_CONTROL_ANISOTROPIC);
    tensor(flag, args, r.mutable_deformation_end());
  } else if (kind == "brush") {
    r.set_control(v1::DEFORM_CONTROL_BRUSH);
    size_t start = 0;
    for (size_t end = 0; end != std::string::npos; start = end + 1) {
      end = args.find('/', start);
      const std::vector<double> v = numbers(flag, args.substr(start, end - start), {4});
      v1::BrushStroke* s = r.add_strokes();
      s->mutable_center()->set_x(v[0]), s->mutable_center()->set_y(v[1]);
      s->set_radius(v[2]), s->set_strength(v[3]);
    }
  } else {
    throw UsageError(flag + " " + value + ": constant, map, isotropic, anisotropic or brush (KIND:ARGS)");
  }
}

void apply(const std::string& flag, const std::string& value, Deform& d) {
  v1::DeformTextureRequest& r = d.request;
  if (flag == "--image")
    image_flag(flag, value, r.mutable_texture());
  else if (flag == "--rigidity")
    d.rigidity = value;
  else if (flag == "--chart")
    *r.mutable_chart() = exr_plane(flag, value);
  else if (flag == "--control")
    control_flag(value, r);
  else if (flag == "--kappa")
    r.set_kappa(number(flag, value, ""));
  else if (flag == "--frames")
    r.set_frames(integer32(flag, value, 1));
  else if (flag == "--dt")
    r.set_dt(number(flag, value, "s"));
  else if (flag == "--substeps")
    r.set_substeps(integer32(flag, value, 1));
  else if (flag == "--stack")
    r.set_stack_levels(integer32(flag, value));
  else if (flag == "--planes") {
    r.clear_planes();
    for (const std::string& name : items(flag, value)) r.add_planes(named(flag, name, kPlanes));
  } else if (flag == "--out" || flag == "-o")
    d.out = value;
  else
    throw UsageError("unknown flag " + flag);
}

// The texture's width and height: its first channel's, or the PNG header's (a PNG signature and its IHDR
// chunk first, as the PNG specification requires; 1 to 2^24 texels, whose constant rigidity map of 64 MiB
// is squalld's default --max-message-bytes, so that one of a forged header is refused rather than made).
std::pair<uint32_t, uint32_t> texture_size(const v1::ImageTexture& image) {
  if (image.channels_size() > 0) return {image.channels(0).nx(), image.channels(0).ny()};
  const std::string& png = image.png();
  auto be32 = [&](size_t at) {
    return uint32_t(uint8_t(png[at])) << 24 | uint32_t(uint8_t(png[at + 1])) << 16 |
           uint32_t(uint8_t(png[at + 2])) << 8 | uint32_t(uint8_t(png[at + 3]));
  };
  static const char kSignature[] = "\x89PNG\r\n\x1a\n";
  if (png.size() < 24 || png.compare(0, 8, kSignature, 8) != 0 || png.compare(12, 4, "IHDR") != 0)
    throw UsageError("--image: not a PNG file (no PNG signature and IHDR chunk)");
  const uint32_t width = be32(16), height = be32(20);
  if (width < 1 || height < 1 || double(width) * height > double(1 << 24))
    throw UsageError("--image: the PNG header says " + std::to_string(width) + " x " + std::to_string(height) +
                     " pixels: must be 1 to 2^24");
  return {width, height};
}

void rigidity(Deform& d) {
  if (d.rigidity.empty()) throw UsageError("--rigidity FILE.exr|VALUE is required");
  const auto ext = std::filesystem::path(d.rigidity).extension().string();
  if (ext == ".exr" || ext == ".EXR") return void(*d.request.mutable_rigidity() = exr_plane("--rigidity", d.rigidity));
  const double r = number("--rigidity", d.rigidity, "in [-1, 1], or an .exr file");
  const auto [nx, ny] = texture_size(d.request.texture());
  field::encode({"rigidity", "1", nx, ny, 0, v1::DTYPE_FLOAT32}, std::vector<float>(size_t(nx) * ny, float(r)),
                d.request.mutable_rigidity());
}

Deform parse(const std::vector<std::string>& args) {
  Deform d;
  d.request.set_frames(30);
  d.request.set_control(v1::DEFORM_CONTROL_CONSTANT);
  d.request.set_d_mu(0.1);
  for (size_t i = 1; i < args.size(); i += 2) {
    if (i + 1 >= args.size()) throw UsageError(args[i] + " needs a value (or is unknown)");
    apply(args[i], args[i + 1], d);
  }
  if (!d.request.has_texture()) throw UsageError("--image FILE is required");
  if (d.out.empty()) throw UsageError("--out DIR is required");
  const auto control = d.request.control();
  if (d.request.has_kappa() && (control == v1::DEFORM_CONTROL_CONSTANT || control == v1::DEFORM_CONTROL_BRUSH))
    throw UsageError("--kappa scales the d mu of --control map, isotropic and anisotropic: not a flag of " +
                     std::string(control == v1::DEFORM_CONTROL_BRUSH ? "brush" : "constant"));
  rigidity(d);
  return d;
}

void write_frame(const std::string& out, const v1::DeformFrame& frame) {
  client::Image image;
  for (const auto& f : frame.planes()) {
    image.nx = int(f.nx()), image.ny = int(f.ny());
    image.channels.push_back({f.name(), field::decode(f, "frame.planes." + f.name())});
  }
  if (image.channels.empty()) throw std::runtime_error("frame " + std::to_string(frame.index()) + " has no planes");
  image.attributes.emplace_back("squall.frame", std::to_string(frame.index()));
  client::add_time_attribute(image, frame.time());
  image.attributes.emplace_back("squall.deform.solver_residual", std::to_string(frame.solver_residual()));
  char name[32];
  std::snprintf(name, sizeof name, "/frame_%04u", frame.index());
  client::write_exr(out + name + ".exr", image);
  client::write_png_preview(out + name + ".png", image.nx, image.ny, image.channels.front().values);
}

}  // namespace

int deform(client::Client& client, const std::vector<std::string>& args) {
  const Deform d = parse(args);
  const OutputFolder folder(d.out);
  auto service = v1::Textures::NewStub(client.channel());
  auto context = client.context("", double(d.request.frames()));
  auto reader = service->DeformTexture(context.get(), d.request);
  v1::DeformFrame frame;
  uint32_t written = 0;
  try {
    for (; reader->Read(&frame); ++written) write_frame(d.out, frame);
  } catch (const std::exception& e) {
    std::cerr << "squall texture deform: " << e.what() << "\n";
    context->TryCancel();
    reader->Finish();
    return kLocalError;
  }
  client::check(reader->Finish(), "Textures.DeformTexture");
  std::cout << "flow solved in " << frame.solver_iterations() << " iterations (residual " << frame.solver_residual()
            << "); wrote " << written << " frames to " << d.out << "\n";
  return kOk;
}

}  // namespace squall::cli::texture
