#include "textures/textures_request.h"

#include <png.h>

#include <algorithm>
#include <cstring>
#include <vector>

#include "common/error.h"
#include "common/field_codec.h"
#include "common/validate.h"
#include "ocean/ocean_engine.h"
#include "ocean/ocean_request.h"
#include "textures/texture_engine.h"

namespace squall::textures::rpc {
namespace v1 = squall::v1;
using validate::at;
using validate::known;

namespace {

// ---- Velocity ----

// A named analytic parameter: its proto field, its slot in fields.h's params[], and whether the field
// divides by it (then it must be > 0, not only finite).
struct Named {
  const char* field;
  int param;
  double value;
  bool divisor = false;
};

int velocity_kind(int kind, const std::string& path) {
  known(path, kind, 9, "AnalyticVelocity.Kind");
  constexpr int kKinds[] = {SQUALL_VELOCITY_UNIFORM,      SQUALL_VELOCITY_UNIFORM, SQUALL_VELOCITY_ROTATION,
                            SQUALL_VELOCITY_SHEAR,        SQUALL_VELOCITY_SINK,    SQUALL_VELOCITY_VORTEX,
                            SQUALL_VELOCITY_TAYLOR_GREEN, SQUALL_VELOCITY_CHANNEL, SQUALL_VELOCITY_CYLINDER};
  return kKinds[kind];
}

// The fields a kind reads, in the params[] order of fields.h.
std::vector<Named> named_params(const v1::AnalyticVelocity& a, int kind) {
  const double cx = a.has_center() ? a.center().x() : 0.5, cy = a.has_center() ? a.center().y() : 0.5;
  const double y0 = a.has_y0() ? a.y0() : 0.5;
  switch (kind) {
    case SQUALL_VELOCITY_ROTATION:
      return {{"angular_velocity", 0, a.angular_velocity()}, {"center.x", 1, cx}, {"center.y", 2, cy}};
    case SQUALL_VELOCITY_SHEAR: return {{"shear_rate", 0, a.shear_rate()}, {"y0", 1, y0}};
    case SQUALL_VELOCITY_SINK:
      return {{"speed", 0, a.speed()},
              {"center.x", 1, cx},
              {"center.y", 2, cy},
              {"epsilon", 3, a.has_epsilon() ? a.epsilon() : 0.05, true}};
    case SQUALL_VELOCITY_VORTEX:
      return {{"circulation", 0, a.circulation()},
              {"center.x", 1, cx},
              {"center.y", 2, cy},
              {"core_radius", 3, a.has_core_radius() ? a.core_radius() : 0.1, true}};
    case SQUALL_VELOCITY_TAYLOR_GREEN:
      return {{"speed", 0, a.speed()}, {"period", 1, a.has_period() ? a.period() : 1.0, true}};
    case SQUALL_VELOCITY_CHANNEL:
      return {
          {"speed", 0, a.speed()}, {"y0", 1, y0}, {"half_width", 2, a.has_half_width() ? a.half_width() : 0.5, true}};
    case SQUALL_VELOCITY_CYLINDER:
      return {{"speed", 0, a.speed()},
              {"center.x", 1, cx},
              {"center.y", 2, cy},
              {"radius", 3, a.has_radius() ? a.radius() : 0.1, true}};
    default: return {{"velocity_x", 0, a.velocity_x()}, {"velocity_y", 1, a.velocity_y()}};
  }
}

VelocitySpec analytic(const v1::AnalyticVelocity& a, const std::string& path) {
  VelocitySpec v;
  v.kind = velocity_kind(a.kind(), path + ".kind");
  for (const Named& n : named_params(a, v.kind)) {
    const std::string field = path + "." + n.field;
    const double lo = n.divisor ? kMinVelocityDivisor : -kMaxVelocityParam;
    v.params[n.param] = validate::in(field, n.value, validate::closed(lo, kMaxVelocityParam));
  }
  return v;
}

// A Field that must be an nx x ny plane, decoded.
std::vector<float> plane(const v1::Field& f, const std::string& path, uint32_t nx, uint32_t ny, const char* owner) {
  if (f.nx() != nx)
    validate::reject(path + ".nx", double(f.nx()), std::string(owner) + "'s nx = " + std::to_string(nx));
  if (f.ny() != ny)
    validate::reject(path + ".ny", double(f.ny()), std::string(owner) + "'s ny = " + std::to_string(ny));
  if (f.nz() > 1) validate::reject(path + ".nz", double(f.nz()), "0 or 1 (a 2D field)");
  return field::decode(f, path);
}

Extrapolation extrapolation(int e, const std::string& path) {
  known(path, e, 4, "VelocityGrid.Extrapolation");
  if (e == v1::VelocityGrid::EXTRAPOLATION_ZERO) return Extrapolation::Zero;
  if (e == v1::VelocityGrid::EXTRAPOLATION_PUSH_PULL) return Extrapolation::PushPull;
  return Extrapolation::Clamp;
}

VelocitySpec grid(const v1::VelocityGrid& g, const std::string& path) {
  VelocitySpec v;
  v.kind = SQUALL_VELOCITY_GRID;
  // Its size first, as sent: the frames' and the mask's fields are checked against it.
  v.nx = int(validate::in(path + ".nx", int64_t(g.nx()), 2, kMaxGridSide));
  v.ny = int(validate::in(path + ".ny", int64_t(g.ny()), 2, kMaxGridSide));
  v.origin_x = validate::finite(path + ".origin.x", g.origin().x());
  v.origin_y = validate::finite(path + ".origin.y", g.origin().y());
  v.hx = validate::positive(path + ".spacing.x", g.spacing().x());
  v.hy = validate::positive(path + ".spacing.y", g.spacing().y());
  for (int f = 0; f < g.frames_size(); ++f) {
    const auto& frame = g.frames(f);
    const std::string fpath = at(path + ".frames", size_t(f));
    v.frames.push_back({frame.time(), plane(frame.u(), fpath + ".u", g.nx(), g.ny(), "the grid"),
                        plane(frame.v(), fpath + ".v", g.nx(), g.ny(), "the grid")});
  }
  v.extrapolation = extrapolation(g.extrapolation(), path + ".extrapolation");
  if (g.has_mask()) {
    const std::vector<float> mask = plane(g.mask(), path + ".mask", g.nx(), g.ny(), "the grid");
    validate::each(path + ".mask", mask.data(), mask.size());  // finite; nonzero = fluid
    for (float m : mask) v.mask.push_back(m != 0);
  }
  return v;
}

VelocitySpec velocity(const v1::VelocitySpec& v, const std::string& path) {
  if (v.has_grid()) return grid(v.grid(), path + ".grid");
  if (v.field_case() == v1::VelocitySpec::kEwaveSession || v.has_ocean() || v.has_river()) {
    VelocitySpec current;
    current.kind = SQUALL_VELOCITY_GRID;  // its frames come from the engine that computes it
    return current;
  }
  return analytic(v.named(), path + ".named");
}

// ---- Texture ----

// libpng reads the PNG from the request's bytes; its errors jump back to the setjmp of the stage that
// called it, whose frame holds no C++ object.
struct PngSource {
  const std::string* bytes;
  size_t offset;
};

void png_read_bytes(png_structp png, png_bytep out, png_size_t n) {
  auto* source = static_cast<PngSource*>(png_get_io_ptr(png));
  if (n > source->bytes->size() - source->offset) png_error(png, "truncated");
  std::memcpy(out, source->bytes->data() + source->offset, n);
  source->offset += n;
}

[[noreturn]] void png_fail(png_structp png, png_const_charp) { png_longjmp(png, 1); }
void png_warn(png_structp, png_const_charp) {}

struct PngHeader {
  png_uint_32 width = 0, height = 0;
  int channels = 0, depth = 0;
};

// Reads the header and asks for 8- or 16-bit samples, 1 to 4 per pixel (palette expanded to RGB,
// transparency to alpha).
bool png_header(png_structp png, png_infop info, PngHeader* header) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_info(png, info);
  png_set_expand(png);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  header->width = png_get_image_width(png, info);
  header->height = png_get_image_height(png, info);
  header->channels = png_get_channels(png, info);
  header->depth = png_get_bit_depth(png, info);
  return true;
}

bool png_rows(png_structp png, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_image(png, rows);
  png_read_end(png, nullptr);
  return true;
}

struct PngReader {
  png_structp png = nullptr;
  png_infop info = nullptr;
  ~PngReader() { png_destroy_read_struct(&png, info ? &info : nullptr, nullptr); }
};

// The PNG's channels as planes of values in [0, 1], row j of the file as texture row j.
void png_image(const std::string& bytes, LimitGate& gate, Slot& decoded, const std::string& path, TextureSpec& out) {
  if (bytes.size() < 8 || png_sig_cmp(reinterpret_cast<png_const_bytep>(bytes.data()), 0, 8) != 0)
    fail(Code::InvalidArgument, path + " is not a PNG file (" + std::to_string(bytes.size()) + " bytes)");
  PngReader reader;
  PngSource source{&bytes, 0};
  reader.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, png_fail, png_warn);
  if (reader.png) reader.info = png_create_info_struct(reader.png);
  if (!reader.png || !reader.info) fail(Code::Internal, "libpng could not start reading " + path);
  png_set_read_fn(reader.png, &source, png_read_bytes);
  // libpng's own limit (a million pixels a side) would call a larger image unreadable: the PNG format's
  // limit lets the header through, and --max-grid-cells judges it.
  png_set_user_limits(reader.png, 0x7fffffff, 0x7fffffff);
  PngHeader h;
  if (!png_header(reader.png, reader.info, &h)) fail(Code::InvalidArgument, path + " is not a readable PNG file");
  gate.check_grid(path + " width", path + " height", int64_t(h.width), int64_t(h.height));
  // A few kB of PNG may decode to gigabytes: held before they are allocated, so that concurrent calls are
  // refused rather than killed by the kernel's OOM killer. The samples are given back once converted.
  const size_t row_bytes = size_t(h.width) * h.channels * (h.depth / 8);
  const uint64_t sample_bytes = uint64_t(row_bytes) * h.height;
  decoded = gate.acquire_memory(path + " decoded (its samples, then as floats)",
                                sample_bytes + uint64_t(h.width) * h.height * h.channels * sizeof(float));
  std::vector<png_byte> pixels(row_bytes * h.height);
  std::vector<png_bytep> rows(h.height);
  for (size_t j = 0; j < h.height; ++j) rows[j] = pixels.data() + j * row_bytes;
  if (!png_rows(reader.png, rows.data())) fail(Code::InvalidArgument, path + " is a damaged PNG file");
  out.width = int(h.width);
  out.height = int(h.height);
  out.channels = h.channels;
  const size_t n = size_t(h.width) * h.height;
  out.pixels.assign(n * h.channels, 0);
  for (size_t k = 0; k < n * h.channels; ++k) {
    const size_t c = k % h.channels, pixel = k / h.channels;
    out.pixels[c * n + pixel] =
        h.depth == 16 ? float((pixels[2 * k] << 8 | pixels[2 * k + 1]) / 65535.0) : float(pixels[k] / 255.0);
  }
  std::vector<png_byte>().swap(pixels);
  decoded.give_back(sample_bytes);
}

