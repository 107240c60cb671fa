// Noise for cloud modeling: Ken Perlin's improved noise (2002, his reference permutation table, so host
// and device can agree) and its fractal sum (eq 3.6 of J. Tessendorf and M. Kowalski, "Resolution Independent
// Volumes" (SIGGRAPH course notes 2010/2011, App. D of J. Tessendorf, "Gilligan: A Prototype Framework for
// Simulating and Rendering Maritime Environments" (2017)); Gilligan eqs 108/110):
//   FS(x) = sum_{i<octaves} r^i PN(x f_jump^i),  r = roughness, f_jump = frequency jump.
#pragma once

#include <array>

namespace squall::clouds {

using Vec3d = std::array<double, 3>;

// Perlin's improved noise at p (dimensionless lattice units); |PN| <= 1 (clamped).
double perlin(const Vec3d& p);

struct NoiseParams {
  double frequency = 1.0;       // base spatial frequency, 1/m; > 0
  int octaves = 4;              // fractal octaves, 1..16
  double roughness = 0.5;       // amplitude ratio between octaves r, (0, 1]
  double frequency_jump = 2.2;  // frequency ratio between octaves f_jump, [1, 8]
  Vec3d offset{0, 0, 0};        // translation of the noise pattern, m (animates it)
};

// Fractal sum FS(x) divided by its bound sum_i r^i, so the result lies in [-1, 1]. x in metres.
double fractal_noise(const NoiseParams& params, const Vec3d& x);

}  // namespace squall::clouds
