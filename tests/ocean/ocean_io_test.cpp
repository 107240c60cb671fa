// The host side of the Ocean service that needs no device: float16 conversion (exhaustive, against
// OpenEXR's Imath), the OpenEXR and PNG writers (read back with OpenEXR's and libpng's own readers),
// StreamTiles chunk planning, the client's frame reassembly and the Field codec (common/field_codec.h).
#include <Imath/half.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfStringAttribute.h>
#include <gtest/gtest.h>

#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <thread>

#include "client/image_io.h"
#include "client/ocean_frames.h"
#include "common/error.h"
#include "common/field_codec.h"
#include "common/float16.h"
#include "ocean/ocean_request.h"
#include "ocean/tile_chunks.h"
#include "support/expect_error.h"
#include "support/png_grey.h"
#include "support/process.h"

namespace squall {
namespace {

bool is_nan_bits(uint32_t f) { return (f & 0x7fffffffu) > 0x7f800000u; }

// Every one of the 2^32 floats converts exactly as Imath's imath_float_to_half (round to nearest even);
// NaNs stay NaN with their sign. Two threads, half the range each.
TEST(Float16, EveryFloatRoundsAsImath) {
  std::atomic<uint64_t> mismatches{0}, nan_failures{0};
  std::atomic<uint32_t> first_bad{0};
  auto check_range = [&](uint64_t begin, uint64_t end) {
    uint64_t bad = 0, bad_nan = 0;
    for (uint64_t u = begin; u < end; ++u) {
      uint32_t bits = uint32_t(u);
      float f;
      std::memcpy(&f, &bits, 4);
      uint16_t mine = f16::from_float(f);
      if (is_nan_bits(bits)) {
        bool nan = (mine & 0x7c00u) == 0x7c00u && (mine & 0x3ffu) != 0 && (mine & 0x8000u) == ((bits >> 16) & 0x8000u);
        bad_nan += !nan;
      } else if (mine != imath_float_to_half(f)) {
        if (bad++ == 0) first_bad = bits;
      }
    }
    mismatches += bad;
    nan_failures += bad_nan;
  };
  std::thread other(check_range, 0, 1ull << 31);
  check_range(1ull << 31, 1ull << 32);
  other.join();
  EXPECT_EQ(mismatches.load(), 0u) << "first mismatch at float bits " << std::hex << first_bad.load();
  EXPECT_EQ(nan_failures.load(), 0u);
}

TEST(Float16, RoundingCasesByHand) {
  EXPECT_EQ(f16::from_float(1.0f), 0x3c00);
  EXPECT_EQ(f16::from_float(65504.0f), 0x7bff);               // largest half
  EXPECT_EQ(f16::from_float(65519.996f), 0x7bff);             // just below the halfway point to 65536
  EXPECT_EQ(f16::from_float(65520.0f), 0x7c00);               // the tie goes to even: inf
  EXPECT_EQ(f16::from_float(1.0f + 1.0f / 2048), 0x3c00);     // tie between 1 and 1+2^-10: even (1)
  EXPECT_EQ(f16::from_float(1.0f + 3.0f / 2048), 0x3c02);     // tie between 1+2^-10 and 1+2^-9: even (up)
  EXPECT_EQ(f16::from_float(std::ldexp(1.0f, -24)), 0x0001);  // smallest subnormal
  EXPECT_EQ(f16::from_float(std::ldexp(1.0f, -25)), 0x0000);  // half of it: tie to even zero
  EXPECT_EQ(f16::from_float(std::ldexp(1.5f, -25)), 0x0001);
  EXPECT_EQ(f16::from_float(-0.0f), 0x8000);
  EXPECT_EQ(f16::from_float(-INFINITY), 0xfc00);
}

// Every half converts back to the float Imath gives (exact), and from_float(to_float(h)) == h.
TEST(Float16, EveryHalfConvertsBackExactly) {
  int bad = 0, bad_round_trip = 0;
  for (uint32_t h = 0; h < 65536; ++h) {
    float mine = f16::to_float(uint16_t(h));
    float ref = imath_half_to_float(uint16_t(h));
    uint32_t a, b;
    std::memcpy(&a, &mine, 4);
    std::memcpy(&b, &ref, 4);
    bool nan = (h & 0x7c00u) == 0x7c00u && (h & 0x3ffu);
    bad += nan ? !std::isnan(mine) : a != b;
    if (!nan) bad_round_trip += f16::from_float(mine) != h;
  }
  EXPECT_EQ(bad, 0);
  EXPECT_EQ(bad_round_trip, 0);
}

// An EXR written by write_exr, read back with OpenEXR's own InputFile: identical pixels and attributes.
TEST(ImageIo, ExrReadsBackWithOpenExr) {
  client::Image image;
  image.nx = 37;
  image.ny = 23;  // not square, not a power of two: catches a swapped stride
  std::mt19937 rng(3);
  std::normal_distribution<float> normal;
  for (const char* name : {"height", "displacement_x", "normal_z"}) {
    client::Channel c{name, std::vector<float>(size_t(image.nx) * image.ny)};
    for (auto& v : c.values) v = normal(rng);
    image.channels.push_back(std::move(c));
  }
  image.channels[0].values[5] = -0.0f;
  image.channels[0].values[6] = std::ldexp(1.0f, -140);  // a float subnormal survives too
  image.attributes = {{"squall.request.tile.choppiness", "1.5"},
                      {"squall.request.tile.layers[0].spectrum", "SPECTRUM_MODEL_JONSWAP"}};
  std::string path = test::temp_dir("exr") + "/tile.exr";
  client::write_exr(path, image);

  Imf::InputFile file(path.c_str());
  const Imf::Header& header = file.header();
  Imath::Box2i window = header.dataWindow();
  ASSERT_EQ(window.max.x - window.min.x + 1, image.nx);
  ASSERT_EQ(window.max.y - window.min.y + 1, image.ny);
  for (const auto& [name, value] : image.attributes) {
    const auto* attribute = header.findTypedAttribute<Imf::StringAttribute>(name);
    ASSERT_NE(attribute, nullptr) << name;
    EXPECT_EQ(attribute->value(), value);
  }
  Imf::FrameBuffer frame;
  std::vector<std::vector<float>> read(image.channels.size(), std::vector<float>(size_t(image.nx) * image.ny));
  for (size_t c = 0; c < image.channels.size(); ++c) {
    const Imf::Channel* channel = header.channels().findChannel(image.channels[c].name);
    ASSERT_NE(channel, nullptr) << image.channels[c].name;
    EXPECT_EQ(channel->type, Imf::FLOAT);
    frame.insert(image.channels[c].name, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(read[c].data()), sizeof(float),
                                                    sizeof(float) * image.nx));
  }
  file.setFrameBuffer(frame);
  file.readPixels(window.min.y, window.max.y);
  for (size_t c = 0; c < image.channels.size(); ++c)
    EXPECT_EQ(std::memcmp(read[c].data(), image.channels[c].values.data(), read[c].size() * 4), 0)
        << image.channels[c].name;
}

TEST(ImageIo, ExrRejectsAChannelOfTheWrongSize) {
  client::Image image{4, 4, {{"height", std::vector<float>(15)}}, {}};
  EXPECT_THROW(client::write_exr(test::temp_dir("exr-bad") + "/x.exr", image), std::runtime_error);
}

// Reads a whole file's bytes.
std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// While alive, no file grows past `bytes` (RLIMIT_FSIZE): a write past it fails as on a full disk
// (EFBIG; SIGXFSZ ignored), then the limit and the signal are restored.
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) : old_signal_(std::signal(SIGXFSZ, SIG_IGN)) {
    getrlimit(RLIMIT_FSIZE, &old_);
    rlimit limited = old_;
    limited.rlim_cur = bytes;
    setrlimit(RLIMIT_FSIZE, &limited);
  }
  ~FileSizeLimit() {
    setrlimit(RLIMIT_FSIZE, &old_);
    std::signal(SIGXFSZ, old_signal_);
  }

 private:
  rlimit old_{};
  void (*old_signal_)(int);
};