// 8-bit interleaved pixels as planes of byte / 255.
void pixels8_image(const v1::Pixels8& p, LimitGate& gate, Slot& decoded, const std::string& path, TextureSpec& out) {
  gate.check_grid(path + ".width", path + ".height", int64_t(p.width()), int64_t(p.height()));
  validate::in(path + ".width", int64_t(p.width()), 1, int64_t(1) << 30);
  validate::in(path + ".height", int64_t(p.height()), 1, int64_t(1) << 30);
  validate::in(path + ".channels", int64_t(p.channels()), 1, SQUALL_TEXTURE_MAX_CHANNELS);
  const size_t pixels = size_t(p.width()) * p.height();
  validate::count(path + ".data", p.data().size(), pixels * p.channels(), "width x height x channels bytes");
  decoded = gate.acquire_memory(path + " as floats", uint64_t(pixels) * p.channels() * sizeof(float));
  out.width = int(p.width());
  out.height = int(p.height());
  out.channels = int(p.channels());
  out.pixels.resize(pixels * p.channels());
  const auto* bytes = reinterpret_cast<const unsigned char*>(p.data().data());
  for (size_t k = 0; k < pixels; ++k)
    for (int c = 0; c < out.channels; ++c) out.pixels[c * pixels + k] = float(bytes[k * out.channels + c]) / 255.0f;
}

