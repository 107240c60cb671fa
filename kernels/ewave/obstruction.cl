// eWave obstruction map from shapes (J. Tessendorf, "Gilligan: A Prototype Framework for Simulating and
// Rendering Maritime Environments" (2017), sec. 3.3, eq 74): O = 0 inside a shape, 1 outside, and the covered
// fraction of each edge cell in between, estimated from SQUALL_EWAVE_SUBSAMPLES^2 points per cell.
#include "ewave/shapes.h"

static bool inside_polygon(float px, float py, __global const float* vertices, int first, int count) {
  bool inside = false;
  for (int v = 0, w = count - 1; v < count; w = v++) {
    float xv = vertices[2 * (first + v)], yv = vertices[2 * (first + v) + 1];
    float xw = vertices[2 * (first + w)], yw = vertices[2 * (first + w) + 1];
    if ((yv > py) != (yw > py) && px < (xw - xv) * (py - yv) / (yw - yv) + xv) inside = !inside;
  }
  return inside;
}

static bool inside_shape(EWaveShape s, float px, float py, __global const float* vertices) {
  if (px < s.xmin || px > s.xmax || py < s.ymin || py > s.ymax) return false;
  float dx = px - s.cx, dy = py - s.cy;
  float u = s.cos_h * dx + s.sin_h * dy;   // along the shape's a axis
  float v = -s.sin_h * dx + s.cos_h * dy;  // along its b axis
  switch (s.kind) {
    case SQUALL_EWAVE_SHAPE_CIRCLE: return dx * dx + dy * dy <= s.a * s.a;
    case SQUALL_EWAVE_SHAPE_ELLIPSE: return (u / s.a) * (u / s.a) + (v / s.b) * (v / s.b) <= 1.0f;
    case SQUALL_EWAVE_SHAPE_BOX: return fabs(u) <= s.a && fabs(v) <= s.b;
    default: return inside_polygon(px, py, vertices, s.first_vertex, s.vertex_count);
  }
}

// O[i, j] *= 1 - (fraction of the cell covered by the union of the shapes); with reset, O[i, j] = that
// factor (1 away from the shapes).
__kernel void ewave_rasterize(__global float* obstruction, __global const EWaveShape* shapes, const int shape_count,
                              __global const float* vertices, const int nx, const int ny, const float dx,
                              const float dy, const int reset) {
  uint i = get_global_id(0), j = get_global_id(1);
  if (i >= nx || j >= ny) return;
  float x0 = i * dx, y0 = j * dy, x1 = x0 + dx, y1 = y0 + dy;  // the cell's extent
  bool near = false;
  for (int s = 0; s < shape_count && !near; ++s)
    near = shapes[s].xmax >= x0 && shapes[s].xmin <= x1 && shapes[s].ymax >= y0 && shapes[s].ymin <= y1;
  if (!near) {
    if (reset) obstruction[i + nx * j] = 1.0f;
    return;
  }
  int covered = 0;
  for (int sy = 0; sy < SQUALL_EWAVE_SUBSAMPLES; ++sy) {
    float py = y0 + (sy + 0.5f) * dy / SQUALL_EWAVE_SUBSAMPLES;
    for (int sx = 0; sx < SQUALL_EWAVE_SUBSAMPLES; ++sx) {
      float px = x0 + (sx + 0.5f) * dx / SQUALL_EWAVE_SUBSAMPLES;
      bool hit = false;
      for (int s = 0; s < shape_count && !hit; ++s) hit = inside_shape(shapes[s], px, py, vertices);
      covered += hit ? 1 : 0;
    }
  }
  float base = reset ? 1.0f : obstruction[i + nx * j];
  obstruction[i + nx * j] = base * (1.0f - (float)covered / (SQUALL_EWAVE_SUBSAMPLES * SQUALL_EWAVE_SUBSAMPLES));
}