// An image file that cannot be written in full (the disk fills) leaves the file that was there as it was,
// and nothing beside it: the EXR and the PNG go to a temporary file renamed over the old one once whole.
TEST(ImageIo, AWriteThatFailsLeavesTheFileThatWasThere) {
  const std::string dir = test::temp_dir("exr-full");
  const int n = 256;
  client::Image small{2, 2, {{"height", std::vector<float>(4, 1.0f)}}, {}};
  client::Image large{n, n, {{"height", std::vector<float>(size_t(n) * n)}}, {}};
  std::mt19937 rng(5);
  std::normal_distribution<float> normal;
  for (float& v : large.channels[0].values) v = normal(rng);  // noise: 256 KiB that ZIP barely shrinks
  client::write_exr(dir + "/tile.exr", small);
  client::write_png_preview(dir + "/tile.png", 2, 2, small.channels[0].values);
  const std::string exr = file_bytes(dir + "/tile.exr"), png = file_bytes(dir + "/tile.png");
  {
    const FileSizeLimit full(16 << 10);
    EXPECT_THROW(client::write_exr(dir + "/tile.exr", large), std::runtime_error);
    EXPECT_THROW(client::write_png_preview(dir + "/tile.png", n, n, large.channels[0].values), std::runtime_error);
  }
  EXPECT_TRUE(file_bytes(dir + "/tile.exr") == exr) << "the EXR that was there changed";
  EXPECT_TRUE(file_bytes(dir + "/tile.png") == png) << "the PNG that was there changed";
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 2) << "a temporary file was left";
  client::write_exr(dir + "/tile.exr", large);
  EXPECT_GT(file_bytes(dir + "/tile.exr").size(), size_t(16 << 10)) << "the limit was lifted";
  // The file replaced keeps its mode.
  std::filesystem::permissions(dir + "/tile.exr", std::filesystem::perms(0640));
  client::write_exr(dir + "/tile.exr", large);
  EXPECT_EQ(std::filesystem::status(dir + "/tile.exr").permissions(), std::filesystem::perms(0640));
  // A symbolic link is written through, as named (so is a device: /dev/full fails as a full disk).
  std::filesystem::create_symlink("tile.exr", dir + "/link.exr");
  client::write_exr(dir + "/link.exr", small);
  EXPECT_TRUE(std::filesystem::is_symlink(dir + "/link.exr"));
  EXPECT_TRUE(file_bytes(dir + "/tile.exr") == exr) << "not written through the link";
}