void image(const v1::ImageTexture& im, LimitGate& gate, Slot& decoded, const std::string& path, TextureSpec& out) {
  out.kind = SQUALL_TEXTURE_IMAGE;
  const int sources = (im.channels_size() > 0) + !im.png().empty() + im.has_pixels8();
  if (sources != 1)
    fail(Code::InvalidArgument,
         path + " has " + std::to_string(sources) + " of channels, png and pixels8; send exactly one of them");
  if (!im.png().empty()) return png_image(im.png(), gate, decoded, path + ".png", out);
  if (im.has_pixels8()) return pixels8_image(im.pixels8(), gate, decoded, path + ".pixels8", out);
  const uint32_t nx = im.channels(0).nx(), ny = im.channels(0).ny();
  // Their number, size and floats' memory before any plane is decoded.
  validate::in(path + ".channels", int64_t(im.channels_size()), 1, SQUALL_TEXTURE_MAX_CHANNELS);
  gate.check_grid(at(path + ".channels", 0), nx, ny);
  const size_t values = size_t(nx) * ny * im.channels_size();
  decoded = gate.acquire_memory(path + ".channels as floats", uint64_t(values) * sizeof(float));
  out.pixels.reserve(values);
  out.width = int(nx);
  out.height = int(ny);
  out.channels = im.channels_size();
  for (int c = 0; c < im.channels_size(); ++c) {
    const std::string cpath = at(path + ".channels", size_t(c));
    std::vector<float> values = plane(im.channels(c), cpath, nx, ny, "channels[0]");
    validate::each(cpath, values.data(), values.size(), validate::closed(-kMaxTextureValue, kMaxTextureValue));
    out.pixels.insert(out.pixels.end(), values.begin(), values.end());
  }
}

