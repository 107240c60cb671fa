// The binary state of an eWave session (EWaveSession::state, restore, config_from_state), version 2 (the
// magic's last character). Little-endian host layout; the header has 8-byte members only, so no padding.
//   offset  size  field
//   0       152   StateHeader: the config without its initial fields, start time and ocean specs, the
//                 step index and the time
//   152     F     h, then phi: nx ny values each, in the state's type (float, or double with
//                 config.double_precision), F = state_field_bytes()
//   152+F   8     u64 ambient ocean length A; 0: the config has no ambient_ocean
//   160+F   A     config.ambient_ocean (ocean/tile_spec_bytes.h), and nothing after it
// Version 1 ("SQEWAVE1") ends after phi: it holds no ambient ocean. A config without one is written so, as
// squalld wrote every state before version 2 (which older daemons then still read).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "ewave/ewave_config.h"

namespace squall::ewave {

constexpr int kStateFields = 2;  // h, phi

struct StateHeader {
  char magic[8];  // "SQEWAVE2" (or "SQEWAVE1")
  int64_t nx, ny;
  double dx, dy;
  int64_t dispersion;
  double gravity, depth, capillary_length;
  int64_t trim;
  double trim_width, trim_alpha, friction_time, source_scale;
  int64_t mask_phi;
  int64_t double_precision;
  double displacement_scale;
  uint64_t step;
  double time;
};
static_assert(sizeof(StateHeader) == 8 + 18 * 8, "StateHeader: 8-byte members, no padding");

// Bytes of the h and phi fields of a grid in the state's type.
size_t state_field_bytes(int64_t nx, int64_t ny, bool double_precision);

// A state of `config` at (step, time): version 2 with the config's ambient ocean written, version 1 without
// one; the fields zero (to be filled at state_fields()).
std::string new_state(const EWaveConfig& config, uint64_t step, double time);
// The version-1 bytes of a state: the same header (its magic "SQEWAVE1"), h and phi, no ambient ocean.
std::string without_ambient_ocean(std::string state);
char* state_fields(std::string& state);
const char* state_fields(const std::string& state);

// The header of state bytes of version 1 or 2. Throws Error(InvalidArgument) when they are too few, the
// magic is not ours, the grid is invalid, or their size does not match the grid (and the ambient ocean's
// length).
StateHeader parse_state_header(const std::string& bytes);
// The bytes of the config's ambient_ocean in state bytes whose header parse_state_header() returned;
// empty when it has none (a version 1 state never has one).
std::string_view ambient_ocean_bytes(const std::string& bytes, const StateHeader& header);
// The config a header describes, validated (InvalidArgument naming the field under "state"; with a gate,
// its grid within --max-grid-cells); also checks the header's time (naming state.time).
EWaveConfig config_of(const StateHeader& header, const LimitGate* gate = nullptr);
// Throws Error(InvalidArgument) naming the first field value of the state that is not finite and within
// +-1e25.
void check_fields_in_range(const std::string& bytes, const StateHeader& header);

// values converted to host bytes of the state's type (float or double).
std::vector<char> to_state_type(const std::vector<double>& values, bool double_precision);

}  // namespace squall::ewave
