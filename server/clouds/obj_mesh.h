// Wavefront OBJ text to a TriangleMesh: `v x y z` vertices (m) and `f` faces (polygons fan-triangulated;
// `i`, `i/t`, `i/t/n`, `i//n` and negative, relative indices); `#` starts a comment, on any line. Other lines
// are ignored.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "clouds/model.h"

namespace squall::clouds {

// The vertices and fanned triangles an OBJ text names, counted line by line as parse_obj reads them (a face
// of n >= 3 vertices is n - 2 triangles) without reading a number: what parsing it will store, known before.
struct ObjCounts {
  uint64_t vertices = 0, triangles = 0;
};
ObjCounts count_obj(std::string_view text);

// Throws squall::Error(InvalidArgument) naming field and the line for malformed input.
TriangleMesh parse_obj(std::string_view text, const std::string& field);

}  // namespace squall::clouds