void noise(const v1::NoiseTexture& n, const std::string& path, TextureSpec& out) {
  out.kind = SQUALL_TEXTURE_NOISE;
  out.bands = n.has_bands() ? n.bands() : 4;
  out.base_cells = n.has_base_cells() ? double(n.base_cells()) : 4.0;
  out.time_varying = n.time_varying();
  if (n.has_spin() && !n.time_varying())
    validate::reject(path + ".spin", n.spin(), "unset: time_varying is false (a still texture)");
  out.spin = n.time_varying() ? (n.has_spin() ? n.spin() : 1.0) : 0.0;
  out.seed = n.has_seed() ? n.seed() : 1;
}

int final_function(int f, const std::string& path) {
  known(path, f, 6, "FinalFunction");
  constexpr int kFunctions[] = {SQUALL_FINAL_IDENTITY,   SQUALL_FINAL_IDENTITY, SQUALL_FINAL_SUM_BANDS,
                                SQUALL_FINAL_TURBULENCE, SQUALL_FINAL_RIDGED,   SQUALL_FINAL_LUT};
  return kFunctions[f];
}

// The LUT's band shaping g: SUM_BANDS, TURBULENCE or RIDGED (UNSPECIFIED: RIDGED, as in LTA11 sec. 3.2).
int band_shape(int f, const std::string& path) {
  const int shape = f == v1::FINAL_FUNCTION_UNSPECIFIED ? SQUALL_FINAL_RIDGED : final_function(f, path);
  if (shape == SQUALL_FINAL_IDENTITY || shape == SQUALL_FINAL_LUT)
    validate::reject(path, double(f), "FINAL_FUNCTION_SUM_BANDS, _TURBULENCE or _RIDGED");
  return shape;
}

