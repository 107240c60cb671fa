#include "ocean/ocean_request.h"

#include "common/error.h"
#include "common/validate.h"
#include "ocean/spectrum_setup.h"
#include "common/field_codec.h"

namespace squall::ocean::rpc {
namespace {

namespace v1 = squall::v1;

using validate::Interval;

// Fields whose request names differ from the engine's are checked here, with the engine's ranges; every
// other range is checked once, by the engine (validate_tile), under the request's path.
double renamed(const std::string& path, double v, const Interval& range) { return validate::in(path, v, range); }

template <typename Enum>
[[noreturn]] void unknown(const std::string& path, Enum value, const char* type) {
  validate::reject(path, std::to_string(int(value)),
                   std::string("a valid ") + type + " (UNSPECIFIED and unknown values are rejected)");
}

SpectrumModel spectrum(const std::string& path, v1::SpectrumModel m) {
  switch (m) {
    case v1::SPECTRUM_MODEL_PHILLIPS: return SpectrumModel::Phillips;
    case v1::SPECTRUM_MODEL_PIERSON_MOSKOWITZ: return SpectrumModel::PiersonMoskowitz;
    case v1::SPECTRUM_MODEL_JONSWAP: return SpectrumModel::Jonswap;
    case v1::SPECTRUM_MODEL_MODIFIED_JONSWAP: return SpectrumModel::ModifiedJonswap;
    case v1::SPECTRUM_MODEL_TMA: return SpectrumModel::Tma;
    case v1::SPECTRUM_MODEL_MULTIPEAK: return SpectrumModel::Multipeak;
    default: unknown(path, m, "SpectrumModel");
  }
}

SpreadingModel spreading(const std::string& path, v1::SpreadingModel m) {
  switch (m) {
    case v1::SPREADING_MODEL_ISOTROPIC: return SpreadingModel::Isotropic;
    case v1::SPREADING_MODEL_PIERSON_COS2: return SpreadingModel::PiersonCos2;
    case v1::SPREADING_MODEL_KRYLOV: return SpreadingModel::Krylov;
    case v1::SPREADING_MODEL_MITSUYASU: return SpreadingModel::Mitsuyasu;
    case v1::SPREADING_MODEL_JONSWAP: return SpreadingModel::Jonswap;
    case v1::SPREADING_MODEL_VON_MISES: return SpreadingModel::VonMises;
    case v1::SPREADING_MODEL_HYPERBOLIC: return SpreadingModel::Hyperbolic;
    default: unknown(path, m, "SpreadingModel");
  }
}

DispersionKind dispersion(const std::string& path, v1::DispersionModel m) {
  switch (m) {
    case v1::DISPERSION_MODEL_DEEP: return DispersionKind::Deep;
    case v1::DISPERSION_MODEL_SHALLOW: return DispersionKind::Shallow;
    case v1::DISPERSION_MODEL_CAPILLARY: return DispersionKind::Capillary;
    case v1::DISPERSION_MODEL_COMBINED: return DispersionKind::Combined;
    default: unknown(path, m, "DispersionModel");
  }
}

PartialSpectrum partial(const v1::PartialSpectrum& p) {
  PartialSpectrum out;
  out.peak_frequency = p.peak_frequency();
  out.significant_wave_height = p.significant_wave_height();
  if (p.has_a()) out.a = p.a();
  if (p.has_b()) out.b = p.b();
  if (p.has_c()) out.c = p.c();
  if (p.has_n()) out.n = p.n();
  if (p.has_m()) out.m = p.m();
  return out;
}

void spectrum_parameters(const v1::LayerSpec& in, const std::string& path, LayerSpec& l) {
  l.wind_speed = in.wind_speed();
  const bool fetch_used = l.spectrum == SpectrumModel::Jonswap || l.spectrum == SpectrumModel::ModifiedJonswap ||
                          l.spectrum == SpectrumModel::Tma;
  l.fetch = in.fetch();
  if (!fetch_used && in.fetch() == 0) l.fetch = LayerSpec{}.fetch;  // ignored; keep the engine's valid default
  if (in.has_peak_enhancement())
    l.gamma = renamed(path + ".peak_enhancement", in.peak_enhancement(), kPeakEnhancementRange);
  if (in.has_sigma_below_peak())
    l.sigma_a = renamed(path + ".sigma_below_peak", in.sigma_below_peak(), kPeakWidthRange);
  if (in.has_sigma_above_peak())
    l.sigma_b = renamed(path + ".sigma_above_peak", in.sigma_above_peak(), kPeakWidthRange);
  if (in.has_phillips_amplitude()) l.phillips_amplitude = in.phillips_amplitude();
  if (in.has_phillips_cutoff()) l.phillips_cutoff = in.phillips_cutoff();
  if (in.has_phillips_exponent()) l.phillips_exponent = in.phillips_exponent();
  // A request's partials are an error with another spectrum (the engine would ignore them).
  if (l.spectrum != SpectrumModel::Multipeak && in.partials_size() > 0)
    fail(Code::InvalidArgument, path + ".partials is only for SPECTRUM_MODEL_MULTIPEAK");
  for (const auto& p : in.partials()) l.partials.push_back(partial(p));
}

void dispersion_parameters(const v1::LayerSpec& in, const std::string& path, LayerSpec& l) {
  l.dispersion = dispersion(path + ".dispersion", in.dispersion());
  const bool depth_used = l.dispersion == DispersionKind::Shallow || l.dispersion == DispersionKind::Combined ||
                          l.spectrum == SpectrumModel::Tma;
  l.depth = in.depth();
  if (!depth_used && in.depth() == 0) l.depth = LayerSpec{}.depth;  // ignored; keep the engine's valid default
  l.capillary_length = in.capillary_length();
  if (in.has_gravity()) l.gravity = in.gravity();
}

LayerSpec layer(const v1::LayerSpec& in, const std::string& path) {
  LayerSpec l;
  l.lx = renamed(path + ".extent_x", in.extent_x(), kExtentRange);
  l.ly = renamed(path + ".extent_y", in.extent_y(), kExtentRange);
  l.nx = in.nx();
  l.ny = in.ny();
  l.spectrum = spectrum(path + ".spectrum", in.spectrum());
  if (l.spectrum != SpectrumModel::Phillips || in.spreading() != v1::SPREADING_MODEL_UNSPECIFIED)
    l.spreading = spreading(path + ".spreading", in.spreading());
  l.wind_direction = in.wind_direction();
  spectrum_parameters(in, path, l);
  dispersion_parameters(in, path, l);
  l.k_min = in.k_min();
  l.k_max = in.k_max();
  l.seed = in.seed();
  l.drift_x = in.drift_x();
  l.drift_y = in.drift_y();
  return l;
}

// The grid (nx, ny) and the extent each default to the first layer's when left 0 and 0.
void output_grid_spec(const v1::OutputGrid& in, const std::string& path, TileSpec& t) {
  const bool grid = in.nx() != 0 || in.ny() != 0, extent = in.extent_x() != 0 || in.extent_y() != 0;
  if (!grid && !extent) return;
  const LayerSpec& first = t.layers.front();
  t.nx = first.nx, t.ny = first.ny, t.lx = first.lx, t.ly = first.ly;
  if (grid) t.nx = in.nx(), t.ny = in.ny();
  if (extent) {
    t.lx = renamed(path + ".extent_x", in.extent_x(), kExtentRange);
    t.ly = renamed(path + ".extent_y", in.extent_y(), kExtentRange);
  }
}

}  // namespace

TileSpec tile_spec(const v1::TileSpec& tile, const LimitGate& gate, const std::string& path) {
  TileSpec t;
  for (int i = 0; i < tile.layers_size(); ++i)
    t.layers.push_back(layer(tile.layers(i), validate::at(path + ".layers", i)));
  t.b_correction = tile.b_correction();
  t.choppiness = tile.choppiness();
  if (!t.layers.empty()) output_grid_spec(tile.output(), path + ".output", t);
  if (tile.has_whitecap_threshold()) t.whitecap_threshold = tile.whitecap_threshold();
  if (tile.has_whitecap_decay_time()) t.whitecap_decay = tile.whitecap_decay_time();
  // Present means a scale (> 0); the engine's 0 means "unset" (the output grid's spacing).
  if (tile.has_pixel_scale()) t.pixel_scale = validate::positive(path + ".pixel_scale", tile.pixel_scale(), 1e6);
  if (tile.has_slope_k_max()) t.slope_k_max = tile.slope_k_max();
  validate_tile(t, gate, path);
  return t;
}

std::vector<v1::TileOutput> outputs(const google::protobuf::RepeatedField<int>& in, const std::string& path) {
  if (in.empty()) fail(Code::InvalidArgument, path + " is empty: ask for at least one TileOutput");
  std::vector<v1::TileOutput> out;
  for (int i = 0; i < in.size(); ++i) {
    std::string item = validate::at(path, i);
    if (in[i] == v1::TILE_OUTPUT_UNSPECIFIED || !v1::TileOutput_IsValid(in[i])) unknown(item, in[i], "TileOutput");
    auto o = static_cast<v1::TileOutput>(in[i]);
    for (auto seen : out)
      if (seen == o) fail(Code::InvalidArgument, item + " = " + v1::TileOutput_Name(o) + " is asked for twice");
    out.push_back(o);
  }
  return out;
}

unsigned output_flags(const std::vector<v1::TileOutput>& outputs) {
  unsigned flags = 0;
  for (auto o : outputs) {
    switch (o) {
      case v1::TILE_OUTPUT_HEIGHT: flags |= Height; break;
      case v1::TILE_OUTPUT_DISPLACEMENT_X:
      case v1::TILE_OUTPUT_DISPLACEMENT_Y: flags |= Displacement; break;
      case v1::TILE_OUTPUT_SLOPE_X:
      case v1::TILE_OUTPUT_SLOPE_Y: flags |= Slopes; break;
      case v1::TILE_OUTPUT_NORMAL_X:
      case v1::TILE_OUTPUT_NORMAL_Y:
      case v1::TILE_OUTPUT_NORMAL_Z: flags |= Normals; break;
      case v1::TILE_OUTPUT_JACOBIAN:
      case v1::TILE_OUTPUT_JACOBIAN_MINUS:
      case v1::TILE_OUTPUT_JACOBIAN_PLUS: flags |= Jacobian; break;
      case v1::TILE_OUTPUT_WHITECAP: flags |= Whitecaps; break;
      default: break;
    }
  }
  return flags;
}

int output_plane(v1::TileOutput output) {
  static_assert(v1::TILE_OUTPUT_HEIGHT == 1 && v1::TILE_OUTPUT_NORMAL_Z == 8 && v1::TILE_OUTPUT_WHITECAP == 12,
                "TileOutput n is the n-th field of TileFields (kAllPlanes bit n - 1)");
  return int(output) - 1;
}

unsigned output_planes(const std::vector<v1::TileOutput>& outputs) {
  unsigned planes = 0;
  for (auto o : outputs) planes |= 1u << output_plane(o);
  return planes;
}

void output_grid(const TileSpec& spec, int64_t* nx, int64_t* ny) {
  bool own = spec.nx > 0 && spec.ny > 0;
  *nx = own ? spec.nx : spec.layers.at(0).nx;
  *ny = own ? spec.ny : spec.layers.at(0).ny;
}

namespace {

struct Selected {
  const FloatView* values;
  const char* name;
  const char* unit;
};

Selected select(const TileFields& f, v1::TileOutput o) {
  switch (o) {
    case v1::TILE_OUTPUT_HEIGHT: return {&f.height, "height", "m"};
    case v1::TILE_OUTPUT_DISPLACEMENT_X: return {&f.displacement_x, "displacement_x", "m"};
    case v1::TILE_OUTPUT_DISPLACEMENT_Y: return {&f.displacement_y, "displacement_y", "m"};
    case v1::TILE_OUTPUT_SLOPE_X: return {&f.slope_x, "slope_x", "1"};
    case v1::TILE_OUTPUT_SLOPE_Y: return {&f.slope_y, "slope_y", "1"};
    case v1::TILE_OUTPUT_NORMAL_X: return {&f.normal_x, "normal_x", "1"};
    case v1::TILE_OUTPUT_NORMAL_Y: return {&f.normal_y, "normal_y", "1"};
    case v1::TILE_OUTPUT_NORMAL_Z: return {&f.normal_z, "normal_z", "1"};
    case v1::TILE_OUTPUT_JACOBIAN: return {&f.jacobian, "jacobian", "1"};
    case v1::TILE_OUTPUT_JACOBIAN_MINUS: return {&f.jacobian_minus, "jacobian_minus", "1"};
    case v1::TILE_OUTPUT_JACOBIAN_PLUS: return {&f.jacobian_plus, "jacobian_plus", "1"};
    case v1::TILE_OUTPUT_WHITECAP: return {&f.whitecaps, "whitecap", "1"};
    default: fail(Code::Internal, "unknown TileOutput " + std::to_string(int(o)));
  }
}

}  // namespace

void fill_field(const TileFields& tile, v1::TileOutput output, v1::DType d, v1::Field* field) {
  Selected s = select(tile, output);
  const squall::field::Header header{s.name, s.unit, uint32_t(tile.nx), uint32_t(tile.ny), 0, d};
  squall::field::encode(header, s.values->data(), s.values->size(), field);
  field->mutable_spacing()->set_x(tile.dx);
  field->mutable_spacing()->set_y(tile.dy);
  field->mutable_origin();  // (0, 0, 0)
}

void fill_fields(const TileFields& tile, const std::vector<v1::TileOutput>& outputs, v1::DType dtype,
                 const Cancellation& cancel, google::protobuf::RepeatedPtrField<v1::Field>* fields) {
  for (size_t i = 0; i < outputs.size(); ++i) {
    if (cancel.requested()) Cancellation::stopped("outputs[" + std::to_string(i) + "]'s field");
    fill_field(tile, outputs[i], dtype, fields->Add());
  }
}

double sim_time(const std::string& path, double seconds) {
  return validate::in(path, seconds, validate::closed(-1e9, 1e9));
}

}  // namespace squall::ocean::rpc
