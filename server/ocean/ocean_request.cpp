#include "ocean/ocean_request.h"

#include <cmath>
#include <sstream>

#include "common/error.h"
#include "ocean/float16.h"

namespace squall::ocean::rpc {
namespace {

namespace v1 = squall::v1;

constexpr int kMaxLayers = 8;

std::string text(double v) {
  std::ostringstream s;
  s.precision(9);
  s << v;
  return s.str();
}

// v must be finite and in the interval; open ends exclude the bound. Message:
// "tile.layers[0].wind_speed = -1: must be finite and in (0, 100]".
double check(const std::string& path, double v, double lo, double hi, bool lo_open, bool hi_open) {
  bool ok = std::isfinite(v) && (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi);
  if (!ok) {
    std::string range;
    if (std::isinf(lo) && std::isinf(hi)) range = "";
    else if (std::isinf(hi)) range = std::string(lo_open ? " and > " : " and >= ") + text(lo);
    else range = std::string(" and in ") + (lo_open ? "(" : "[") + text(lo) + ", " + text(hi) + (hi_open ? ")" : "]");
    fail(Code::InvalidArgument, path + " = " + text(v) + ": must be finite" + range);
  }
  return v;
}
constexpr double kInf = INFINITY;
double positive(const std::string& path, double v, double hi) { return check(path, v, 0, hi, true, false); }
double non_negative(const std::string& path, double v, double hi = kInf) { return check(path, v, 0, hi, false, false); }
double any_finite(const std::string& path, double v) { return check(path, v, -kInf, kInf, false, false); }

template <typename Enum>
[[noreturn]] void unknown(const std::string& path, Enum value, const char* type) {
  fail(Code::InvalidArgument, path + " = " + std::to_string(int(value)) + ": not a valid " + type +
                                  " (UNSPECIFIED and unknown values are rejected)");
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

PartialSpectrum partial(const v1::PartialSpectrum& p, const std::string& path) {
  PartialSpectrum out;
  out.peak_frequency = positive(path + ".peak_frequency", p.peak_frequency(), 100);
  out.significant_wave_height = positive(path + ".significant_wave_height", p.significant_wave_height(), 100);
  if (p.has_a()) out.a = non_negative(path + ".a", p.a(), 1e6);
  if (p.has_b()) out.b = non_negative(path + ".b", p.b(), 1e6);
  if (p.has_c()) out.c = non_negative(path + ".c", p.c(), 1e6);
  if (p.has_n()) out.n = positive(path + ".n", p.n(), 100);
  if (p.has_m()) out.m = positive(path + ".m", p.m(), 100);
  if (out.a == 0 && out.c == 0) fail(Code::InvalidArgument, path + ".a and " + path + ".c are both 0: the partial has no energy");
  return out;
}

void spectrum_parameters(const v1::LayerSpec& in, const std::string& path, LayerSpec& l) {
  // Multipeak needs no wind, unless its spreading model does (s of eq 34 depends on U).
  const bool multipeak = l.spectrum == SpectrumModel::Multipeak;
  const bool spreading_uses_wind = l.spreading == SpreadingModel::Mitsuyasu || l.spreading == SpreadingModel::Jonswap ||
                                   l.spreading == SpreadingModel::VonMises;
  l.wind_speed = check(path + ".wind_speed", in.wind_speed(), 0, 100, !multipeak || spreading_uses_wind, false);
  const bool fetch_used = l.spectrum == SpectrumModel::Jonswap || l.spectrum == SpectrumModel::ModifiedJonswap ||
                          l.spectrum == SpectrumModel::Tma;
  l.fetch = check(path + ".fetch", in.fetch(), 0, 1e8, fetch_used, false);
  if (!fetch_used && in.fetch() == 0) l.fetch = LayerSpec{}.fetch;  // ignored; keep the engine's valid default
  if (in.has_peak_enhancement()) l.gamma = check(path + ".peak_enhancement", in.peak_enhancement(), 1, 100, false, false);
  if (in.has_sigma_below_peak()) l.sigma_a = positive(path + ".sigma_below_peak", in.sigma_below_peak(), 10);
  if (in.has_sigma_above_peak()) l.sigma_b = positive(path + ".sigma_above_peak", in.sigma_above_peak(), 10);
  if (in.has_phillips_amplitude()) l.phillips_amplitude = non_negative(path + ".phillips_amplitude", in.phillips_amplitude());
  if (in.has_phillips_cutoff()) l.phillips_cutoff = non_negative(path + ".phillips_cutoff", in.phillips_cutoff());
  if (in.has_phillips_exponent()) l.phillips_exponent = non_negative(path + ".phillips_exponent", in.phillips_exponent(), 64);
  if (multipeak && (in.partials_size() < 1 || in.partials_size() > kMaxPartialSpectra))
    fail(Code::InvalidArgument, path + ".partials has " + std::to_string(in.partials_size()) +
                                    " entries: the MULTIPEAK spectrum needs 1 to " + std::to_string(kMaxPartialSpectra));
  if (!multipeak && in.partials_size() > 0)
    fail(Code::InvalidArgument, path + ".partials is only for SPECTRUM_MODEL_MULTIPEAK");
  for (int i = 0; i < in.partials_size(); ++i)
    l.partials.push_back(partial(in.partials(i), path + ".partials[" + std::to_string(i) + "]"));
}

void dispersion_parameters(const v1::LayerSpec& in, const std::string& path, LayerSpec& l) {
  l.dispersion = dispersion(path + ".dispersion", in.dispersion());
  const bool depth_used = l.dispersion == DispersionKind::Shallow || l.dispersion == DispersionKind::Combined ||
                          l.spectrum == SpectrumModel::Tma;
  l.depth = check(path + ".depth", in.depth(), 0, 1e5, depth_used, false);
  if (!depth_used && in.depth() == 0) l.depth = LayerSpec{}.depth;  // ignored; keep the engine's valid default
  l.capillary_length = non_negative(path + ".capillary_length", in.capillary_length(), 1);
  if (in.has_gravity()) l.gravity = positive(path + ".gravity", in.gravity(), 100);
}

LayerSpec layer(const v1::LayerSpec& in, const std::string& path, const LimitGate& gate) {
  LayerSpec l;
  l.lx = positive(path + ".extent_x", in.extent_x(), 1e6);
  l.ly = positive(path + ".extent_y", in.extent_y(), 1e6);
  gate.check_grid(path, in.nx(), in.ny());
  if (in.nx() % 2 || in.ny() % 2 || in.nx() < 2 || in.ny() < 2)
    fail(Code::InvalidArgument, path + ".nx, " + path + ".ny = " + std::to_string(in.nx()) + ", " +
                                    std::to_string(in.ny()) + ": each must be even and >= 2");
  l.nx = in.nx();
  l.ny = in.ny();
  l.spectrum = spectrum(path + ".spectrum", in.spectrum());
  if (l.spectrum != SpectrumModel::Phillips || in.spreading() != v1::SPREADING_MODEL_UNSPECIFIED)
    l.spreading = spreading(path + ".spreading", in.spreading());
  l.wind_direction = check(path + ".wind_direction", in.wind_direction(), -1e6, 1e6, false, false);
  spectrum_parameters(in, path, l);
  dispersion_parameters(in, path, l);
  l.k_min = non_negative(path + ".k_min", in.k_min());
  l.k_max = non_negative(path + ".k_max", in.k_max());
  if (l.k_max > 0 && l.k_max <= l.k_min)
    fail(Code::InvalidArgument, path + ".k_max = " + text(l.k_max) + ": must be 0 (no limit) or > " + path +
                                    ".k_min = " + text(l.k_min));
  l.seed = in.seed();
  l.drift_x = check(path + ".drift_x", in.drift_x(), -100, 100, false, false);
  l.drift_y = check(path + ".drift_y", in.drift_y(), -100, 100, false, false);
  return l;
}

// The grid (nx, ny) and the extent each default to the first layer's when left 0 and 0.
void output_grid_spec(const v1::OutputGrid& in, const std::string& path, const LimitGate& gate, TileSpec& t) {
  const bool grid = in.nx() != 0 || in.ny() != 0, extent = in.extent_x() != 0 || in.extent_y() != 0;
  if (!grid && !extent) return;
  const LayerSpec& first = t.layers.front();
  t.nx = first.nx, t.ny = first.ny, t.lx = first.lx, t.ly = first.ly;
  if (grid) {
    gate.check_grid(path, in.nx(), in.ny());
    t.nx = in.nx(), t.ny = in.ny();
  }
  if (extent) {
    t.lx = positive(path + ".extent_x", in.extent_x(), 1e6);
    t.ly = positive(path + ".extent_y", in.extent_y(), 1e6);
  }
}

}  // namespace

TileSpec tile_spec(const v1::TileSpec& tile, const LimitGate& gate, const std::string& path) {
  if (tile.layers_size() < 1 || tile.layers_size() > kMaxLayers)
    fail(Code::InvalidArgument, path + ".layers has " + std::to_string(tile.layers_size()) + " entries: must be 1 to " +
                                    std::to_string(kMaxLayers));
  TileSpec t;
  for (int i = 0; i < tile.layers_size(); ++i)
    t.layers.push_back(layer(tile.layers(i), path + ".layers[" + std::to_string(i) + "]", gate));
  t.b_correction = tile.b_correction();
  t.choppiness = check(path + ".choppiness", tile.choppiness(), -100, 100, false, false);
  output_grid_spec(tile.output(), path + ".output", gate, t);
  if (tile.has_whitecap_threshold()) t.whitecap_threshold = any_finite(path + ".whitecap_threshold", tile.whitecap_threshold());
  if (tile.has_whitecap_decay_time())
    t.whitecap_decay = positive(path + ".whitecap_decay_time", tile.whitecap_decay_time(), 1e9);
  if (tile.has_pixel_scale()) t.pixel_scale = positive(path + ".pixel_scale", tile.pixel_scale(), 1e6);
  if (tile.has_slope_k_max()) t.slope_k_max = positive(path + ".slope_k_max", tile.slope_k_max(), 1e9);
  return t;
}

std::vector<v1::TileOutput> outputs(const google::protobuf::RepeatedField<int>& in, const std::string& path) {
  if (in.empty()) fail(Code::InvalidArgument, path + " is empty: ask for at least one TileOutput");
  std::vector<v1::TileOutput> out;
  for (int i = 0; i < in.size(); ++i) {
    std::string item = path + "[" + std::to_string(i) + "]";
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

v1::DType dtype(v1::DType d, const std::string& path) {
  if (d == v1::DTYPE_UNSPECIFIED) return v1::DTYPE_FLOAT32;
  if (d == v1::DTYPE_FLOAT32 || d == v1::DTYPE_FLOAT16) return d;
  fail(Code::InvalidArgument, path + " = " + std::to_string(int(d)) + ": must be DTYPE_FLOAT32 or DTYPE_FLOAT16");
}

double finite_value(double v, const std::string& path) { return any_finite(path, v); }

void output_grid(const TileSpec& spec, int64_t* nx, int64_t* ny) {
  bool own = spec.nx > 0 && spec.ny > 0;
  *nx = own ? spec.nx : spec.layers.at(0).nx;
  *ny = own ? spec.ny : spec.layers.at(0).ny;
}

size_t bytes_per_value(v1::DType d) { return d == v1::DTYPE_FLOAT16 ? 2 : 4; }

namespace {

struct Selected {
  const std::vector<float>* values;
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
  const size_t n = size_t(tile.nx) * size_t(tile.ny);
  if (s.values->size() != n)
    fail(Code::Internal, std::string("engine returned ") + std::to_string(s.values->size()) + " values of " + s.name +
                             ", expected " + std::to_string(n));
  field->set_name(s.name);
  field->set_unit(s.unit);
  field->set_nx(uint32_t(tile.nx));
  field->set_ny(uint32_t(tile.ny));
  field->mutable_spacing()->set_x(tile.dx);
  field->mutable_spacing()->set_y(tile.dy);
  field->mutable_origin();  // (0, 0, 0)
  field->set_dtype(d);
  std::string* data = field->mutable_data();
  data->clear();
  if (d == v1::DTYPE_FLOAT16) {
    f16::append_half_bytes(s.values->data(), n, data);
  } else {
    data->assign(reinterpret_cast<const char*>(s.values->data()), n * sizeof(float));  // little-endian host
  }
}

}  // namespace squall::ocean::rpc