// The LUT's scalar field: nx x ny node values placed by origin and spacing.
ScalarGridSpec scalar_grid(const v1::ScalarGrid& g, const std::string& path) {
  ScalarGridSpec out;
  out.nx = int(validate::in(path + ".nx", int64_t(g.nx()), 2, kMaxGridSide));
  out.ny = int(validate::in(path + ".ny", int64_t(g.ny()), 2, kMaxGridSide));
  out.origin_x = validate::finite(path + ".origin.x", g.origin().x());
  out.origin_y = validate::finite(path + ".origin.y", g.origin().y());
  out.hx = validate::positive(path + ".spacing.x", g.spacing().x());
  out.hy = validate::positive(path + ".spacing.y", g.spacing().y());
  out.values = plane(g.values(), path + ".values", g.nx(), g.ny(), "the grid");
  return out;
}

FinalLookupSpec lookup(const v1::FinalLookup& l, const std::string& path) {
  FinalLookupSpec out;
  if (l.has_field()) out.field = scalar_grid(l.field(), path + ".field");
  out.channels = l.has_channels() ? l.channels() : 1;
  out.table.assign(l.table().begin(), l.table().end());
  out.lut_min = l.lut_min();
  out.lut_max = l.has_lut_max() ? l.lut_max() : 1.0;
  out.band_shape = band_shape(l.band_shape(), path + ".band_shape");
  return out;
}

TextureSpec texture(const v1::TextureSource& t, LimitGate& gate, Slot& decoded, const std::string& path) {
  TextureSpec out;
  if (t.has_image())
    image(t.image(), gate, decoded, path + ".image", out);
  else
    noise(t.noise(), path + ".noise", out);
  out.scale = t.has_scale() ? t.scale() : 4.0;
  out.final_function = final_function(t.final_function(), path + ".final_function");
  out.final_scale = t.has_final_scale() ? t.final_scale() : 1.0;
  if (out.final_function == SQUALL_FINAL_LUT) out.lut = lookup(t.lut(), path + ".lut");
  return out;
}

// ---- Output, methods ----

OutputSpec output(const v1::TextureOutput& o, const LimitGate& gate, const std::string& path) {
  OutputSpec out;
  gate.check_grid(path + ".width", path + ".height", int64_t(o.width()), int64_t(o.height()));  // as sent
  out.width = int(validate::in(path + ".width", int64_t(o.width()), 1, 1 << 30));
  out.height = int(validate::in(path + ".height", int64_t(o.height()), 1, 1 << 30));
  if (!o.has_region()) return out;  // the unit square
  const auto& r = o.region();
  out.x0 = validate::finite(path + ".region.x0", r.x0());
  out.y0 = validate::finite(path + ".region.y0", r.y0());
  out.x1 = validate::in(path + ".region.x1", r.x1(), validate::above(r.x0()));
  out.y1 = validate::in(path + ".region.y1", r.y1(), validate::above(r.y0()));
  return out;
}

Method method(int m, const std::string& path) {
  known(path, m, 5, "TextureMethod");
  switch (m) {
    case v1::TEXTURE_METHOD_EULERIAN_MULTILAYER: return Method::EulerianMultilayer;
    case v1::TEXTURE_METHOD_TWO_PHASE_FLOW_MAP: return Method::TwoPhaseFlowMap;
    case v1::TEXTURE_METHOD_NAIVE: return Method::Naive;
    default: return Method::LagrangianGrids;
  }
}

LagrangianParams lagrangian(const v1::LagrangianParams& p, const std::string& path) {
  LagrangianParams out;  // texture_spec.h's defaults, the ones textures.proto publishes
  if (p.has_d()) out.d = p.d();
  if (p.has_alpha()) out.alpha = p.alpha();
  if (p.has_beta()) out.beta = p.beta();
  if (p.has_grid_res()) out.grid_res = p.grid_res();
  if (p.has_delta_max()) out.delta_max = p.delta_max();
  if (p.has_fade_tau()) out.fade_tau = p.fade_tau();
  known(path + ".blend", p.blend(), 3, "LagrangianParams.Blend");
  if (p.blend() == v1::LagrangianParams::BLEND_NORMALIZED) out.blend = Blend::Normalized;
  known(path + ".patch_origin", p.patch_origin(), 3, "LagrangianParams.PatchOrigin");
  if (p.patch_origin() == v1::LagrangianParams::PATCH_ORIGIN_WINDOW) out.patch_origin = PatchOrigin::Window;
  return out;
}

