// The boundary values of a river's stream function from its network (Q. Yu, F. Neyret, E. Bruneton,
// N. Holzschuch, "Scalable Real-Time Animation of Rivers", Eurographics 2009, sec. 4.1): the flow rates
// Q of the channels (given, or from mass conservation at the junctions with the split in proportion to the
// cross-sections), then psi on every bank such that psi_left - psi_right = Q for every channel and banks
// that continue through a junction share one value. Host only.
#pragma once

#include <string>
#include <vector>

#include "textures/river_spec.h"

namespace squall::textures {

struct RiverNetwork {
  std::vector<double> flow_rate;  // Q per channel, du^2/s
  std::vector<double> left_psi;   // psi on each channel's left bank
  std::vector<double> right_psi;  // psi on each channel's right bank
  // Bank b (2c: channel c's left, 2c + 1: its right) belongs to boundary boundary_of[b]: banks joined
  // through junctions form one boundary, numbered 0 .. boundaries - 1.
  std::vector<int> boundary_of;
  std::vector<double> boundary_psi;  // per boundary
};

// Throws InvalidArgument naming the field under `path` (e.g. "river.channels[2].flow_rate") when a flow
// rate cannot be determined, a junction does not conserve the flow, or the flow rates around a loop of
// channels disagree (an island drawn as channels: give it as an obstacle instead).
RiverNetwork solve_network(const RiverSpec& river, const std::string& path);

// w of a channel: its cross_section, or the distance between the first points of its banks.
double cross_section(const RiverChannelSpec& channel);

}  // namespace squall::textures
