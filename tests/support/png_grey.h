// Reads a PNG back as 8-bit grey with libpng's simplified API, as another tool would read our previews.
#pragma once

#include <png.h>

#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace squall::test {

struct GreyImage {
  int width = 0;
  int height = 0;
  std::vector<png_byte> pixels;  // width * height, x fastest
};

inline GreyImage read_png_grey(const std::string& path) {
  png_image png;
  std::memset(&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&png, path.c_str())) throw std::runtime_error(path + ": " + png.message);
  png.format = PNG_FORMAT_GRAY;
  GreyImage image{int(png.width), int(png.height), std::vector<png_byte>(PNG_IMAGE_SIZE(png))};
  if (!png_image_finish_read(&png, nullptr, image.pixels.data(), 0, nullptr))
    throw std::runtime_error(path + ": " + png.message);
  return image;
}

}  // namespace squall::test
