#include "textures/river_network.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <queue>

#include "common/disjoint_sets.h"
#include "common/error.h"
#include "common/validate.h"

namespace squall::textures {
namespace {

using validate::at;
using validate::number;

int left_bank(int channel) { return 2 * channel; }
int right_bank(int channel) { return 2 * channel + 1; }

// Sum of the known flow rates of `channels`, and how many are unknown.
struct SideSum {
  double known = 0;
  int unknown = 0;
};

SideSum side_sum(const std::vector<uint32_t>& channels, const std::vector<std::optional<double>>& q) {
  SideSum s;
  for (uint32_t c : channels) {
    if (q[c])
      s.known += *q[c];
    else
      ++s.unknown;
  }
  return s;
}

// One junction's law (sec. 4.1): when one side is fully known, the other side's unknown channels share
// what it lacks in proportion to their cross-sections. True when it set a flow rate.
bool apply_junction(const RiverJunctionSpec& j, const RiverSpec& river, std::vector<std::optional<double>>& q,
                    const std::string& path) {
  const SideSum in = side_sum(j.upstream, q), out = side_sum(j.downstream, q);
  if (in.unknown == 0 && out.unknown == 0) {
    if (std::abs(in.known - out.known) > 1e-9 * std::max(in.known, out.known))
      fail(Code::InvalidArgument, path + ": flow in " + number(in.known) + " du^2/s != flow out " + number(out.known) +
                                      " du^2/s (mass conservation)");
    return false;
  }
  if (in.unknown > 0 && out.unknown > 0) return false;
  const bool fill_upstream = in.unknown > 0;
  const std::vector<uint32_t>& side = fill_upstream ? j.upstream : j.downstream;
  const double missing = fill_upstream ? out.known - in.known : in.known - out.known;
  if (!(missing > 0))
    fail(Code::InvalidArgument, path + ": the given flow rates leave " + number(missing) +
                                    " du^2/s for the channels whose flow_rate is unset (must be > 0)");
  double width = 0;
  for (int c : side)
    if (!q[c]) width += cross_section(river.channels[c]);
  for (int c : side)
    if (!q[c]) q[c] = missing * cross_section(river.channels[c]) / width;
  return true;
}

std::vector<double> flow_rates(const RiverSpec& river, const std::string& path) {
  std::vector<std::optional<double>> q;
  for (const RiverChannelSpec& c : river.channels) q.push_back(c.flow_rate);
  for (bool changed = true; changed;) {
    changed = false;
    for (size_t j = 0; j < river.junctions.size(); ++j)
      changed |= apply_junction(river.junctions[j], river, q, at(path + ".junctions", j));
  }
  std::vector<double> rates;
  for (size_t c = 0; c < q.size(); ++c) {
    if (!q[c])
      fail(Code::InvalidArgument,
           at(path + ".channels", c) + ".flow_rate is unset and no junction determines it: give it (du^2/s)");
    rates.push_back(*q[c]);
  }
  return rates;
}

// Banks that continue through a junction: the outer banks, and the banks between neighbouring channels.
std::vector<int> join_banks(const RiverSpec& river) {
  DisjointSets banks(2 * river.channels.size());
  for (const RiverJunctionSpec& j : river.junctions) {
    banks.join(left_bank(j.upstream.front()), left_bank(j.downstream.front()));
    banks.join(right_bank(j.upstream.back()), right_bank(j.downstream.back()));
    for (const std::vector<uint32_t>* side : {&j.upstream, &j.downstream})
      for (size_t k = 0; k + 1 < side->size(); ++k) banks.join(right_bank((*side)[k]), left_bank((*side)[k + 1]));
  }
  std::vector<int> boundary(banks.size(), -1), of(banks.size());
  int boundaries = 0;
  for (size_t b = 0; b < banks.size(); ++b) {
    int& id = boundary[banks.find(b)];
    if (id < 0) id = boundaries++;
    of[b] = id;
  }
  return of;
}

// psi per boundary from psi_left - psi_right = Q of each channel, breadth first from psi = 0 on the right
// bank of the first channel of each connected network.
std::vector<double> boundary_values(const RiverNetwork& n, int boundaries, const std::string& path) {
  struct Edge {
    int to;
    double difference;  // psi(to) - psi(from)
    int channel;
  };
  std::vector<std::vector<Edge>> edges(boundaries);
  for (size_t c = 0; c < n.flow_rate.size(); ++c) {
    const int l = n.boundary_of[left_bank(int(c))], r = n.boundary_of[right_bank(int(c))];
    edges[r].push_back({l, n.flow_rate[c], int(c)});
    edges[l].push_back({r, -n.flow_rate[c], int(c)});
  }
  std::vector<std::optional<double>> psi(boundaries);
  for (size_t c = 0; c < n.flow_rate.size(); ++c) {
    const int start = n.boundary_of[right_bank(int(c))];
    if (psi[start]) continue;
    psi[start] = 0.0;
    std::queue<int> frontier;
    frontier.push(start);
    for (; !frontier.empty(); frontier.pop()) {
      for (const Edge& e : edges[frontier.front()]) {
        const double value = *psi[frontier.front()] + e.difference;
        if (!psi[e.to]) {
          psi[e.to] = value;
          frontier.push(e.to);
        } else if (std::abs(*psi[e.to] - value) > 1e-9 * (std::abs(value) + std::abs(e.difference))) {
          fail(Code::InvalidArgument, at(path + ".channels", size_t(e.channel)) +
                                          ": the flow rates around a loop of channels disagree (draw an "
                                          "island as an obstacle, not as channels around it)");
        }
      }
    }
  }
  std::vector<double> values;
  for (const auto& v : psi) values.push_back(*v);
  return values;
}

// The kernels hold the banks' psi in float32: each channel's Q must survive its banks' values rounded there
// (to within kFloatFlowTolerance of Q), else a small channel's flow is lost beside larger values (Q = 10
// between banks at psi = 1e9 and 1e9 - 10, which float32 spaces 64 apart, baked no flow at all).
constexpr double kFloatFlowTolerance = 1e-3;

void check_float_resolution(const RiverNetwork& n, const std::string& path) {
  double largest = 0;
  for (double psi : n.boundary_psi) largest = std::max(largest, std::abs(psi));
  for (size_t c = 0; c < n.flow_rate.size(); ++c) {
    const double rounded = double(float(n.left_psi[c])) - double(float(n.right_psi[c]));
    if (std::abs(rounded - n.flow_rate[c]) > kFloatFlowTolerance * n.flow_rate[c])
      fail(Code::InvalidArgument, at(path + ".channels", c) + ": its flow rate " + number(n.flow_rate[c]) +
                                      " du^2/s is lost in float32 beside bank values (psi) up to " + number(largest) +
                                      " (its banks' differ by " + number(rounded) +
                                      "): float32 keeps flow rates down to about 1e-4 of the largest bank value");
  }
}

}  // namespace

double cross_section(const RiverChannelSpec& channel) {
  if (channel.cross_section) return *channel.cross_section;
  return std::hypot(channel.left.front().x - channel.right.front().x, channel.left.front().y - channel.right.front().y);
}

RiverNetwork solve_network(const RiverSpec& river, const std::string& path) {
  RiverNetwork n;
  n.flow_rate = flow_rates(river, path);
  n.boundary_of = join_banks(river);
  int boundaries = 0;
  for (int b : n.boundary_of) boundaries = std::max(boundaries, b + 1);
  n.boundary_psi = boundary_values(n, boundaries, path);
  for (size_t c = 0; c < river.channels.size(); ++c) {
    n.left_psi.push_back(n.boundary_psi[n.boundary_of[left_bank(int(c))]]);
    n.right_psi.push_back(n.boundary_psi[n.boundary_of[right_bank(int(c))]]);
  }
  check_float_resolution(n, path);
  return n;
}

}  // namespace squall::textures
