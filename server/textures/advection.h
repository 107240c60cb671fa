// One advection in progress (a stream's state) and the frames it produces.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "textures/device_inputs.h"
#include "textures/fields.h"

namespace squall::textures {

// Particle bookkeeping of the Lagrangian method during one frame (zero for the Eulerian methods).
struct ParticleStats {
  int alive = 0, fading = 0, born = 0;
  // ALIVE particles turned FADING, by the rule that killed them (LTA11 sec. 3.3.2-3.3.3).
  int killed_coverage = 0, killed_quality = 0, killed_fold = 0, killed_density = 0;
  int deleted = 0;            // faded out, or left the sampled region
  double min_quality = 1;     // smallest vertex quality Q_V of an ALIVE grid (eq. 2)
  double max_distortion = 1;  // largest triangle distortion delta (eq. 1) of an ALIVE grid
};

struct FrameStats {
  std::vector<double> mean, stddev;  // per final plane, over fluid pixels
  int64_t uncovered = 0;             // fluid pixels no sample covered
  ParticleStats particles;
  std::vector<std::pair<std::string, double>> stage_ms;  // host wall time per stage
};

// A frame: planes of width x height floats, x fastest: `final_planes` of F(R'), `raw_planes` of R',
// then SQUALL_AUX_PLANES auxiliary planes (fields.h).
struct TextureFrame {
  int index = 0;
  double time = 0;  // s
  int width = 0, height = 0;
  int final_planes = 0, raw_planes = 0;
  std::vector<float> planes;
  FrameStats stats;

  const float* plane(int k) const { return planes.data() + size_t(k) * width * height; }
  const float* weight_sum() const { return plane(final_planes + raw_planes); }
  const float* weight_sq_sum() const { return plane(final_planes + raw_planes + 1); }
  const float* coverage() const { return plane(final_planes + raw_planes + 2); }
  const float* layer() const { return plane(final_planes + raw_planes + 3); }
  const float* uv_x() const { return plane(final_planes + raw_planes + 4); }
  const float* uv_y() const { return plane(final_planes + raw_planes + 5); }
};

// A frame of `frame`'s size with every plane `texture` asks for, zeroed.
TextureFrame empty_frame(int index, double time, const OutputGrid& frame, const TextureSource& texture);
// Mean and standard deviation of each final plane over the fluid pixels, and the uncovered fluid pixels.
FrameStats frame_stats(const TextureFrame& frame);

class Advection {
 public:
  virtual ~Advection() = default;
  // Frame 0 at t0, then each call advances dt and returns the next frame.
  virtual TextureFrame next() = 0;
  // The whole state after the last frame, from which resume() continues bit-identically.
  virtual std::string checkpoint() const = 0;

  // Steering (TextureEngine::steer): from the next frame on, the velocity field and the texture's
  // animation of `inputs`, `dt` seconds between frames and `substeps` integration steps per frame. The
  // frame times stay continuous: the next frame is at the last frame's time + dt.
  virtual void steer(std::shared_ptr<const DeviceInputs> inputs, double dt, int substeps) = 0;
  virtual const DeviceInputs& inputs() const = 0;
  // The time of the last frame next() returned (t0 before the first; a resumed advection: its checkpoint's).
  virtual double time() const = 0;
};

}  // namespace squall::textures
