#include "client/ocean_cli_request.h"

#include <cctype>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "client/cli_flags.h"

namespace squall::cli::ocean {

const char* const kHelp = R"(usage:
  squall ocean tile   [LAYER FLAGS] [TILE FLAGS] [--time S] -o TILE.exr [--preview FILE.png|none]
  squall ocean stream [LAYER FLAGS] [TILE FLAGS] [--t0 S] --dt S --frames N -o DIR
  squall ocean sample [LAYER FLAGS] [TILE FLAGS] [--time S] --point X,Y ... | --points-file CSV
                      [--invert-displacement on|off]
layer flags (apply to the current layer; --add-layer starts another, a copy of the current one):
  --extent LX[,LY]          patch size, m (default 1000)
  --grid NX[,NY]            FFT grid, each even and >= 2, NX NY <= --max-grid-cells (default 256)
  --spectrum NAME           phillips | pierson-moskowitz | jonswap | modified-jonswap | tma | multipeak (default jonswap)
  --spreading NAME          none | isotropic | pierson-cos2 | krylov | mitsuyasu | jonswap | von-mises | hyperbolic
                            (default mitsuyasu; none only with phillips)
  --dispersion NAME         deep | shallow | capillary | combined (default deep)
  --wind-speed U            m/s, (0, 100] (default 10)
  --wind-direction THETA    rad, direction the wind blows towards (default 0 = +x)
  --fetch X                 m (JONSWAP, modified JONSWAP, TMA; default 100000)
  --depth H                 m (shallow/combined dispersion, TMA; default 100)
  --capillary-length L      m (capillary/combined dispersion; default 0.0027)
  --gamma G                 JONSWAP/TMA peak enhancement (default 3.3)
  --sigma SA,SB             JONSWAP/TMA peak widths below/above the peak (default 0.07,0.09)
  --phillips-amplitude A    m^2;  --phillips-cutoff L  m;  --phillips-exponent P
  --partial WP,HS           multipeak: add a partial spectrum with peak frequency WP rad/s and Hs m
  --gravity G               m/s^2 (default 9.81)
  --k-band KMIN,KMAX        rad/m: zero the modes outside (KMAX 0: no upper limit)
  --seed N                  random seed (default 1)
  --drift UX,UY             drift current, m/s (default 0,0)
tile flags:
  --choppiness LAMBDA       horizontal displacement scale; positive sharpens crests (default 1)
  --b-correction on|off     multi-layer spectrum correction (default off)
  --output-grid NX,NY       output samples (default: the first layer's grid)
  --output-extent LX,LY     output area, m (default: the first layer's extent)
  --whitecap-threshold J    J- below this marks whitecaps (default 0.3)
  --whitecap-decay-time T   s, e-folding time (default 4)
  --pixel-scale R           m, for the unresolved slope variance (default: the output cell size)
  --outputs A,B,...         height displacement_x displacement_y slope_x slope_y normal_x normal_y normal_z
                            jacobian jacobian_minus jacobian_plus whitecap
                            (default height,displacement_x,displacement_y,normal_x,normal_y,normal_z)
  --dtype float32|float16   transfer type (default float32); files are always 32-bit float
--outputs, --dtype and the output and whitecap flags are for tile and stream (they do not change samples).
The stream's deadline is --timeout times the number of frames.
)";

namespace {

namespace v1 = squall::v1;

// "A" or "A,B" (also "AxB"): two numbers, the second defaulting to the first.
std::pair<std::string, std::string> pair_of(const std::string& flag, const std::string& text) {
  const size_t at = text.find_first_of(",x");
  if (at == std::string::npos) return {text, text};
  if (text.find_first_of(",x", at + 1) != std::string::npos)
    throw UsageError(flag + " " + text + ": one value or two (A,B or AxB)");
  return {text.substr(0, at), text.substr(at + 1)};
}

bool on_off(const std::string& flag, const std::string& text) {
  if (text == "on" || text == "true" || text == "1") return true;
  if (text == "off" || text == "false" || text == "0") return false;
  throw UsageError(flag + " " + text + ": must be on or off");
}

const std::map<std::string, v1::SpectrumModel> kSpectra = {
    {"phillips", v1::SPECTRUM_MODEL_PHILLIPS}, {"pierson-moskowitz", v1::SPECTRUM_MODEL_PIERSON_MOSKOWITZ},
    {"jonswap", v1::SPECTRUM_MODEL_JONSWAP},   {"modified-jonswap", v1::SPECTRUM_MODEL_MODIFIED_JONSWAP},
    {"tma", v1::SPECTRUM_MODEL_TMA},           {"multipeak", v1::SPECTRUM_MODEL_MULTIPEAK}};
const std::map<std::string, v1::SpreadingModel> kSpreadings = {
    {"none", v1::SPREADING_MODEL_UNSPECIFIED},          {"isotropic", v1::SPREADING_MODEL_ISOTROPIC},
    {"pierson-cos2", v1::SPREADING_MODEL_PIERSON_COS2}, {"krylov", v1::SPREADING_MODEL_KRYLOV},
    {"mitsuyasu", v1::SPREADING_MODEL_MITSUYASU},       {"jonswap", v1::SPREADING_MODEL_JONSWAP},
    {"von-mises", v1::SPREADING_MODEL_VON_MISES},       {"hyperbolic", v1::SPREADING_MODEL_HYPERBOLIC}};
const std::map<std::string, v1::DispersionModel> kDispersions = {{"deep", v1::DISPERSION_MODEL_DEEP},
                                                                 {"shallow", v1::DISPERSION_MODEL_SHALLOW},
                                                                 {"capillary", v1::DISPERSION_MODEL_CAPILLARY},
                                                                 {"combined", v1::DISPERSION_MODEL_COMBINED}};
const std::map<std::string, v1::TileOutput> kOutputs = {{"height", v1::TILE_OUTPUT_HEIGHT},
                                                        {"displacement_x", v1::TILE_OUTPUT_DISPLACEMENT_X},
                                                        {"displacement_y", v1::TILE_OUTPUT_DISPLACEMENT_Y},
                                                        {"slope_x", v1::TILE_OUTPUT_SLOPE_X},
                                                        {"slope_y", v1::TILE_OUTPUT_SLOPE_Y},
                                                        {"normal_x", v1::TILE_OUTPUT_NORMAL_X},
                                                        {"normal_y", v1::TILE_OUTPUT_NORMAL_Y},
                                                        {"normal_z", v1::TILE_OUTPUT_NORMAL_Z},
                                                        {"jacobian", v1::TILE_OUTPUT_JACOBIAN},
                                                        {"jacobian_minus", v1::TILE_OUTPUT_JACOBIAN_MINUS},
                                                        {"jacobian_plus", v1::TILE_OUTPUT_JACOBIAN_PLUS},
                                                        {"whitecap", v1::TILE_OUTPUT_WHITECAP}};

v1::LayerSpec default_layer() {
  v1::LayerSpec l;
  l.set_extent_x(1000);
  l.set_extent_y(1000);
  l.set_nx(256);
  l.set_ny(256);
  l.set_spectrum(v1::SPECTRUM_MODEL_JONSWAP);
  l.set_spreading(v1::SPREADING_MODEL_MITSUYASU);
  l.set_dispersion(v1::DISPERSION_MODEL_DEEP);
  l.set_wind_speed(10);
  l.set_fetch(100000);
  l.set_depth(100);
  l.set_capillary_length(0.0027);
  l.set_seed(1);
  return l;
}

// Returns true when `flag` is a layer flag (and applies it to `layer`).
bool layer_flag(const std::string& flag, const std::string& value, v1::LayerSpec& l) {
  if (flag == "--extent") {
    auto [x, y] = pair_of(flag, value);
    l.set_extent_x(number(flag, x, "m"));
    l.set_extent_y(number(flag, y, "m"));
  } else if (flag == "--grid") {
    auto [x, y] = pair_of(flag, value);
    l.set_nx(integer32(flag, x));
    l.set_ny(integer32(flag, y));
  } else if (flag == "--spectrum") {
    l.set_spectrum(named(flag, value, kSpectra));
  } else if (flag == "--spreading") {
    l.set_spreading(named(flag, value, kSpreadings));
  } else if (flag == "--dispersion") {
    l.set_dispersion(named(flag, value, kDispersions));
  } else if (flag == "--wind-speed") {
    l.set_wind_speed(number(flag, value, "m/s"));
  } else if (flag == "--wind-direction") {
    l.set_wind_direction(number(flag, value, "rad"));
  } else if (flag == "--fetch") {
    l.set_fetch(number(flag, value, "m"));
  } else if (flag == "--depth") {
    l.set_depth(number(flag, value, "m"));
  } else if (flag == "--capillary-length") {
    l.set_capillary_length(number(flag, value, "m"));
  } else if (flag == "--gamma") {
    l.set_peak_enhancement(number(flag, value, "1"));
  } else if (flag == "--phillips-amplitude") {
    l.set_phillips_amplitude(number(flag, value, "m^2"));
  } else if (flag == "--phillips-cutoff") {
    l.set_phillips_cutoff(number(flag, value, "m"));
  } else if (flag == "--phillips-exponent") {
    l.set_phillips_exponent(number(flag, value, "1"));
  } else if (flag == "--sigma") {
    auto [a, b] = pair_of(flag, value);
    l.set_sigma_below_peak(number(flag, a, "1"));
    l.set_sigma_above_peak(number(flag, b, "1"));
  } else if (flag == "--partial") {
    auto [wp, hs] = pair_of(flag, value);
    auto* p = l.add_partials();
    p->set_peak_frequency(number(flag, wp, "rad/s"));
    p->set_significant_wave_height(number(flag, hs, "m"));
  } else if (flag == "--gravity") {
    l.set_gravity(number(flag, value, "m/s^2"));
  } else if (flag == "--k-band") {
    auto [lo, hi] = pair_of(flag, value);
    l.set_k_min(number(flag, lo, "rad/m"));
    l.set_k_max(number(flag, hi, "rad/m"));
  } else if (flag == "--seed") {
    l.set_seed(integer(flag, value));
  } else if (flag == "--drift") {
    auto [x, y] = pair_of(flag, value);
    l.set_drift_x(number(flag, x, "m/s"));
    l.set_drift_y(number(flag, y, "m/s"));
  } else {
    return false;
  }
  return true;
}

bool tile_flag(const std::string& flag, const std::string& value, Request& r) {
  v1::TileSpec& t = r.tile;
  if (flag == "--choppiness") {
    t.set_choppiness(number(flag, value, "1"));
  } else if (flag == "--b-correction") {
    t.set_b_correction(on_off(flag, value));
  } else if (flag == "--output-grid") {
    auto [x, y] = pair_of(flag, value);
    t.mutable_output()->set_nx(integer32(flag, x));
    t.mutable_output()->set_ny(integer32(flag, y));
  } else if (flag == "--output-extent") {
    auto [x, y] = pair_of(flag, value);
    t.mutable_output()->set_extent_x(number(flag, x, "m"));
    t.mutable_output()->set_extent_y(number(flag, y, "m"));
  } else if (flag == "--whitecap-threshold") {
    t.set_whitecap_threshold(number(flag, value, "1"));
  } else if (flag == "--whitecap-decay-time") {
    t.set_whitecap_decay_time(number(flag, value, "s"));
  } else if (flag == "--pixel-scale") {
    t.set_pixel_scale(number(flag, value, "m"));
  } else {
    return false;
  }
  return true;
}

// "X,Y" in metres (not pair_of's shorthand: one number is no point, and an x is no separator here).
std::pair<double, double> point(const std::string& flag, const std::string& text) {
  const std::vector<std::string> xy = items(flag, text);
  if (xy.size() != 2) throw UsageError(flag + " " + text + ": must be X,Y (m)");
  try {
    return {number(flag, xy[0], "m"), number(flag, xy[1], "m")};
  } catch (const UsageError&) {  // named whole
    throw UsageError(flag + " " + text + ": must be X,Y, two finite numbers (m)");
  }
}

// A CSV line that names its columns ("x,y"): it starts with a letter, and is no number (nan, inf, infinity).
bool is_header(const std::string& line) {
  if (line.empty() || !std::isalpha(static_cast<unsigned char>(line[0]))) return false;
  std::string word = line.substr(0, line.find(','));
  for (char& c : word) c = char(std::tolower(static_cast<unsigned char>(c)));
  return word != "nan" && word != "inf" && word != "infinity";
}

// X,Y lines; empty lines and # comments skipped, a header allowed before the first point, a UTF-8 byte order
// mark and CRLF line ends read.
void read_points_file(const std::string& path, Request& r) {
  const std::string text = read_bytes("--points-file", path);
  std::istringstream in(text.rfind("\xEF\xBB\xBF", 0) == 0 ? text.substr(3) : text);
  int line_number = 0;
  const size_t before = r.points.size();
  for (std::string line; std::getline(in, line);) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();  // CRLF
    if (line.empty() || line[0] == '#' || (r.points.size() == before && is_header(line))) continue;
    std::string where = "--points-file " + path + ":" + std::to_string(line_number);
    r.points.push_back(point(where, line));
  }
}

// The flags of what a verb sends beside the tile and what it writes: each verb reads some of them (kVerbFlags).
bool run_flag(const std::string& flag, const std::string& value, Request& r) {
  if (flag == "--outputs") {
    r.outputs.clear();
    for (const std::string& name : items(flag, value)) r.outputs.push_back(named(flag, name, kOutputs));
  } else if (flag == "--dtype") {
    r.dtype = named(flag, value,
                    std::map<std::string, v1::DType>{{"float32", v1::DTYPE_FLOAT32}, {"float16", v1::DTYPE_FLOAT16}});
  } else if (flag == "--time") {
    r.time = number(flag, value, "s");
  } else if (flag == "--t0") {
    r.t0 = number(flag, value, "s");
  } else if (flag == "--dt") {
    r.dt = number(flag, value, "s"), r.have_dt = true;
  } else if (flag == "--frames") {
    r.frames = integer32(flag, value), r.have_frames = true;
  } else if (flag == "-o" || flag == "--output") {
    r.out = value;
  } else if (flag == "--preview") {
    r.preview = value;
  } else if (flag == "--point") {
    r.points.push_back(point(flag, value));
  } else if (flag == "--points-file") {
    read_points_file(value, r);
  } else if (flag == "--invert-displacement") {
    r.invert = on_off(flag, value);
  } else {
    return false;
  }
  return true;
}

// The tile flags of what a tile holds beside the surface, which do not change samples.
const std::set<std::string> kTileOutputFlags = {"--output-grid", "--output-extent", "--whitecap-threshold",
                                                "--whitecap-decay-time", "--pixel-scale"};
std::set<std::string> with_tile_outputs(std::set<std::string> flags) {
  flags.insert(kTileOutputFlags.begin(), kTileOutputFlags.end());
  return flags;
}

}  // namespace

const std::map<std::string, std::set<std::string>> kVerbFlags = {
    {"tile", with_tile_outputs({"--time", "-o", "--output", "--preview", "--outputs", "--dtype"})},
    {"stream", with_tile_outputs({"--t0", "--dt", "--frames", "-o", "--output", "--outputs", "--dtype"})},
    {"sample", {"--time", "--point", "--points-file", "--invert-displacement"}}};

Request parse(const std::vector<std::string>& args) {
  Request r;
  r.tile.set_choppiness(1);
  *r.tile.add_layers() = default_layer();
  r.outputs = {v1::TILE_OUTPUT_HEIGHT,   v1::TILE_OUTPUT_DISPLACEMENT_X, v1::TILE_OUTPUT_DISPLACEMENT_Y,
               v1::TILE_OUTPUT_NORMAL_X, v1::TILE_OUTPUT_NORMAL_Y,       v1::TILE_OUTPUT_NORMAL_Z};
  for (size_t i = 1; i < args.size(); ++i) {
    const std::string& flag = args[i];
    if (flag == "--add-layer") {
      v1::LayerSpec copy = r.tile.layers(r.tile.layers_size() - 1);
      *r.tile.add_layers() = copy;
      continue;
    }
    if (i + 1 >= args.size()) throw UsageError(flag + " needs a value (or is unknown)");
    const std::string& value = args[++i];
    v1::LayerSpec& layer = *r.tile.mutable_layers(r.tile.layers_size() - 1);
    if (run_flag(flag, value, r) || (kTileOutputFlags.count(flag) && tile_flag(flag, value, r)))
      r.run_flags.push_back(flag);
    else if (!layer_flag(flag, value, layer) && !tile_flag(flag, value, r))
      throw UsageError("unknown flag " + flag);
  }
  return r;
}

}  // namespace squall::cli::ocean
