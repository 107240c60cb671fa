// Content-aware texture deformation on the device (G. Guingo et al., "Content-aware texture deformation with
// dynamic control", Computers & Graphics 91, 2020): the flow field solved once from the rigidity map
// (sec. 4, eq. 6), the per-texel warp moved every frame by its d mu (sec. 3.3, eq. 5), the controls of d mu
// (sec. 5, eqs. 7-8) and the resampling stack (sec. 6.1, eqs. 9-14). No gRPC in here.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/cancel.h"
#include "common/limits.h"
#include "runtime/runtime.h"
#include "textures/deform_spec.h"

namespace squall::textures {

// The flow solve's outcome (the same for every frame of a deformation).
struct FlowSolve {
  int iterations = 0;
  double residual = 0;  // |D^T (D v - R)| / |D^T R| at the end (0 when R is 0 everywhere)
};

// One frame: the planes asked for (DeformPlanes), each width * height floats, x fastest, in the order
// color (channels planes), warp (x, y), reference (t*), level (h), flow (x, y).
struct DeformFrame {
  int index = 0;
  double time = 0;  // s: index dt
  int width = 0, height = 0;
  std::vector<float> planes;
  double max_warp = 0;                          // texels: max |W(u) - u|
  double max_residual = 0;                      // texels: max |residual warp| (max_warp without a stack)
  double min_reference = 0, max_reference = 0;  // t* over the texels
};

class Deformation {
 public:
  virtual ~Deformation() = default;
  // Frame 0 (the undeformed texture), then each call takes one frame's step and returns the frame.
  virtual DeformFrame next(const DeformPlanes& planes) = 0;
  // From the next frame on: `control` replaces the running one. For the tensor controls,
  // control.deformation_start is G now, reached at the next frame and held after it. Checked first:
  // INVALID_ARGUMENT naming DeformControl's fields under `path` ("<path>.d_mu", "<path>.deformation", ...;
  // bare names when `path` is empty), and the deformation keeps its control.
  virtual void steer(const DeformControl& control, const std::string& path = "") = 0;
  virtual const FlowSolve& flow() const = 0;
  // Device bytes this deformation holds (its state, flow, texture and stack).
  virtual uint64_t device_bytes() const = 0;
};

class DeformEngine {
 public:
  // The flow solves kept count in `gate`'s memory budget as cached memory, given back to calls that need it.
  DeformEngine(Runtime& runtime, LimitGate& gate);
  ~DeformEngine();

  // Host and device bytes a deformation of a validated `spec` holds while it runs, an estimate for the
  // caller's memory budget: its state (the texture and its stack, the warp, the reference times, the
  // output), its flow field on the host and the device with a kept solve's key (rigidity and chart), a d mu
  // map's copies (map_bytes) and the flow solve's buffers (CGLS in double).
  static uint64_t working_bytes(const DeformSpec& spec);
  // The flow solve's part of working_bytes, held only until the flow is there.
  static uint64_t solve_bytes(const DeformSpec& spec);
  // A d mu map's copies in a running deformation besides the spec's own: the control's on the host, and for
  // a MAP control its buffer on the device (part of working_bytes where the spec holds a map).
  static uint64_t map_bytes(const DeformSpec& spec);

  // Every field in range (INVALID_ARGUMENT naming "<path>.<field>", the proto's names: "texture",
  // "rigidity", "chart", "d_mu_map", "strokes[i].radius", "deformation_start.xx", ...); width * height (and
  // the stack's levels) within --max-grid-cells (RESOURCE_EXHAUSTED).
  void validate(const DeformSpec& spec, const std::string& path) const;
  // A validated spec's deformation. The flow field is solved here (or reused: the last few solves are
  // kept, keyed by the rigidity, chart, size, tolerance and iterations); the solve asks `cancel` between
  // its iterations (Error(Cancelled)). `reserved`: where given, the caller's reservation of working_bytes,
  // from which a solve kept takes its bytes, and which gives the solve's share back (solve_bytes) once the
  // flow is there.
  std::unique_ptr<Deformation> start(const DeformSpec& spec, const Cancellation& cancel = {}, Slot* reserved = nullptr);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace squall::textures
