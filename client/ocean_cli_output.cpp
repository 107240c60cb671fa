#include "client/ocean_cli_output.h"

#include <filesystem>
#include <iomanip>
#include <sstream>

#include "client/image_io.h"
#include "client/ocean_frames.h"

namespace squall::cli::ocean {

std::string preview_path(const Request& r) {
  if (!r.preview.empty()) return r.preview == "none" ? "" : r.preview;
  return client::preview_beside(r.out);
}

std::string frame_path(const std::string& dir, uint32_t index) {
  std::ostringstream name;
  name << dir << "/frame_" << std::setw(5) << std::setfill('0') << index << ".exr";
  return name.str();
}

void write_tile(const squall::v1::GetTileResponse& tile, const google::protobuf::Message& request,
                const std::string& exr, const std::string& png) {
  client::write_exr_and_preview(exr, client::ocean::tile_image(tile, request), png);
}

void write_samples(std::ostream& out, const Request& r, const squall::v1::SampleSurfaceResponse& s) {
  out << "x,y,source_x,source_y,height,displacement_x,displacement_y,normal_x,normal_y,normal_z\n"
      << std::setprecision(9);
  for (int i = 0; i < s.height_size(); ++i)
    out << r.points[i].first << "," << r.points[i].second << "," << s.source_x(i) << "," << s.source_y(i) << ","
        << s.height(i) << "," << s.displacement_x(i) << "," << s.displacement_y(i) << "," << s.normal_x(i) << ","
        << s.normal_y(i) << "," << s.normal_z(i) << "\n";
}

}  // namespace squall::cli::ocean
