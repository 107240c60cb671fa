// eWave obstruction shapes, shared by host C++ and OpenCL C (a struct that crosses the boundary).
//
// Layout (64 bytes, every member 4 bytes, no padding):
//   offset  0  int   kind            SQUALL_EWAVE_SHAPE_*
//   offset  4  int   first_vertex    polygon: index of its first (x, y) pair in the vertex array
//   offset  8  int   vertex_count    polygon: number of vertices (>= 3); other kinds: 0
//   offset 12  int   reserved        0
//   offset 16  float cx, cy          centre (m), grid frame: cell (i, j) has its centre at ((i+0.5)dx, (j+0.5)dy)
//   offset 24  float a, b            circle: a = radius; ellipse: semi-axes; box: half-lengths (m)
//   offset 32  float cos_h, sin_h    heading of the shape's a axis, measured from +x
//   offset 40  float xmin, ymin      bounding box (m), filled by the host
//   offset 48  float xmax, ymax
//   offset 56  float reserved2[2]
#ifndef SQUALL_EWAVE_SHAPES_H
#define SQUALL_EWAVE_SHAPES_H

#define SQUALL_EWAVE_SHAPE_CIRCLE 0
#define SQUALL_EWAVE_SHAPE_ELLIPSE 1
#define SQUALL_EWAVE_SHAPE_BOX 2
#define SQUALL_EWAVE_SHAPE_POLYGON 3

// ewave_rasterize estimates a cell's covered fraction from SUBSAMPLES x SUBSAMPLES points.
#define SQUALL_EWAVE_SUBSAMPLES 8

typedef struct {
  int kind;
  int first_vertex;
  int vertex_count;
  int reserved;
  float cx, cy;
  float a, b;
  float cos_h, sin_h;
  float xmin, ymin;
  float xmax, ymax;
  float reserved2[2];
} EWaveShape;

#ifdef __cplusplus
#include "common/host_layout.h"
SQUALL_ASSERT_SIZE(EWaveShape, 64);
SQUALL_ASSERT_OFFSET(EWaveShape, kind, 0);
SQUALL_ASSERT_OFFSET(EWaveShape, first_vertex, 4);
SQUALL_ASSERT_OFFSET(EWaveShape, vertex_count, 8);
SQUALL_ASSERT_OFFSET(EWaveShape, reserved, 12);
SQUALL_ASSERT_OFFSET(EWaveShape, cx, 16);
SQUALL_ASSERT_OFFSET(EWaveShape, cy, 20);
SQUALL_ASSERT_OFFSET(EWaveShape, a, 24);
SQUALL_ASSERT_OFFSET(EWaveShape, b, 28);
SQUALL_ASSERT_OFFSET(EWaveShape, cos_h, 32);
SQUALL_ASSERT_OFFSET(EWaveShape, sin_h, 36);
SQUALL_ASSERT_OFFSET(EWaveShape, xmin, 40);
SQUALL_ASSERT_OFFSET(EWaveShape, ymin, 44);
SQUALL_ASSERT_OFFSET(EWaveShape, xmax, 48);
SQUALL_ASSERT_OFFSET(EWaveShape, ymax, 52);
SQUALL_ASSERT_OFFSET(EWaveShape, reserved2, 56);
#endif

#endif