// Unset: off (c_w = 0) with texture_spec.h's time constants; ranges are checked by TextureEngine::validate.
VorticityCascade cascade(const v1::VorticityCascade& c) {
  VorticityCascade out;
  out.c_w = c.c_w();
  if (c.has_tau()) out.tau = c.tau();
  if (c.has_tau_ratio()) out.tau_ratio = c.tau_ratio();
  return out;
}

EulerianParams eulerian(const v1::EulerianParams& p, Method method, const std::string& path) {
  EulerianParams out;  // texture_spec.h's defaults
  if (p.latencies_size())
    out.latencies.assign(p.latencies().begin(), p.latencies().end());
  else if (method != Method::EulerianMultilayer)
    out.latencies = {1.0};  // the flow map's one layer
  if (p.has_phases()) out.phases = p.phases();
  known(path + ".weight", p.weight(), 3, "EulerianParams.PhaseWeight");
  if (p.weight() == v1::EulerianParams::PHASE_WEIGHT_TRIANGLE) out.weight = PhaseWeight::Triangle;
  if (p.has_d_star()) out.d_star = p.d_star();
  known(path + ".deformation", p.deformation(), 3, "EulerianParams.DeformationSum");
  if (p.deformation() == v1::EulerianParams::DEFORMATION_SUM_PAPER) out.deformation = DeformationSum::Paper;
  known(path + ".blend", p.blend(), 4, "EulerianParams.Blend");
  if (p.blend() == v1::EulerianParams::BLEND_FINAL) out.blend = EulerianBlend::Final;
  if (p.blend() == v1::EulerianParams::BLEND_OCTAVE_VARIANCE_PRESERVING)
    out.blend = EulerianBlend::OctaveVariancePreserving;
  if (p.has_grid_nx()) out.grid_nx = p.grid_nx();
  if (p.has_grid_ny()) out.grid_ny = p.grid_ny();
  out.cascade = cascade(p.cascade());
  out.random_offset = p.random_offset();
  return out;
}

// ---- Frames ----

int64_t texture_channels(const TextureSpec& t) { return t.kind == SQUALL_TEXTURE_IMAGE ? t.channels : t.bands; }

void fill_stats(const FrameStats& s, v1::FrameStats* out) {
  for (double m : s.mean) out->add_mean(m);
  for (double d : s.stddev) out->add_stddev(d);
  out->set_uncovered_pixels(s.uncovered);
  const ParticleStats& p = s.particles;
  auto* q = out->mutable_particles();
  q->set_alive(p.alive);
  q->set_fading(p.fading);
  q->set_born(p.born);
  q->set_killed_coverage(p.killed_coverage);
  q->set_killed_quality(p.killed_quality);
  q->set_killed_fold(p.killed_fold);
  q->set_killed_density(p.killed_density);
  q->set_deleted(p.deleted);
  q->set_min_quality(p.min_quality);
  q->set_max_distortion(p.max_distortion);
  for (const auto& [stage, ms] : s.stage_ms) {
    auto* timing = out->add_stages();
    timing->set_stage(stage);
    timing->set_milliseconds(ms);
  }
}

}  // namespace

TextureSpec image_texture(const v1::ImageTexture& im, LimitGate& gate, Slot& decoded, const std::string& path) {
  TextureSpec t;
  image(im, gate, decoded, path, t);
  return t;
}

std::vector<float> image_plane(const v1::Field& f, const std::string& path, uint32_t nx, uint32_t ny) {
  return plane(f, path, nx, ny, "the texture");
}

