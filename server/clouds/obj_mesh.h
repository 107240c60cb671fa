// Wavefront OBJ text to a TriangleMesh: `v x y z` vertices (m) and `f` faces (polygons fan-triangulated;
// `i`, `i/t`, `i/t/n`, `i//n` and negative, relative indices); `#` starts a comment, on any line. Other lines
// are ignored.
#pragma once

#include <string>

#include "clouds/model.h"

namespace squall::clouds {

// Throws squall::Error(InvalidArgument) naming field and the line for malformed input.
TriangleMesh parse_obj(const std::string& text, const std::string& field);

}  // namespace squall::clouds
