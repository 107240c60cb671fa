#include "clouds/obj_mesh.h"

#include <algorithm>
#include <optional>

#include "common/error.h"
#include "common/validate.h"

namespace squall::clouds {
namespace {

constexpr std::string_view kSpace = " \t\r\v\f";

// The first whitespace-separated token of `rest`, taken off its front; empty once none is left.
std::string_view take_token(std::string_view& rest) {
  const size_t start = rest.find_first_not_of(kSpace);
  if (start == std::string_view::npos) {
    rest = {};
    return {};
  }
  rest.remove_prefix(start);
  const std::string_view token = rest.substr(0, rest.find_first_of(kSpace));
  rest.remove_prefix(token.size());
  return token;
}

// Calls visit(number, tag, rest) for each line of `text`: its number from 1, its first token and the rest of
// it, a comment ('#' to the line's end) left out.
template <class Visit>
void for_each_line(std::string_view text, Visit visit) {
  for (size_t start = 0, number = 1; start <= text.size(); ++number) {
    const size_t end = std::min(text.find('\n', start), text.size());
    std::string_view rest = text.substr(start, end - start);
    rest = rest.substr(0, rest.find('#'));
    const std::string_view tag = take_token(rest);
    visit(number, tag, rest);
    start = end + 1;
  }
}

uint64_t count_tokens(std::string_view rest) {
  uint64_t n = 0;
  while (!take_token(rest).empty()) ++n;
  return n;
}

}  // namespace

ObjCounts count_obj(std::string_view text) {
  ObjCounts counts;
  for_each_line(text, [&](size_t, std::string_view tag, std::string_view rest) {
    if (tag == "v") counts.vertices += 1;
    if (tag == "f") counts.triangles += std::max<uint64_t>(count_tokens(rest), 2) - 2;
  });
  return counts;
}

TriangleMesh parse_obj(std::string_view text, const std::string& field) {
  const ObjCounts counts = count_obj(text);
  TriangleMesh mesh;
  mesh.from_obj = true;
  mesh.vertices.reserve(counts.vertices);
  mesh.triangles.reserve(3 * counts.triangles);
  std::vector<uint32_t> face;
  for_each_line(text, [&](size_t number, std::string_view tag, std::string_view rest) {
    auto bad = [&](const std::string& why) {
      fail(Code::InvalidArgument, field + " line " + std::to_string(number) + ": " + why);
    };
    if (tag == "v") {  // x y z, then an optional w (or an exporter's colour), not read
      Vec3d v;
      for (int a = 0; a < 3; ++a) {
        const std::string_view token = take_token(rest);
        if (token.empty()) bad("a vertex needs three numbers");
        const std::optional<double> x = validate::decimal(token);
        if (!x) bad("vertex coordinate \"" + validate::printable(token) + "\" is not a finite decimal number");
        v[a] = *x;
      }
      mesh.vertices.push_back(v);
    } else if (tag == "f") {
      face.clear();
      for (std::string_view token = take_token(rest); !token.empty(); token = take_token(rest)) {
        long index = 0;
        const std::string vertex(token.substr(0, token.find('/')));  // v/vt/vn: the vertex
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
  });
  return mesh;
}

}  // namespace squall::clouds