AdvectSpec spec(const v1::AdvectTextureRequest& r, LimitGate& gate, Slot& decoded, const std::string& path) {
  AdvectSpec s;
  s.method = method(r.method(), path + ".method");
  s.velocity = velocity(r.velocity(), path + ".velocity");
  s.texture = texture(r.texture(), gate, decoded, path + ".texture");
  s.output = output(r.output(), gate, path + ".output");
  s.t0 = r.t0();
  s.dt = r.has_dt() ? r.dt() : 1.0 / 30;
  s.frames = r.frames();
  s.substeps = r.has_substeps() ? r.substeps() : 1;
  s.seed = r.has_seed() ? r.seed() : 1;
  s.lagrangian = lagrangian(r.lagrangian(), path + ".lagrangian");
  s.eulerian = eulerian(r.eulerian(), s.method, path + ".eulerian");
  return s;
}

FollowedCurrent followed(const v1::VelocitySpec& velocity, const LimitGate& gate, const std::string& path) {
  FollowedCurrent current;
  if (velocity.field_case() == v1::VelocitySpec::kEwaveSession) {
    current.path = path + ".ewave_session";
    if (velocity.ewave_session().empty()) fail(Code::InvalidArgument, current.path + " is empty: pass a session id");
    current.ewave_session = velocity.ewave_session();
  } else if (velocity.has_ocean()) {
    current.path = path + ".ocean";
    current.ocean = ocean::rpc::tile_spec(velocity.ocean(), gate, current.path);
    ocean::validate_current(*current.ocean, gate, current.path);
  }
  return current;
}

AdvectSpec interactive_start(const v1::TextureControl& control, LimitGate& gate, Slot& decoded,
                             const std::string& path) {
  if (!control.has_start())
    fail(Code::InvalidArgument, path + ".start is unset: the first message starts the advection");
  const v1::AdvectTextureRequest& start = control.start();
  const std::string start_path = path + ".start";
  if (start.frames() != 0)
    validate::reject(start_path + ".frames", start.frames(), "0 (each message asks for its frames)");
  if (start.checkpoint_every() != 0)
    validate::reject(start_path + ".checkpoint_every", start.checkpoint_every(),
                     "0 (interactive streams carry no checkpoints)");
  if (!start.resume_state().empty())
    fail(Code::InvalidArgument, start_path + ".resume_state is set: interactive streams do not resume checkpoints");
  AdvectSpec s = spec(start, gate, decoded, start_path);
  s.frames = 1;  // per message (control_frames)
  return s;
}

uint32_t control_frames(const v1::TextureControl& control, const std::string& path) {
  if (!control.has_frames()) return 1;
  return uint32_t(validate::in(path + ".frames", int64_t(control.frames()), 0, kMaxControlFrames));
}

bool steer(const v1::TextureControl& control, AdvectSpec& s, const std::string& path) {
  if (control.has_velocity()) s.velocity = velocity(control.velocity(), path + ".velocity");
  // Checked here as well as by TextureEngine::validate, so that the first message's steering is named as
  // the message's own field, not the start's.
  if (control.has_dt()) s.dt = validate::positive(path + ".dt", control.dt(), kMaxTextureDt);
  if (control.has_substeps())
    s.substeps = int(validate::in(path + ".substeps", int64_t(control.substeps()), 1, kMaxTextureSubsteps));
  if (control.has_final_scale())
    s.texture.final_scale =
        validate::in(path + ".final_scale", control.final_scale(), validate::closed(-kMaxFinalScale, kMaxFinalScale));
  if (control.has_spin()) {
    if (s.texture.kind != SQUALL_TEXTURE_NOISE)
      validate::reject(path + ".spin", control.spin(), "unset: the texture is an image, not flow noise");
    if (!s.texture.time_varying)
      validate::reject(path + ".spin", control.spin(),
                       "unset: the noise is still (time_varying false), not flow noise");
    s.texture.spin = validate::in(path + ".spin", control.spin(), validate::closed(-kMaxSpin, kMaxSpin));
  }
  return control.has_velocity() || control.has_dt() || control.has_substeps() || control.has_final_scale() ||
         control.has_spin();
}