// The PNG preview maps [min, max] to [0, 255]: read back with libpng, the minimum is 0, the maximum 255
// and a value a third of the way up is 85.
TEST(ImageIo, PngPreviewSpansTheRange) {
  const int nx = 5, ny = 3;
  std::vector<float> v(nx * ny, -1.0f);
  v[0] = -4;  // min
  v[14] = 5;  // max
  v[7] = -1;  // (-1 - -4) / 9 = 1/3 -> 85
  std::string path = test::temp_dir("png") + "/p.png";
  client::write_png_preview(path, nx, ny, v);
  const test::GreyImage png = test::read_png_grey(path);
  ASSERT_EQ(png.width, nx);
  ASSERT_EQ(png.height, ny);
  EXPECT_EQ(png.pixels[0], 0);
  EXPECT_EQ(png.pixels[14], 255);
  EXPECT_EQ(png.pixels[7], 85);
}

// A radiance preview is exposed so that the 99th percentile of what is lit (above 0) is white, clipped
// above it and sRGB-encoded: of 0, 1, ..., 100 (49.5 for 50), 99 is white, 100 clipped to it, 98 is
// 255 * (1.055 * (98/99)^(1/2.4) - 0.055) = 253.9, 254, and 49.5 (half of white) 187.5, 188. However many
// pixels are dark, the lit ones set the exposure; negative and non-finite values are black, and an image
// with nothing lit stays black.
TEST(ImageIo, ARadiancePreviewIsExposedAtThe99thPercentileAndSrgbEncoded) {
  std::vector<float> ramp(101);
  for (int i = 0; i <= 100; ++i) ramp[i] = float(i);
  ramp[50] = 49.5f;
  const std::vector<unsigned char> grey = client::preview_grey(ramp, client::Tone::Radiance);
  EXPECT_EQ(grey[0], 0);
  EXPECT_EQ(grey[50], 188);
  EXPECT_EQ(grey[98], 254);
  EXPECT_EQ(grey[99], 255);
  EXPECT_EQ(grey[100], 255);
  std::vector<float> mostly_dark(10000, 0.0f);
  std::copy(ramp.begin(), ramp.end(), mostly_dark.begin());
  EXPECT_EQ(client::preview_grey(mostly_dark, client::Tone::Radiance)[98], 254);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(client::preview_grey({-1, 2, nan, 0}, client::Tone::Radiance), (std::vector<unsigned char>{0, 255, 0, 0}));
  EXPECT_EQ(client::preview_grey({0, 0, nan}, client::Tone::Radiance), (std::vector<unsigned char>{0, 0, 0}));
}

