#include "clouds/obj_mesh.h"

#include <optional>
#include <sstream>

#include "common/error.h"
#include "common/validate.h"

namespace squall::clouds {

TriangleMesh parse_obj(const std::string& text, const std::string& field) {
  TriangleMesh mesh;
  mesh.from_obj = true;
  std::istringstream lines(text);
  std::string line;
  int number = 0;
  auto bad = [&](const std::string& why) {
    fail(Code::InvalidArgument, field + " line " + std::to_string(number) + ": " + why);
  };
  while (std::getline(lines, line)) {
    ++number;
    std::istringstream in(line.substr(0, line.find('#')));  // a comment runs from '#' to the line's end
    std::string tag;
    in >> tag;
    if (tag == "v") {  // x y z, then an optional w (or an exporter's colour), not read
      Vec3d v;
      for (int a = 0; a < 3; ++a) {
        std::string token;
        if (!(in >> token)) bad("a vertex needs three numbers");
        const std::optional<double> x = validate::decimal(token);
        if (!x) bad("vertex coordinate \"" + validate::printable(token) + "\" is not a finite decimal number");
        v[a] = *x;
      }
      mesh.vertices.push_back(v);
    } else if (tag == "f") {
      std::vector<uint32_t> face;
      std::string token;
      while (in >> token) {
        long index = 0;
        const std::string vertex = token.substr(0, token.find('/'));  // v/vt/vn: the vertex
        size_t used = 0;
        try {
          index = std::stol(vertex, &used);
        } catch (const std::exception&) {
        }
        if (vertex.empty() || used != vertex.size())
          bad("face index \"" + validate::printable(token) + "\" is not a whole number");
        long n = long(mesh.vertices.size());
        long resolved = index > 0 ? index - 1 : n + index;
        if (index == 0 || resolved < 0 || resolved >= n)
          bad("face index " + validate::printable(token) + " is out of range");
        face.push_back(uint32_t(resolved));
      }
      if (face.size() < 3) bad("a face needs at least three vertices");
      for (size_t k = 1; k + 1 < face.size(); ++k)
        mesh.triangles.insert(mesh.triangles.end(), {face[0], face[k], face[k + 1]});
    }
  }
  return mesh;
}

}  // namespace squall::clouds
