#include "clouds/noise.h"

#include <algorithm>
#include <cmath>

namespace squall::clouds {
namespace {

// Perlin's reference permutation (Improved Noise, 2002), repeated to 512 entries on use.
constexpr std::array<int, 256> kPermutation = {
    151, 160, 137, 91,  90,  15,  131, 13,  201, 95,  96,  53,  194, 233, 7,   225, 140, 36,  103, 30,  69,  142,
    8,   99,  37,  240, 21,  10,  23,  190, 6,   148, 247, 120, 234, 75,  0,   26,  197, 62,  94,  252, 219, 203,
    117, 35,  11,  32,  57,  177, 33,  88,  237, 149, 56,  87,  174, 20,  125, 136, 171, 168, 68,  175, 74,  165,
    71,  134, 139, 48,  27,  166, 77,  146, 158, 231, 83,  111, 229, 122, 60,  211, 133, 230, 220, 105, 92,  41,
    55,  46,  245, 40,  244, 102, 143, 54,  65,  25,  63,  161, 1,   216, 80,  73,  209, 76,  132, 187, 208, 89,
    18,  169, 200, 196, 135, 130, 116, 188, 159, 86,  164, 100, 109, 198, 173, 186, 3,   64,  52,  217, 226, 250,
    124, 123, 5,   202, 38,  147, 118, 126, 255, 82,  85,  212, 207, 206, 59,  227, 47,  16,  58,  17,  182, 189,
    28,  42,  223, 183, 170, 213, 119, 248, 152, 2,   44,  154, 163, 70,  221, 153, 101, 155, 167, 43,  172, 9,
    129, 22,  39,  253, 19,  98,  108, 110, 79,  113, 224, 232, 178, 185, 112, 104, 218, 246, 97,  228, 251, 34,
    242, 193, 238, 210, 144, 12,  191, 179, 162, 241, 81,  51,  145, 235, 249, 14,  239, 107, 49,  192, 214, 31,
    181, 199, 106, 157, 184, 84,  204, 176, 115, 121, 50,  45,  127, 4,   150, 254, 138, 236, 205, 93,  222, 114,
    67,  29,  24,  72,  243, 141, 128, 195, 78,  66,  215, 61,  156, 180};

int perm(int i) { return kPermutation[i & 255]; }
double fade(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }
double lerp(double t, double a, double b) { return a + t * (b - a); }
double grad(int hash, double x, double y, double z) {
  int h = hash & 15;
  double u = h < 8 ? x : y;
  double v = h < 4 ? y : (h == 12 || h == 14 ? x : z);
  return ((h & 1) == 0 ? u : -u) + ((h & 2) == 0 ? v : -v);
}

}  // namespace

double perlin(const Vec3d& p) {
  double fx = std::floor(p[0]), fy = std::floor(p[1]), fz = std::floor(p[2]);
  // The lattice repeats every 256 cells: the cell reduced in double first (exact), so that a cell past
  // int's range is not converted.
  auto cell = [](double f) { return static_cast<int>(f - 256 * std::floor(f / 256)) & 255; };
  int X = cell(fx), Y = cell(fy), Z = cell(fz);
  double x = p[0] - fx, y = p[1] - fy, z = p[2] - fz;
  double u = fade(x), v = fade(y), w = fade(z);
  int A = perm(X) + Y, AA = perm(A) + Z, AB = perm(A + 1) + Z;
  int B = perm(X + 1) + Y, BA = perm(B) + Z, BB = perm(B + 1) + Z;
  double n = lerp(w,
                  lerp(v, lerp(u, grad(perm(AA), x, y, z), grad(perm(BA), x - 1, y, z)),
                       lerp(u, grad(perm(AB), x, y - 1, z), grad(perm(BB), x - 1, y - 1, z))),
                  lerp(v, lerp(u, grad(perm(AA + 1), x, y, z - 1), grad(perm(BA + 1), x - 1, y, z - 1)),
                       lerp(u, grad(perm(AB + 1), x, y - 1, z - 1), grad(perm(BB + 1), x - 1, y - 1, z - 1))));
  return std::clamp(n, -1.0, 1.0);
}

double fractal_noise(const NoiseParams& params, const Vec3d& x) {
  double sum = 0, bound = 0, amplitude = 1, frequency = params.frequency;
  for (int i = 0; i < params.octaves; ++i) {  // eq 3.6
    Vec3d p{(x[0] + params.offset[0]) * frequency, (x[1] + params.offset[1]) * frequency,
            (x[2] + params.offset[2]) * frequency};
    sum += amplitude * perlin(p);
    bound += amplitude;
    amplitude *= params.roughness;
    frequency *= params.frequency_jump;
  }
  return sum / bound;
}

}  // namespace squall::clouds
