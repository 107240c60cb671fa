// The static flow field of a content-aware deformation (G. Guingo et al., "Content-aware texture
// deformation with dynamic control", Computers & Graphics 91, 2020, sec. 4): div v = R (eq. 6) in the
// least-squares sense, v = 0 on the fixed texels, solved once by CGLS and kept in a small cache.
#pragma once

#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <vector>

#include "common/limits.h"
#include "runtime/runtime.h"
#include "textures/deform.h"
#include "textures/deform_kernels.h"

namespace squall::textures {

struct FlowField {
  int width = 0, height = 0;
  std::vector<float> v;  // float2 per texel (x, y), x fastest: texels per unit of d mu
  cl::Buffer buffer;     // the same on the device (read only once solved)
  FlowSolve solve;
  uint64_t bytes() const { return uint64_t(width) * height * 2 * sizeof(float); }
};

// Fixed texels (v = 0): the texture's border, texels outside the chart and their 4-neighbours. 1: free.
std::vector<uint8_t> free_texels(int width, int height, const std::vector<uint8_t>& chart);

// R_dual on the (W - 1) x (H - 1) dual cells: the mean of the 4 surrounding R.
std::vector<double> dual_rigidity(int width, int height, const std::vector<float>& rigidity);

// Solves eq. 6 for a validated spec on the device.
std::shared_ptr<const FlowField> solve_flow(Runtime& runtime, DeformKernels& kernels, const DeformSpec& spec,
                                            const Cancellation& cancel = {});

// The last few solves, keyed by rigidity, chart, size, tolerance and iterations (compared in full). What it
// keeps (the flow on the host and the device, and the key's rigidity and chart) counts in `gate`'s memory
// budget (null: not counted) as cached memory; where the budget has no room for a new solve, the least
// recently used that no deformation uses make room or it is not kept, and a call that needs the room takes
// it back (reclaim).
class FlowCache final : public MemoryReclaimer {
 public:
  explicit FlowCache(LimitGate* gate);
  ~FlowCache() override;
  FlowCache(const FlowCache&) = delete;
  FlowCache& operator=(const FlowCache&) = delete;

  std::shared_ptr<const FlowField> find(const DeformSpec& spec);
  // `reserved`, when given, is the caller's reservation that counted the flow: its bytes move from there.
  void keep(const DeformSpec& spec, std::shared_ptr<const FlowField> flow, Slot* reserved = nullptr);
  uint64_t reclaim(uint64_t bytes) override;

 private:
  struct Entry {
    uint64_t hash;
    int width, height;
    int64_t max_iterations;
    double tolerance;
    std::vector<float> rigidity;
    std::vector<uint8_t> chart;
    std::shared_ptr<const FlowField> flow;
    uint64_t bytes;
    Slot memory;
  };
  static constexpr size_t kEntries = 4;
  bool matches(const Entry& e, uint64_t hash, const DeformSpec& spec) const;
  std::list<Entry>::iterator oldest_unused();  // under mutex_: end() if every entry is in use

  LimitGate* gate_;
  std::mutex mutex_;
  std::list<Entry> entries_;  // most recently used first
};

}  // namespace squall::textures
