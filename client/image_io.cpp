#include "client/image_io.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <ImfStdIO.h>
#include <ImfStringAttribute.h>
#include <png.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "client/replacing_file.h"

namespace squall::client {

void write_exr_and_preview(const std::string& exr, const Image& image, const std::string& png, Tone tone) {
  write_exr(exr, image);
  if (png.empty() || image.channels.empty()) return;
  try {
    write_png_preview(png, image.nx, image.ny, image.channels.front().values, tone);
  } catch (...) {
    std::remove(exr.c_str());
    throw;
  }
}

void add_time_attribute(Image& image, double seconds) {
  std::ostringstream t;
  t.precision(17);
  t << seconds;
  image.attributes.emplace_back("squall.time_seconds", t.str());
}

void write_exr(const std::string& path, const Image& image) {
  if (image.nx < 1 || image.ny < 1) throw std::runtime_error(path + ": image has no pixels");
  const size_t n = static_cast<size_t>(image.nx) * image.ny;
  Imf::Header header(image.nx, image.ny);
  header.compression() = Imf::ZIP_COMPRESSION;
  for (const auto& [name, value] : image.attributes) header.insert(name, Imf::StringAttribute(value));
  Imf::FrameBuffer frame;
  for (const auto& channel : image.channels) {
    if (channel.values.size() != n)
      throw std::runtime_error(path + ": channel " + channel.name + " has " + std::to_string(channel.values.size()) +
                               " values, expected " + std::to_string(n));
    header.channels().insert(channel.name, Imf::Channel(Imf::FLOAT));
    char* base = reinterpret_cast<char*>(const_cast<float*>(channel.values.data()));
    frame.insert(channel.name, Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * image.nx));
  }
  try {
    ReplacingFile out(path);
    std::ofstream stream(out.temp(), std::ios::binary | std::ios::trunc);
    if (!stream) throw std::runtime_error("cannot open it");
    {
      Imf::StdOFStream exr(stream, path.c_str());
      Imf::OutputFile file(exr, header);
      file.setFrameBuffer(frame);
      file.writePixels(image.ny);
    }  // the line offsets are written as the file closes, where OpenEXR reports no error
    stream.close();
    if (stream.fail()) throw std::runtime_error("it was not written in full (is the disk full?)");
    if (!out.commit()) throw std::runtime_error(std::string("cannot put it in place: ") + std::strerror(errno));
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot write " + path + ": " + e.what());
  }
}

std::string preview_beside(const std::string& output) {
  const std::string exr = ".exr";
  const bool has_exr = output.size() > exr.size() && output.compare(output.size() - exr.size(), exr.size(), exr) == 0;
  return (has_exr ? output.substr(0, output.size() - exr.size()) : output) + ".png";
}

namespace {

struct PngWriter {
  FILE* file = nullptr;
  png_structp png = nullptr;
  png_infop info = nullptr;
  ~PngWriter() {
    if (png) png_destroy_write_struct(&png, info ? &info : nullptr);
    if (file) std::fclose(file);
  }
};

// The sRGB encoding of a linear value in [0, 1] (IEC 61966-2-1).
double srgb_encoded(double linear) {
  return linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1 / 2.4) - 0.055;
}

std::vector<png_byte> range_grey(const std::vector<float>& values) {
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (float v : values)
    if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
  std::vector<png_byte> grey(values.size(), 0);
  for (size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) continue;
    double unit = hi > lo ? (values[i] - lo) / (double(hi) - lo) : 0.5;
    grey[i] = static_cast<png_byte>(std::lround(255 * unit));
  }
  return grey;
}

// The value that Radiance maps to white: the 99th percentile of the finite values above 0; 0 where none is.
float radiance_white(const std::vector<float>& values) {
  std::vector<float> lit;
  lit.reserve(values.size());
  for (float v : values)
    if (std::isfinite(v) && v > 0) lit.push_back(v);
  if (lit.empty()) return 0;
  auto at = lit.begin() + std::ptrdiff_t(0.99 * double(lit.size() - 1));
  std::nth_element(lit.begin(), at, lit.end());
  return *at;
}

std::vector<png_byte> radiance_grey(const std::vector<float>& values) {
  const double white = radiance_white(values);
  std::vector<png_byte> grey(values.size(), 0);
  if (!(white > 0)) return grey;
  for (size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) continue;
    const double exposed = std::clamp(values[i] / white, 0.0, 1.0);
    grey[i] = static_cast<png_byte>(std::lround(255 * srgb_encoded(exposed)));
  }
  return grey;
}

}  // namespace

std::vector<unsigned char> preview_grey(const std::vector<float>& values, Tone tone) {
  return tone == Tone::Radiance ? radiance_grey(values) : range_grey(values);
}

void write_png_preview(const std::string& path, int nx, int ny, const std::vector<float>& values, Tone tone) {
  if (nx < 1 || ny < 1 || values.size() != static_cast<size_t>(nx) * ny)
    throw std::runtime_error(path + ": preview needs nx * ny values");
  std::vector<png_byte> grey = preview_grey(values, tone);
  ReplacingFile out(path);
  PngWriter w;
  w.file = std::fopen(out.temp().c_str(), "wb");
  if (!w.file) throw std::runtime_error("cannot open " + path + " for writing");
  w.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  if (w.png) w.info = png_create_info_struct(w.png);
  if (!w.png || !w.info) throw std::runtime_error("libpng could not start writing " + path);
  if (setjmp(png_jmpbuf(w.png))) throw std::runtime_error("libpng failed writing " + path);
  png_init_io(w.png, w.file);
  png_set_IHDR(w.png, w.info, nx, ny, 8, PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(w.png, w.info);
  for (int j = 0; j < ny; ++j) png_write_row(w.png, grey.data() + static_cast<size_t>(j) * nx);
  png_write_end(w.png, nullptr);
  const int flushed = std::fflush(w.file), closed = std::fclose(w.file);
  w.file = nullptr;
  if (flushed != 0 || closed != 0 || !out.commit()) throw std::runtime_error("cannot write " + path);
}

}  // namespace squall::client
