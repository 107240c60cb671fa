#include "ewave/ewave_state_format.h"

#include <algorithm>
#include <cstring>
#include <type_traits>

#include "common/byte_codec.h"
#include "common/error.h"
#include "common/validate.h"
#include "ocean/tile_spec_bytes.h"

namespace squall::ewave {
namespace {

constexpr char kMagic[8] = {'S', 'Q', 'E', 'W', 'A', 'V', 'E', '2'};
constexpr char kMagicVersion1[8] = {'S', 'Q', 'E', 'W', 'A', 'V', 'E', '1'};
constexpr size_t kLengthBytes = sizeof(uint64_t);  // the ambient ocean's length

bool is_version1(const StateHeader& h) { return std::memcmp(h.magic, kMagicVersion1, sizeof(kMagicVersion1)) == 0; }

// The most steps a state may have made: exact in a double (a JSON client's after_step); a million steps a
// second take 285 years to get there.
constexpr uint64_t kMaxStep = uint64_t(1) << 53;

size_t ambient_ocean_offset(const StateHeader& h) {
  return sizeof(StateHeader) + state_field_bytes(h.nx, h.ny, h.double_precision != 0);
}

// The one mapping between header members and config members, used both ways: copy(stored, value) is
// called once per pair, with the header (or the config) const for writing (or reading).
template <typename Header, typename Config, typename Copy>
void each_member(Header& h, Config& c, Copy copy) {
  copy(h.nx, c.nx);
  copy(h.ny, c.ny);
  copy(h.dx, c.dx);
  copy(h.dy, c.dy);
  copy(h.dispersion, c.dispersion);
  copy(h.gravity, c.gravity);
  copy(h.depth, c.depth);
  copy(h.capillary_length, c.capillary_length);
  copy(h.trim, c.trim);
  copy(h.trim_width, c.trim_width);
  copy(h.trim_alpha, c.trim_alpha);
  copy(h.friction_time, c.friction_time);
  copy(h.source_scale, c.source_scale);
  copy(h.mask_phi, c.mask_phi);
  copy(h.double_precision, c.double_precision);
  copy(h.displacement_scale, c.displacement_scale);
}

}  // namespace

size_t state_field_bytes(int64_t nx, int64_t ny, bool double_precision) {
  return kStateFields * size_t(nx) * size_t(ny) * (double_precision ? sizeof(double) : sizeof(float));
}

std::string new_state(const EWaveConfig& config, uint64_t step, double time) {
  StateHeader h{};
  std::memcpy(h.magic, config.ambient_ocean ? kMagic : kMagicVersion1, sizeof(kMagic));
  each_member(h, config,
              [](auto& stored, const auto& value) { stored = static_cast<std::decay_t<decltype(stored)>>(value); });
  h.step = step;
  h.time = time;
  std::string bytes(ambient_ocean_offset(h), '\0');
  std::memcpy(bytes.data(), &h, sizeof(h));
  if (!config.ambient_ocean) return bytes;
  ByteWriter out(std::move(bytes));
  out.put_counted(ocean::encode_tile_spec(*config.ambient_ocean));
  return out.take();
}

std::string without_ambient_ocean(std::string state) {
  const StateHeader h = parse_state_header(state);
  state.resize(ambient_ocean_offset(h));  // a version-1 state is that long already: nothing is copied
  std::memcpy(state.data(), kMagicVersion1, sizeof(kMagicVersion1));
  return state;
}

char* state_fields(std::string& state) { return state.data() + sizeof(StateHeader); }
const char* state_fields(const std::string& state) { return state.data() + sizeof(StateHeader); }

StateHeader parse_state_header(const std::string& bytes) {
  StateHeader h{};
  if (bytes.size() < sizeof(h))
    fail(Code::InvalidArgument, "state has " + std::to_string(bytes.size()) + " bytes, too few for an eWave state");
  std::memcpy(&h, bytes.data(), sizeof(h));
  if (std::memcmp(h.magic, kMagic, sizeof(kMagic)) != 0 && !is_version1(h))
    fail(Code::InvalidArgument, "state is not an eWave state (bad magic)");
  if (h.nx < 1 || h.ny < 1 || h.nx > (int64_t(1) << 20) || h.ny > (int64_t(1) << 20))
    fail(Code::InvalidArgument, "state.grid is invalid");
  size_t want = ambient_ocean_offset(h);
  if (!is_version1(h) && bytes.size() >= want + kLengthBytes) {
    ByteReader length(std::string_view(bytes).substr(want), "state", "an eWave state");
    want += kLengthBytes + std::min<uint64_t>(length.get<uint64_t>("the ambient ocean length"), bytes.size());
  } else if (!is_version1(h)) {
    want += kLengthBytes;
  }
  if (bytes.size() != want)
    fail(Code::InvalidArgument, "state has " + std::to_string(bytes.size()) + " bytes, want " + std::to_string(want) +
                                    " for its grid" + (is_version1(h) ? "" : " and ambient ocean"));
  return h;
}

std::string_view ambient_ocean_bytes(const std::string& bytes, const StateHeader& h) {
  if (is_version1(h)) return {};
  return std::string_view(bytes).substr(ambient_ocean_offset(h) + kLengthBytes);
}

EWaveConfig config_of(const StateHeader& header, const LimitGate* gate) {
  // The one stored integer whose config member is narrower (the flags, 0 or 1, are checked below).
  if (header.dispersion < 0 || header.dispersion > 3)
    validate::reject("state.dispersion", std::to_string(header.dispersion),
                     "a known dispersion model (deep, shallow, capillary, combined: 0..3)");
  EWaveConfig c;
  each_member(header, c,
              [](const auto& stored, auto& value) { value = static_cast<std::decay_t<decltype(value)>>(stored); });
  validate(c, gate, "state");
  validate::in("state.time", header.time, validate::closed(-kMaxTime, kMaxTime));
  for (const auto& [field, flag] : {std::pair<const char*, int64_t>{"state.trim", header.trim},
                                    {"state.mask_phi", header.mask_phi},
                                    {"state.double_precision", header.double_precision}})
    if (flag != 0 && flag != 1) validate::reject(field, std::to_string(flag), "0 or 1");
  if (header.step > kMaxStep)  // a count that never wraps
    validate::reject("state.step", std::to_string(header.step), "at most 2^53");
  return c;
}

// Far past the state of a physical session, and small enough that a grid's sum of such values in a step's
// transforms, times its propagator, stays within float. (The normals' own limit is lower where slopes pass
// 1.8e19: sq_surface_normal.) Inputs held to their ranges can still drive a session past it, whose state
// EWaveSession::state() then refuses to hand out.
constexpr double kMaxStateValue = 1e25;

void check_fields_in_range(const std::string& bytes, const StateHeader& h) {
  const char* fields = state_fields(bytes);
  const size_t count = kStateFields * size_t(h.nx) * size_t(h.ny);
  for (size_t c = 0; c < count; ++c) {
    double v;
    if (h.double_precision) {
      std::memcpy(&v, fields + c * sizeof(double), sizeof(double));
    } else {
      float f;
      std::memcpy(&f, fields + c * sizeof(float), sizeof(float));
      v = f;
    }
    validate::in(validate::at("state.fields", c), v, validate::closed(-kMaxStateValue, kMaxStateValue));
  }
}

std::vector<char> to_state_type(const std::vector<double>& values, bool double_precision) {
  std::vector<char> bytes(values.size() * (double_precision ? sizeof(double) : sizeof(float)));
  if (double_precision) {
    std::memcpy(bytes.data(), values.data(), bytes.size());
    return bytes;
  }
  for (size_t i = 0; i < values.size(); ++i) {
    float f = float(values[i]);
    std::memcpy(bytes.data() + i * sizeof(float), &f, sizeof(float));
  }
  return bytes;
}

}  // namespace squall::ewave
