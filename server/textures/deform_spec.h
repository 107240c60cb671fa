// What a content-aware deformation asks for (G. Guingo, F. Larue, B. Sauvage, N. Lutz, J.-M. Dischler,
// M.-P. Cani, "Content-aware texture deformation with dynamic control", Computers & Graphics 91, 2020),
// validated by DeformEngine::validate(spec, path). Units: the texture space in texels, texel (i, j) centred
// at (i + 0.5, j + 0.5); the flow v in texels per unit of d mu; d mu dimensionless (a reference time).
#pragma once

#include <cstdint>
#include <vector>

namespace squall::textures {

enum class DeformControlKind {
  Constant,     // d mu = d_mu everywhere
  Map,          // d mu = kappa d_mu_map(u)
  Isotropic,    // eq. 7: d mu = kappa (|A_now|_F - |A_before|_F), A = T A accumulated, T = G_now G_before^-1
  Anisotropic,  // eq. 8: d mu = kappa log(vb^T T vb), vb = v(W(u)) / |v(W(u))| (0 where |v| < 1e-6)
  Brush,        // d mu = sum of the strokes' Gaussians (sec. 5.2)
};

// A 2x2 matrix [[xx, xy], [yx, yy]] (a deformation gradient G, det > 0).
struct Tensor2 {
  double xx = 1, xy = 0, yx = 0, yy = 1;

  double determinant() const { return xx * yy - xy * yx; }
};

// d mu = strength exp(-|u - c|^2 / (2 radius^2)) at texel u (texels).
struct BrushStroke {
  double center_x = 0, center_y = 0;
  double radius = 1;
  double strength = 0;
};

// The control of the frames to come: a DeformSpec's, then changed by DeformEngine::steer.
struct DeformControl {
  DeformControlKind kind = DeformControlKind::Constant;
  double kappa = 1;
  double d_mu = 0;                   // Constant: per frame
  std::vector<float> d_mu_map;       // Map: width * height, x fastest
  Tensor2 deformation_start;         // tensor controls: G at frame 0
  Tensor2 deformation_end;           // G at frame `frames - 1`, linear in between (DeformTexture)
  std::vector<BrushStroke> strokes;  // Brush
  bool paper_dt_factor = false;      // tensor controls: d mu also times dt (eqs. 7-8 as printed)
};

struct DeformSpec {
  int width = 0, height = 0;    // texels, >= 4 each
  int channels = 1;             // planes of the texture C, 1..8
  std::vector<float> pixels;    // channels planes of width * height, x fastest
  std::vector<float> rigidity;  // R, width * height, each in [-1, 1]
  std::vector<uint8_t> chart;   // width * height, nonzero inside the chart; empty: all inside
  DeformControl control;
  // Counts as the request sent them (validated against their ranges before use, and named as sent).
  int64_t frames = 1;             // frame 0 is the undeformed texture
  double dt = 1.0 / 30;           // s between frames
  int64_t substeps = 10;          // Euler sub-steps per frame
  int64_t stack_levels = 0;       // L: stack levels h = -L..L; 0: no stack
  double tolerance = 1e-6;        // flow solve: relative residual of the normal equations
  int64_t max_iterations = 4000;  // flow solve
};

// The planes a frame carries (in this order when set).
struct DeformPlanes {
  bool color = true, warp = false, reference = false, level = false, flow = false;
};

}  // namespace squall::textures
