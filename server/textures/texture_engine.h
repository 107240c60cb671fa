// The textures engine: validates advection requests and starts advections (Lagrangian grids, Eulerian
// multi-layer, two-phase flow map, naive) on the daemon's device. No gRPC in here.
#pragma once

#include <memory>
#include <string>
#include <string_view>

#include "common/cancel.h"
#include "common/limits.h"
#include "runtime/runtime.h"
#include "textures/advection.h"
#include "textures/device_inputs.h"
#include "textures/texture_kernels.h"
#include "textures/texture_spec.h"

namespace squall::textures {

// Largest particle count a Lagrangian request may need (about region area / d^2).
constexpr double kMaxParticles = 200000;

// TextureEngine::validate without an engine: the same checks against `gate`.
// `velocity_path`: the request field the velocity came from (empty: path + ".velocity").
void validate_advect(const AdvectSpec& spec, const LimitGate& gate, const std::string& path,
                     const std::string& velocity_path = "");
// Its t0, dt, frames and substeps alone: checked before a followed current is computed at those times. `now`:
// the time the stream has reached, from which its frames go on (t0 before its first frame).
void validate_clock(const AdvectSpec& spec, const std::string& path, double now);
inline void validate_clock(const AdvectSpec& spec, const std::string& path) { validate_clock(spec, path, spec.t0); }
// A current read from what a request follows (an eWave session, an ocean tile), each time it is read: every
// node's speed within +-kMaxVelocityParam, else FAILED_PRECONDITION naming `path`, the field that follows it
// (the state followed is out of range, not the request).
void validate_followed_current(const VelocitySpec& velocity, const std::string& path);
// A velocity grid made of what a request names (a followed current, a baked river): the checks of a
// request's grid, each error naming "<source>'s grid" (the request has no grid field to name). Run before
// TextureEngine::validate, which then finds nothing of the grid to refuse under a field the request lacks.
void validate_made_velocity(const VelocitySpec& velocity, const LimitGate& gate, const std::string& source);
// The same current read again for a later frame (the request's substeps were checked against its first
// reading): its gradients turn the flow by at most 2 rad per substep of spec.dt, else FAILED_PRECONDITION.
void validate_followed_turn(const AdvectSpec& spec, const std::string& path);

class TextureEngine {
 public:
  TextureEngine(Runtime& runtime, const LimitGate& gate);

  // Every field in range (INVALID_ARGUMENT naming "<path>.<field>"), the output and velocity grids
  // within --max-grid-cells and an Eulerian grid's buffers within the device's largest allocation
  // (RESOURCE_EXHAUSTED).
  void validate(const AdvectSpec& spec, const std::string& path, const std::string& velocity_path = "") const;

  // Bytes the advection of a validated spec holds besides its frames, at most: the Eulerian slots' node
  // state and the cascade's (twice on the device, state and scratch, and once on the host as it starts or
  // checkpoints), or the Lagrangian grids at their bound (positions, coordinates and weights, on the host
  // and on the device).
  static uint64_t state_bytes(const AdvectSpec& spec);
  // Bytes the inputs of a validated spec hold while it runs, at most: the image's planes and the LUT's table
  // and scalar field on the host and the device; a velocity grid's frames kVelocityCopies times (the spec's,
  // or a followed current's two surface currents; their interleaved copy for the upload; on the device, twice
  // while a steered field replaces the last).
  static uint64_t input_bytes(const AdvectSpec& spec);
  static constexpr uint64_t kVelocityCopies = 4;
  // One copy of an Eulerian advection's slots' node state (float4 per slot and node) and of its cascade's
  // (float2 per band and node), bytes: each is one device buffer. 0 for Lagrangian grids.
  static uint64_t eulerian_slot_bytes(const AdvectSpec& spec);
  static uint64_t eulerian_cascade_bytes(const AdvectSpec& spec);

  // A validated spec's advection; `resume_state` (from Advection::checkpoint() of the same request)
  // continues it bit-identically. It asks `cancel` as it starts and before each substep (Eulerian), or before
  // each frame and between the slices of its reconstruction (Lagrangian).
  std::unique_ptr<Advection> start(const AdvectSpec& spec, std::string_view resume_state = {},
                                   const Cancellation& cancel = {});

  // Changes a running advection from its next frame on: `spec` is the spec it was started with, where only
  // the velocity, dt, substeps and the texture's spin and final_scale may differ (validated by the caller).
  // The reference statistics stay those of the start (the texture's channels do not change).
  void steer(Advection& advection, const AdvectSpec& spec);

  // The reference texture registered to the domain, T(S x), on the spec's output pixels.
  TextureFrame window(const AdvectSpec& spec);
  // Mean and variance of each channel of R over one period (images: from the pixels).
  ReferenceStats reference_stats(const TextureSpec& texture);

 private:
  TextureFrame window(const AdvectSpec& spec, const ReferenceStats& stats);

  Runtime& runtime_;
  const LimitGate& gate_;
  TextureKernels kernels_;
};

}  // namespace squall::textures
