#include "client/texture_cli_flags.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "client/cli_flags.h"
#include "server/common/field_codec.h"

namespace squall::cli::texture {
namespace {

namespace v1 = squall::v1;

// R, G, B, A first (in that order), then the others in the file's (alphabetical) order.
std::vector<std::string> exr_channel_order(const Imf::ChannelList& list) {
  std::vector<std::string> names;
  for (auto it = list.begin(); it != list.end(); ++it) names.push_back(it.name());
  auto rank = [](const std::string& name) {
    const std::string order = "RGBA";
    return name.size() == 1 && order.find(name[0]) != std::string::npos ? int(order.find(name[0])) : 4;
  };
  std::stable_sort(names.begin(), names.end(),
                   [&](const std::string& a, const std::string& b) { return rank(a) < rank(b); });
  if (names.size() > 8) names.resize(8);
  return names;
}

// Up to 8 channels of an EXR file as float32 Fields; scanline j becomes texture row j (as write_exr writes).
void read_exr(const std::string& path, v1::ImageTexture* image) {
  Imf::InputFile file(path.c_str());
  const Imath::Box2i window = file.header().dataWindow();
  const int nx = window.max.x - window.min.x + 1, ny = window.max.y - window.min.y + 1;
  const std::vector<std::string> names = exr_channel_order(file.header().channels());
  std::vector<std::vector<float>> planes(names.size(), std::vector<float>(size_t(nx) * ny));
  Imf::FrameBuffer frame;
  const ptrdiff_t first = ptrdiff_t(window.min.x) + ptrdiff_t(window.min.y) * nx;  // the window's first pixel
  for (size_t c = 0; c < names.size(); ++c) {
    char* base = reinterpret_cast<char*>(planes[c].data()) - first * ptrdiff_t(sizeof(float));
    frame.insert(names[c], Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * size_t(nx)));
  }
  file.setFrameBuffer(frame);
  file.readPixels(window.min.y, window.max.y);
  for (size_t c = 0; c < names.size(); ++c)
    squall::field::encode({names[c], "1", uint32_t(nx), uint32_t(ny), 0, v1::DTYPE_FLOAT32}, planes[c],
                          image->add_channels());
}

}  // namespace

// A comma-separated list of one of the allowed lengths.
std::vector<double> numbers(const std::string& flag, const std::string& text, std::vector<size_t> lengths) {
  std::string allowed;
  for (size_t n : lengths) allowed += (allowed.empty() ? "" : " or ") + std::to_string(n);
  if (text.empty()) throw UsageError(flag + ": needs " + allowed + " numbers, none given");
  const std::vector<double> out = number_list(flag, text);
  if (std::find(lengths.begin(), lengths.end(), out.size()) == lengths.end())
    throw UsageError(flag + " " + text + ": needs " + allowed + " numbers");
  return out;
}

void image_flag(const std::string& flag, const std::string& path, v1::ImageTexture* image) {
  image->Clear();  // the last --image given
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext == ".png" || ext == ".PNG") return image->set_png(read_bytes(flag, path));
  if (ext != ".exr" && ext != ".EXR") throw UsageError(flag + " " + path + ": must be a .exr or .png file");
  read_bytes(flag, path);  // a clear message for a missing file
  try {
    read_exr(path, image);
  } catch (const std::exception& e) {
    throw UsageError(flag + " " + path + ": " + e.what());
  }
}

v1::RiverVelocity river_file(const std::string& flag, const std::string& path) {
  v1::RiverVelocity river;
  const auto status = google::protobuf::util::JsonStringToMessage(read_bytes(flag, path), &river);
  if (!status.ok())
    throw UsageError(flag + " " + path + ": not a RiverVelocity in JSON: " + std::string(status.message()));
  return river;
}

}  // namespace squall::cli::texture
