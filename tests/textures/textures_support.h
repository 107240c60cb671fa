// Shared pieces of the textures engine tests: the engine on the test device, request builders at the
// sizes PoCL runs quickly (128 x 128 output, Poisson radius 12 pixels, dt = 1/30 s), and frames as images.
#pragma once

#include <string>
#include <vector>

#include "textures/metrics.h"
#include "textures/texture_engine.h"

namespace squall::test {

textures::TextureEngine& texture_engine();

// Band-limited gradient noise, one band, 128 x 128 pixels over the unit square, the given method and velocity.
textures::AdvectSpec noise_spec(textures::Method method, int velocity_kind, std::vector<double> params = {},
                                int size = 128);

// The vorticity cascade's tests (F. Neyret, "Advected Textures", SCA 2003, sec. 4): the multi-layer method
// on 3 noise bands (4, 8, 16 cells per du, spin 0), 64 x 64 pixels over the unit square, 32 x 32 nodes,
// the cascade's c_w as given.
textures::AdvectSpec cascade_spec(int velocity_kind, std::vector<double> params, double c_w);

// The cascade's (w_k, theta_k) per band and node (band-major, x fastest) in an Eulerian checkpoint taken
// with the cascade on.
std::vector<float> cascade_of_checkpoint(const std::string& checkpoint);

// Runs `frames` frames of the spec (overriding spec.frames).
std::vector<textures::TextureFrame> run(const textures::AdvectSpec& spec, int frames);

// Plane k of a frame as an image.
Image plane_image(const textures::TextureFrame& frame, int k);

// The largest |a - b| over plane k of two frames of the same size.
double max_abs_difference(const textures::TextureFrame& a, const textures::TextureFrame& b, int k);

}  // namespace squall::test