PlaneSelection planes(const v1::TextureOutput& o, const std::string& path) {
  PlaneSelection p;
  p.dtype = field::dtype(o.dtype(), path + ".dtype");
  if (o.planes_size() == 0) return p;
  p.final_planes = false;
  for (int i = 0; i < o.planes_size(); ++i) {
    switch (known(at(path + ".planes", size_t(i)), o.planes(i), 8, "TexturePlane")) {
      case v1::TEXTURE_PLANE_RAW: p.raw_planes = true; break;
      case v1::TEXTURE_PLANE_WEIGHT_SUM: p.weight_sum = true; break;
      case v1::TEXTURE_PLANE_WEIGHT_SQ_SUM: p.weight_sq_sum = true; break;
      case v1::TEXTURE_PLANE_COVERAGE: p.coverage = true; break;
      case v1::TEXTURE_PLANE_LAYER: p.layer = true; break;
      case v1::TEXTURE_PLANE_UV: p.uv = true; break;
      default: p.final_planes = true; break;
    }
  }
  return p;
}

uint64_t frame_bytes(const AdvectSpec& spec, const PlaneSelection& p) {
  const uint64_t channels = uint64_t(std::max<int64_t>(0, texture_channels(spec.texture)));
  const int function = spec.texture.final_function;
  const uint64_t finals = function == SQUALL_FINAL_IDENTITY ? channels
                          : function == SQUALL_FINAL_LUT    ? uint64_t(std::max<int64_t>(0, spec.texture.lut.channels))
                                                            : 1;
  const uint64_t planes = (p.final_planes ? finals : 0) + (p.raw_planes ? channels : 0) + p.weight_sum +
                          p.weight_sq_sum + p.coverage + p.layer + 2 * p.uv;
  return planes * uint64_t(spec.output.width) * uint64_t(spec.output.height) * field::bytes_per_value(p.dtype);
}

uint64_t stream_bytes(const AdvectSpec& spec, uint64_t frame_bytes) {
  const PlaneSelection computed{true, true, true, true, true, true, true, v1::DTYPE_FLOAT32};
  return 2 * rpc::frame_bytes(spec, computed) + 2 * frame_bytes + TextureEngine::state_bytes(spec) +
         TextureEngine::input_bytes(spec);
}

void fill_frame(const TextureFrame& f, const AdvectSpec& spec, const PlaneSelection& p, v1::TextureFrame* out) {
  out->set_index(uint32_t(f.index));
  out->set_time(f.time);
  const OutputSpec& o = spec.output;
  const double px = (o.x1 - o.x0) / f.width, py = (o.y1 - o.y0) / f.height;
  const size_t n = size_t(f.width) * f.height;
  auto add = [&](const std::string& name, int k) {
    v1::Field* field = out->add_planes();
    field::encode({name, "1", uint32_t(f.width), uint32_t(f.height), 0, p.dtype}, f.plane(k), n, field);
    field->mutable_spacing()->set_x(px);
    field->mutable_spacing()->set_y(py);
    field->mutable_origin()->set_x(o.x0 + 0.5 * px);
    field->mutable_origin()->set_y(o.y0 + 0.5 * py);
  };
  if (p.final_planes)
    for (int c = 0; c < f.final_planes; ++c) add(f.final_planes == 1 ? "final" : "final_" + std::to_string(c), c);
  if (p.raw_planes)
    for (int c = 0; c < f.raw_planes; ++c) add("raw_" + std::to_string(c), f.final_planes + c);
  const int aux = f.final_planes + f.raw_planes;
  if (p.weight_sum) add("weight_sum", aux);
  if (p.weight_sq_sum) add("weight_sq_sum", aux + 1);
  if (p.coverage) add("coverage", aux + 2);
  if (p.layer) add("layer", aux + 3);
  if (p.uv) add("uv_x", aux + 4), add("uv_y", aux + 5);
  fill_stats(f.stats, out->mutable_stats());
}

}  // namespace squall::textures::rpc
