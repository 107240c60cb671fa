// Shared pieces of the textures engine tests: the engine on the test device, request builders at the
// sizes PoCL runs quickly (128 x 128 output, Poisson radius 12 pixels, dt = 1/30 s), and frames as images.
#pragma once

#include <vector>

#include "textures/metrics.h"
#include "textures/texture_engine.h"

namespace squall::test {

textures::TextureEngine& texture_engine();

// Band-limited gradient noise, one band, 128 x 128 pixels over the unit square, the given method and velocity.
textures::AdvectSpec noise_spec(textures::Method method, int velocity_kind, std::vector<double> params = {},
                                int size = 128);

// Runs `frames` frames of the spec (overriding spec.frames).
std::vector<textures::TextureFrame> run(const textures::AdvectSpec& spec, int frames);

// Plane k of a frame as an image.
Image plane_image(const textures::TextureFrame& frame, int k);

// The largest |a - b| over plane k of two frames of the same size.
double max_abs_difference(const textures::TextureFrame& a, const textures::TextureFrame& b, int k);

}  // namespace squall::test
