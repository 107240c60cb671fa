// The inputs every advection method reads on the device: the velocity field (analytic, or grid frames
// with their fluid mask), the reference texture's image planes, the LUT final function's table and scalar
// field, and their kernel descriptions (fields.h). Uploaded once per advection.
#pragma once

#include <memory>
#include <vector>

#include "runtime/opencl.h"
#include "runtime/runtime.h"
#include "textures/fields.h"
#include "textures/texture_spec.h"

namespace squall::textures {

// Mean and variance of each channel of the reference texture R over one period (Rhat of LTA11 eq. 4).
struct ReferenceStats {
  std::vector<double> mean, variance;
};

class DeviceInputs {
 public:
  // Uploads the grid frames (push-pull extrapolated where the spec asks), the image planes, and the LUT's
  // table and scalar field.
  DeviceInputs(Runtime& runtime, const AdvectSpec& spec, const ReferenceStats& stats);
  // These inputs with the velocity of `spec` (uploaded) and its texture's spin and final_scale from `time`
  // (s) on; the texture's uploads and statistics are shared, not copied (steering a running advection).
  std::shared_ptr<const DeviceInputs> steered(Runtime& runtime, const AdvectSpec& spec, double time) const;

  // The field for a step over [t0, t0 + span] (s): a grid's frames from the last at or before t0 to the
  // first at or after t0 + span (validate_advect keeps them within SQUALL_VELOCITY_WINDOW), their times
  // counted from t0, as the kernels count a step's times.
  VelocityField velocity(double t0, double span) const;
  // The texture as evaluated at time `time` (flow noise turns with time).
  TextureSource texture(double time) const;
  // The output pixels, binned into tiles of `tile` pixels.
  OutputGrid output(int tile) const;
  // The host's fluid test, the one the kernels use.
  bool fluid(double x, double y) const;

  const cl::Buffer& grid() const { return grid_; }
  const cl::Buffer& mask() const { return mask_; }
  const cl::Buffer& image() const { return image_; }
  const cl::Buffer& scalar() const { return scalar_; }  // the LUT's scalar field s (a few zeros when absent)
  const cl::Buffer& lut() const { return lut_; }        // the LUT's N x C table
  const ReferenceStats& stats() const { return stats_; }

 private:
  void set_velocity(Runtime& runtime, const VelocitySpec& velocity);  // field, frame times, mask, uploads

  VelocityField field_{};
  TextureSource texture_{};
  // Flow noise: band 0 turns at spin_ rad/s from turned_ rad at turned_since_ s (the last change of spin).
  // TextureSource::turn holds the bands' angles at a time.
  double spin_ = 0, turned_ = 0, turned_since_ = 0;
  double turned(double time) const;  // band 0's angle at `time`, rad
  OutputSpec output_;
  std::vector<double> times_;
  std::vector<uint8_t> mask_host_;
  ReferenceStats stats_;
  cl::Buffer grid_, mask_, image_, scalar_, lut_;
};

// The reference statistics of an image texture, computed from its pixels.
ReferenceStats image_stats(const TextureSpec& texture);

}  // namespace squall::textures
