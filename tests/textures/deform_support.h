// Shared pieces of the content-aware deformation tests (G. Guingo et al., "Content-aware texture deformation
// with dynamic control", Computers & Graphics 91, 2020): the engine on the test device, square textures and
// rigidity maps, runs of frames, and the divergence operator of eq. 6 in double on the host.
#pragma once

#include <vector>

#include "textures/deform.h"

namespace squall::test {

textures::DeformEngine& deform_engine();

struct Disk {
  double x, y, radius;  // texels
};

// A size x size spec: R = 1 inside the disks and -1 outside (0 everywhere with none), the given planes of
// texture (channels = planes.size() / size^2), 10 substeps, no stack.
textures::DeformSpec disk_spec(int size, const std::vector<Disk>& disks, const std::vector<float>& texture);

// 0.5 + 0.25 sin(2 pi x / 16) + 0.25 cos(2 pi y / 13): smooth, in [0, 1].
std::vector<float> smooth_texture(int size);
// The disk's coverage of each texel (antialiased over one texel): sums to about its area.
std::vector<float> disk_indicator(int size, const Disk& disk);

// Validates and starts `spec` and takes `frames` frames (frame 0 first).
std::vector<textures::DeformFrame> run(const textures::DeformSpec& spec, int frames,
                                       const textures::DeformPlanes& planes = {});

// Plane k of a frame (W * H floats).
std::vector<float> plane(const textures::DeformFrame& frame, int k);

// The fixed texels' complement (the border, outside the chart and next to it: 0).
std::vector<uint8_t> free_mask(int width, int height, const std::vector<uint8_t>& chart);

// |D^T (D v - R_dual)| / |D^T R_dual| in double over the free texels, v as planes (x then y).
double normal_residual(int width, int height, const std::vector<float>& rigidity, const std::vector<uint8_t>& chart,
                       const std::vector<float>& vx, const std::vector<float>& vy);

double mean_abs_difference(const std::vector<float>& a, const std::vector<float>& b);
double psnr(const std::vector<float>& a, const std::vector<float>& b, double peak);

}  // namespace squall::test
