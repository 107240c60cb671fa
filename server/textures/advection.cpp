#include "textures/advection.h"

#include <cmath>

#include "textures/fields.h"

namespace squall::textures {

TextureFrame empty_frame(int index, double time, const OutputGrid& out, const TextureSource& texture) {
  TextureFrame frame;
  frame.index = index;
  frame.time = time;
  frame.width = out.width;
  frame.height = out.height;
  frame.final_planes = final_channels(&texture);
  frame.raw_planes = texture.channels;
  frame.planes.assign(size_t(frame.final_planes + frame.raw_planes + SQUALL_AUX_PLANES) * out.width * out.height, 0);
  return frame;
}

FrameStats frame_stats(const TextureFrame& frame) {
  FrameStats stats;
  const size_t n = size_t(frame.width) * frame.height;
  const float* coverage = frame.coverage();
  const float* sq_sum = frame.weight_sq_sum();
  for (size_t k = 0; k < n; ++k) stats.uncovered += coverage[k] >= 0 && sq_sum[k] < 1e-12f;
  for (int c = 0; c < frame.final_planes; ++c) {
    const float* plane = frame.plane(c);
    double sum = 0, sum2 = 0, count = 0;
    for (size_t k = 0; k < n; ++k) {
      if (coverage[k] < 0) continue;
      sum += plane[k];
      sum2 += double(plane[k]) * plane[k];
      ++count;
    }
    double mean = count > 0 ? sum / count : 0;
    stats.mean.push_back(mean);
    stats.stddev.push_back(count > 0 ? std::sqrt(std::max(0.0, sum2 / count - mean * mean)) : 0);
  }
  return stats;
}

}  // namespace squall::textures
