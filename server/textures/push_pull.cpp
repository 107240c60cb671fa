#include "textures/push_pull.h"

#include <algorithm>
#include <array>

namespace squall::textures {
namespace {

// One pyramid level: (u * w, v * w, w) sums normalized to (u, v) where w > 0.
struct Level {
  int nx = 0, ny = 0;
  std::vector<std::array<float, 3>> uvw;  // u, v (averages where w > 0), w (valid fraction)
  std::array<float, 3>& at(int i, int j) { return uvw[size_t(i) + size_t(nx) * size_t(j)]; }
};

Level pull(Level& fine) {
  Level coarse{(fine.nx + 1) / 2, (fine.ny + 1) / 2, {}};
  coarse.uvw.assign(size_t(coarse.nx) * coarse.ny, {0, 0, 0});
  for (int j = 0; j < fine.ny; ++j) {
    for (int i = 0; i < fine.nx; ++i) {
      auto& f = fine.at(i, j);
      auto& c = coarse.at(i / 2, j / 2);
      c[0] += f[0] * f[2];
      c[1] += f[1] * f[2];
      c[2] += f[2];
    }
  }
  for (auto& c : coarse.uvw) {
    if (c[2] > 0) c = {c[0] / c[2], c[1] / c[2], std::min(c[2], 1.0f)};
  }
  return coarse;
}

// Fills the empty nodes of `fine` from `coarse`, bilinearly between coarse node centres.
void push(const Level& coarse, Level& fine) {
  for (int j = 0; j < fine.ny; ++j) {
    for (int i = 0; i < fine.nx; ++i) {
      auto& f = fine.at(i, j);
      if (f[2] > 0) continue;
      float x = std::clamp((i + 0.5f) / 2 - 0.5f, 0.0f, float(coarse.nx - 1));
      float y = std::clamp((j + 0.5f) / 2 - 0.5f, 0.0f, float(coarse.ny - 1));
      int i0 = std::min(int(x), std::max(coarse.nx - 2, 0)), j0 = std::min(int(y), std::max(coarse.ny - 2, 0));
      int i1 = std::min(i0 + 1, coarse.nx - 1), j1 = std::min(j0 + 1, coarse.ny - 1);
      float s = x - i0, r = y - j0;
      for (int k = 0; k < 2; ++k) {
        auto c = [&](int a, int b) { return coarse.uvw[size_t(a) + size_t(coarse.nx) * b][k]; };
        f[k] = (1 - r) * ((1 - s) * c(i0, j0) + s * c(i1, j0)) + r * ((1 - s) * c(i0, j1) + s * c(i1, j1));
      }
      f[2] = 1;
    }
  }
}

}  // namespace

void push_pull(int nx, int ny, const std::vector<uint8_t>& mask, std::vector<float>& u, std::vector<float>& v) {
  std::vector<Level> pyramid(1);
  pyramid[0] = {nx, ny, {}};
  pyramid[0].uvw.resize(size_t(nx) * ny);
  for (size_t n = 0; n < pyramid[0].uvw.size(); ++n)
    pyramid[0].uvw[n] = {mask[n] ? u[n] : 0.0f, mask[n] ? v[n] : 0.0f, mask[n] ? 1.0f : 0.0f};
  while (pyramid.back().nx > 1 || pyramid.back().ny > 1) pyramid.push_back(pull(pyramid.back()));
  for (auto& c : pyramid.back().uvw) c[2] = 1;  // the top level is complete (zero without valid nodes)
  for (size_t l = pyramid.size() - 1; l > 0; --l) push(pyramid[l], pyramid[l - 1]);
  for (size_t n = 0; n < pyramid[0].uvw.size(); ++n) {
    u[n] = pyramid[0].uvw[n][0];
    v[n] = pyramid[0].uvw[n][1];
  }
}

bool fills_solid_nodes(const VelocitySpec& grid) {
  return grid.extrapolation == Extrapolation::PushPull && !grid.mask.empty();
}

VelocityFrame sampled_frame(const VelocitySpec& grid, const VelocityFrame& frame) {
  VelocityFrame sampled = frame;
  if (fills_solid_nodes(grid)) push_pull(grid.nx, grid.ny, grid.mask, sampled.u, sampled.v);
  return sampled;
}

}  // namespace squall::textures
