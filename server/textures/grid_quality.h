// The distortion of a particle's deformed grid and its vertex weights: Q. Yu, F. Neyret, E. Bruneton,
// N. Holzschuch, "Lagrangian Texture Advection: Preserving both Spectrum and Velocity Field" (IEEE TVCG
// 2011), sec. 3.3.2-3.3.3 (eqs. 1-2 and the deletion rules) and sec. 3.4.1 (eqs. 5-8).
#pragma once

#include <cstdint>
#include <vector>

#include "textures/poisson.h"

namespace squall::textures {

// A G x G lattice of vertex positions (x fastest), deformed from a regular one of spacing `spacing`.
// Each quad (a, b) is split along its (0,0)-(1,1) diagonal into two triangles.
struct GridView {
  const float* xy;  // 2 G^2 floats: x, y of vertex a + G b at [2 (a + G b)]
  int res;          // G
  double spacing;   // rest spacing g (du)
  Vec2 vertex(int a, int b) const { return {xy[2 * (a + res * b)], xy[2 * (a + res * b) + 1]}; }
};

struct GridQuality {
  std::vector<float> vertex_quality;  // Q_V: mean of Q_t over the vertex's triangles in the fluid (1 if none)
  double min_quality = 1;             // smallest Q_V over vertices with a triangle in the fluid
  double max_distortion = 1;          // largest delta_t (eq. 1)
  bool folded = false;                // some triangle has det J <= 0
};

// The two singular values (largest first) of the 2x2 matrix [[a, b], [c, d]], in closed form.
void singular_values(double a, double b, double c, double d, double& largest, double& smallest);

// Eqs. 1-2 for every triangle whose three vertices are in the fluid (outside[v] == 0).
GridQuality grid_quality(const GridView& grid, double delta_max, const std::vector<uint8_t>& outside);

// Deletion rule 1: p lies inside the grid's outline and at least d from each of its segments.
bool covers_kernel(const GridView& grid, Vec2 p, double d);

// Eqs. 5, 7, 8: w_V = K_t (1 - |V - p| / d)^+ d_V Q_V, with d_V = 0 on the grid's border and outside the fluid.
void vertex_weights(const GridView& grid, Vec2 p, double d, double temporal, const std::vector<float>& quality,
                    const std::vector<uint8_t>& outside, float* weights);

// Eq. 6: the temporal weight K_t of a particle aged `age` (s), killed `since_kill` s ago (negative while
// alive), with fade duration tau: a killed particle fades out from the weight it had when killed.
double temporal_weight(double age, double since_kill, double tau);

}  // namespace squall::textures