// A lamp's inverse-square glow (1 / max(d, 0.5)^2 over 101 x 101 pixels, d in pixels from the centre):
// mapped by its range only the few pixels next to the lamp are above a tenth of white, where the
// radiance preview shows the glow over most of the image.
TEST(ImageIo, ARadiancePreviewShowsALampsGlowThatTheRangeHidesInADot) {
  const int n = 101;
  std::vector<float> glow(size_t(n) * n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      glow[size_t(j) * n + i] = float(1 / std::pow(std::max(std::hypot(i - 50, j - 50), 0.5), 2));
  auto lit = [&](client::Tone tone) {
    const std::vector<unsigned char> grey = client::preview_grey(glow, tone);
    return double(std::count_if(grey.begin(), grey.end(), [](unsigned char g) { return g >= 26; })) / grey.size();
  };
  EXPECT_LT(lit(client::Tone::Range), 0.002);
  EXPECT_GT(lit(client::Tone::Radiance), 0.6);
}

// A frame of 3 fields of 10 rows of 1000 bytes with 2600 bytes per chunk: 2 rows (+ headers) per chunk,
// every row of every field exactly once, in order.
TEST(TileChunks, PlanCoversEveryRowOnceWithinTheBudget) {
  std::vector<uint64_t> row_bytes = {1000, 1000, 1000};
  std::vector<uint32_t> ny = {10, 10, 10};
  auto plan = ocean::rpc::plan_chunks(row_bytes, ny, 2600);
  std::vector<std::vector<int>> seen(3, std::vector<int>(10, 0));
  for (const auto& chunk : plan) {
    uint64_t bytes = 0;
    for (const auto& p : chunk) {
      bytes += p.rows * row_bytes[p.field] + 128;
      for (uint32_t r = p.row; r < p.row + p.rows; ++r) seen[p.field][r]++;
    }
    EXPECT_LE(bytes, 2600u);
  }
  for (const auto& f : seen)
    for (int count : f) EXPECT_EQ(count, 1);
  EXPECT_EQ(plan.size(), 15u);
  // Everything fits in one chunk when the budget allows.
  EXPECT_EQ(ocean::rpc::plan_chunks(row_bytes, ny, 1u << 20).size(), 1u);
  // A row larger than a message cannot be sent.
  EXPECT_THROW(ocean::rpc::plan_chunks({5000}, {2}, 2600), Error);
}

// A frame of 1 or 2 float32 fields "f0", "f1" holding 1000 f + i at index i.
squall::v1::GetTileResponse frame_of(int fields, uint32_t nx, uint32_t ny, double t) {
  squall::v1::GetTileResponse frame;
  frame.mutable_time()->set_seconds(t);
  frame.mutable_stats()->set_unresolved_slope_variance(0.25);
  for (int f = 0; f < fields; ++f) {
    auto* field = frame.add_fields();
    field->set_name(f == 0 ? "f0" : "f1");
    field->set_unit("m");
    field->set_nx(nx);
    field->set_ny(ny);
    field->mutable_spacing()->set_x(0.5);
    field->mutable_spacing()->set_y(0.25);
    field->mutable_origin();  // (0, 0, 0), present, as the service sends it
    field->set_dtype(squall::v1::DTYPE_FLOAT32);
    std::vector<float> v(nx * ny);
    for (size_t i = 0; i < v.size(); ++i) v[i] = float(f * 1000 + i);
    field->set_data(std::string(reinterpret_cast<const char*>(v.data()), v.size() * 4));
  }
  return frame;
}

// Chunks made by fill_chunk and reassembled by the client's FrameAssembler give back the frame, byte
// for byte, both when fields are split into bands of rows and when whole fields travel (moved, not
// copied); each piece carries the world origin of its first row.
TEST(TileChunks, ChunksReassembleToTheFrame) {
  const auto frame = frame_of(2, 16, 9, 1.5);
  for (uint64_t budget : {uint64_t(4 * 64 + 128), uint64_t(1) << 20}) {
    auto plan = ocean::rpc::plan_chunks({64, 64}, {9, 9}, budget);
    EXPECT_EQ(plan.size(), budget < 1000 ? 5u : 1u);  // rows 4 / 4 / 1 + 1 (shared) / 4 / 4
    auto sent = frame;                                // fill_chunk moves whole fields out of the frame
    client::ocean::FrameAssembler assembler;
    std::optional<squall::v1::GetTileResponse> out;
    for (uint32_t c = 0; c < plan.size(); ++c) {
      squall::v1::TileChunk chunk;
      ocean::rpc::fill_chunk(sent, plan, c, 7, &chunk);
      for (const auto& p : chunk.pieces()) EXPECT_DOUBLE_EQ(p.field().origin().y(), p.row_offset() * 0.25);
      EXPECT_FALSE(out.has_value());
      if (c == 0 && plan.size() > 1) {
        squall::v1::TileChunk wrong = chunk;
        wrong.set_chunk_index(1);
        client::ocean::FrameAssembler fresh;
        EXPECT_THROW(fresh.add(wrong), std::runtime_error);  // a stream that starts mid-frame
      }
      out = assembler.add(chunk);
    }
    ASSERT_TRUE(out.has_value());
    EXPECT_TRUE(out->SerializeAsString() == frame.SerializeAsString()) << out->ShortDebugString().substr(0, 400);
    EXPECT_EQ(client::ocean::values(out->fields(1))[3], 1003.0f);
  }
}

TEST(ClientValues, Float16FieldsDecode) {
  squall::v1::Field field;
  field.set_nx(2);
  field.set_ny(1);
  field.set_dtype(squall::v1::DTYPE_FLOAT16);
  const float in[2] = {1.5f, -2.0f};
  std::string bytes;
  f16::append_half_bytes(in, 2, &bytes);
  field.set_data(bytes);
  auto v = client::ocean::values(field);
  EXPECT_EQ(v[0], 1.5f);
  EXPECT_EQ(v[1], -2.0f);
  field.set_nx(3);
  EXPECT_THROW(client::ocean::values(field), std::runtime_error);
}

// The message of the InvalidArgument error `f` throws ("" and a failure if it throws none or another).
std::string invalid_argument(const std::function<void()>& f) {
  return test::expect_error(Code::InvalidArgument, "", f);
}

std::vector<uint32_t> bits_of(const std::vector<float>& v) {
  std::vector<uint32_t> out(v.size());
  std::memcpy(out.data(), v.data(), v.size() * 4);
  return out;
}

// float32 fields carry their values bit for bit (-0, a float subnormal, inf included), with the header
// as given; a 3D field counts nx * ny * nz values.
TEST(FieldCodec, Float32RoundTripIsExact) {
  const std::vector<float> in = {0.0f,     -0.0f,     1.0f,     -1.5f,     3.1415927f, 1e30f, std::ldexp(1.0f, -140),
                                 INFINITY, -INFINITY, 6.02e23f, -7.25e-3f, 42.0f};
  squall::v1::Field f;
  field::encode({"height", "m", 4, 3, 0, squall::v1::DTYPE_FLOAT32}, in, &f);
  EXPECT_EQ(f.name(), "height");
  EXPECT_EQ(f.unit(), "m");
  EXPECT_EQ(f.nx(), 4u);
  EXPECT_EQ(f.ny(), 3u);
  EXPECT_EQ(f.dtype(), squall::v1::DTYPE_FLOAT32);
  EXPECT_EQ(f.data().size(), 12u * 4);
  EXPECT_EQ(field::value_count(f), 12u);
  EXPECT_EQ(bits_of(field::decode(f, "fields[0]")), bits_of(in));

  squall::v1::Field cube;
  field::encode({"density", "kg/m^3", 2, 3, 2, squall::v1::DTYPE_FLOAT32}, in, &cube);
  EXPECT_EQ(cube.nz(), 2u);
  EXPECT_EQ(bits_of(field::decode(cube, "volume")), bits_of(in));
  // The encoder's caller must hand it the grid's count of values: that is a bug, not a bad request.
  test::expect_error(Code::Internal, "", [&] {
    field::encode({"height", "m", 5, 3, 0, squall::v1::DTYPE_FLOAT32}, in, &f);
  });
}

// A Field whose size passes 2^64 bytes is named by its exact size, not a saturated one.
TEST(FieldCodec, AGridPastTwoToTheSixtyFourBytesIsNamedExactly) {
  squall::v1::Field f;
  f.set_nx(4294967295u), f.set_ny(4294967295u), f.set_nz(4294967295u);
  // (2^32 - 1)^3 * 4 = 316912649835696421541200789500
  test::expect_error(Code::InvalidArgument,
                     "map.data has 0 bytes, want nx * ny * nz * 4 = 316912649835696421541200789500",
                     [&] { field::decode(f, "map"); });
  f.set_nz(0);  // (2^32 - 1)^2 * 4 = 73786976260478468100
  test::expect_error(Code::InvalidArgument, "map.data has 0 bytes, want nx * ny * 4 = 73786976260478468100",
                     [&] { field::decode(f, "map"); });
}

// Values that binary16 represents exactly come back exactly (signed zeros, subnormals, the largest
// half, infinities), at 2 bytes per value.
TEST(FieldCodec, Float16RoundTripOfRepresentableValuesIsExact) {
  const std::vector<float> in = {0.0f,
                                 -0.0f,
                                 1.0f,
                                 -2.0f,
                                 0.5f,
                                 1.0f + 1.0f / 1024,
                                 65504.0f,
                                 -65504.0f,
                                 std::ldexp(1.0f, -24),
                                 std::ldexp(-3.0f, -24),
                                 std::ldexp(1.0f, -14),
                                 INFINITY,
                                 -INFINITY,
                                 1234.0f,
                                 std::ldexp(-1638.0f, -14) /* 0xae66 */,
                                 3.0f};
  squall::v1::Field f;
  field::encode({"slope_x", "1", 8, 2, 0, squall::v1::DTYPE_FLOAT16}, in, &f);
  EXPECT_EQ(f.dtype(), squall::v1::DTYPE_FLOAT16);
  ASSERT_EQ(f.data().size(), in.size() * 2);
  EXPECT_EQ(uint8_t(f.data()[4]), 0x00);  // 1.0 = 0x3c00, little-endian
  EXPECT_EQ(uint8_t(f.data()[5]), 0x3c);
  EXPECT_EQ(bits_of(field::decode(f, "fields[1]")), bits_of(in));
  // The decoded values are what the client's values() gives.
  f.set_name("slope_x");
  EXPECT_EQ(bits_of(client::ocean::values(f)), bits_of(in));
}

// A finite value that float16 would carry as inf (|value| >= 65520) is refused, naming the field, the cell
// and the value; 65519.99, which rounds to 65504, and infinities pass.
TEST(FieldCodec, Float16RefusesAFiniteValueItWouldCarryAsInf) {
  std::vector<float> in = {1.0f, std::nextafter(65520.0f, 0.0f), INFINITY, -INFINITY, 2.0f, 3.0f};
  squall::v1::Field f;
  field::encode({"height", "m", 3, 2, 0, squall::v1::DTYPE_FLOAT16}, in, &f);
  EXPECT_EQ(field::decode(f, "f")[1], 65504.0f);
  in[4] = -65520.0f;
  test::expect_error(Code::InvalidArgument,
                     "height = -65520 at (1, 1) is past float16's largest finite value, 65504: ask for DTYPE_FLOAT32",
                     [&] {
                       field::encode({"height", "m", 3, 2, 0, squall::v1::DTYPE_FLOAT16}, in, &f);
                     });
  in[4] = 2.1e7f;
  test::expect_error(Code::InvalidArgument, "height = 21000000 at (1, 1)", [&] {
    field::encode({"height", "m", 3, 2, 0, squall::v1::DTYPE_FLOAT16}, in, &f);
  });
  field::encode({"height", "m", 3, 2, 0, squall::v1::DTYPE_FLOAT32}, in, &f);  // float32 holds it
}

// NaN stays NaN through float16, with its sign.
TEST(FieldCodec, NanSurvivesFloat16) {
  const float quiet = std::numeric_limits<float>::quiet_NaN();
  uint32_t payload_bits = 0x7fa00000u;  // a NaN with payload bits in the top of the mantissa
  float payload;
  std::memcpy(&payload, &payload_bits, 4);
  const std::vector<float> in = {quiet, -quiet, payload, 1.0f};
  squall::v1::Field f;
  field::encode({"height", "m", 2, 2, 0, squall::v1::DTYPE_FLOAT16}, in, &f);
  const std::vector<float> out = field::decode(f, "fields[0]");
  ASSERT_EQ(out.size(), 4u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_TRUE(std::isnan(out[i])) << i;
    EXPECT_EQ(std::signbit(out[i]), std::signbit(in[i])) << i;
  }
  EXPECT_EQ(out[3], 1.0f);
}

// A byte count that does not match nx * ny * bytes per value, or an unknown dtype, is InvalidArgument
// naming the field's path, as the eWave input maps report it.
TEST(FieldCodec, WrongByteCountOrDtypeIsRejectedNamingTheFieldPath) {
  squall::v1::Field f;
  f.set_nx(4), f.set_ny(3), f.set_dtype(squall::v1::DTYPE_FLOAT32);
  f.set_data(std::string(40, '\0'));
  EXPECT_EQ(invalid_argument([&] { field::decode(f, "inputs.obstruction"); }),
            "inputs.obstruction.data has 40 bytes, want nx * ny * 4 = 48");
  f.set_dtype(squall::v1::DTYPE_FLOAT16);
  f.set_data(std::string(22, '\0'));
  EXPECT_EQ(invalid_argument([&] { field::decode(f, "config.initial_height"); }),
            "config.initial_height.data has 22 bytes, want nx * ny * 2 = 24");
  f.set_nz(2);
  EXPECT_EQ(invalid_argument([&] { field::decode(f, "volume"); }),
            "volume.data has 22 bytes, want nx * ny * nz * 2 = 48");
  f.set_nz(0);
  f.set_data(std::string(24, '\0'));
  EXPECT_EQ(field::decode(f, "inputs.obstruction").size(), 12u);
  f.set_dtype(squall::v1::DType(9));
  EXPECT_EQ(invalid_argument([&] { field::decode(f, "inputs.obstruction"); }),
            "inputs.obstruction.dtype = 9 must be DTYPE_FLOAT32 or DTYPE_FLOAT16");
  EXPECT_EQ(invalid_argument([&] { field::bytes_per_value(squall::v1::DType(9), "inputs.dtype"); }),
            "inputs.dtype = 9 must be DTYPE_FLOAT32 or DTYPE_FLOAT16");
  // DTYPE_UNSPECIFIED means float32, as requests default to it.
  EXPECT_EQ(field::dtype(squall::v1::DTYPE_UNSPECIFIED), squall::v1::DTYPE_FLOAT32);
  EXPECT_EQ(field::bytes_per_value(squall::v1::DTYPE_UNSPECIFIED), 4u);
  EXPECT_EQ(field::bytes_per_value(squall::v1::DTYPE_FLOAT16), 2u);
}

// A reply's fields are encoded one by one, the call's cancellation looked at before each (a 4096^2 plane
// is 64 MiB): cancelled at its second look, a reply of three outputs stops after the first field, naming
// the second; never cancelled, it looks once a field and each field is its plane's bytes.
TEST(TileReply, FieldsAreEncodedInOrderAndStopWhenCancelled) {
  ocean::TileFields tile;
  tile.nx = 3, tile.ny = 2, tile.dx = 0.5, tile.dy = 0.25;
  tile.height = FloatView(std::vector<float>{1, 2, 3, 4, 5, 6});
  tile.normal_z = FloatView(std::vector<float>{0.5f, 1, 1, 1, 1, 0.25f});
  tile.jacobian = FloatView(std::vector<float>{-1, 0, 1, 2, 3, 4});
  const std::vector<squall::v1::TileOutput> outputs{squall::v1::TILE_OUTPUT_NORMAL_Z, squall::v1::TILE_OUTPUT_HEIGHT,
                                                    squall::v1::TILE_OUTPUT_JACOBIAN};
  int looks = 0;
  const Cancellation second_look([&] { return ++looks >= 2; });
  google::protobuf::RepeatedPtrField<squall::v1::Field> fields;
  test::expect_error(Code::Cancelled, "outputs[1]'s field cancelled",
                     [&] { ocean::rpc::fill_fields(tile, outputs, squall::v1::DTYPE_FLOAT32, second_look, &fields); });
  EXPECT_EQ(looks, 2);
  ASSERT_EQ(fields.size(), 1);
  EXPECT_EQ(fields[0].name(), "normal_z");
  looks = 0;
  const Cancellation counted([&] { return ++looks < 0; });
  fields.Clear();
  ocean::rpc::fill_fields(tile, outputs, squall::v1::DTYPE_FLOAT32, counted, &fields);
  EXPECT_EQ(looks, 3);
  ASSERT_EQ(fields.size(), 3);
  const FloatView* planes[] = {&tile.normal_z, &tile.height, &tile.jacobian};
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(field::decode(fields[i], "fields"), planes[i]->to_vector()) << fields[i].name();
    EXPECT_EQ(fields[i].nx(), 3u);
    EXPECT_EQ(fields[i].ny(), 2u);
  }
}

}  // namespace
}  // namespace squall
