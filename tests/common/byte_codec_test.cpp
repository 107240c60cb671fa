// The byte codec: its exact bytes (little-endian, IEEE 754 bits), round trips of every value it writes,
// and readers that reject short, forged or overlong bytes with messages naming what they were reading.
#include "common/byte_codec.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "support/expect_error.h"

namespace squall {
namespace {

using test::expect_error;

enum class Small : uint8_t { A = 1, B = 200 };
enum class Signed : int32_t { Minus = -7, Plus = 9 };

ByteReader reader(std::string_view bytes) { return ByteReader(bytes, "data", "a test record"); }

TEST(ByteCodec, ValuesAreLittleEndianAndFloatsTheirIeeeBits) {
  ByteWriter out;
  out.put(uint32_t(0x01020304));
  EXPECT_EQ(out.take(), std::string("\x04\x03\x02\x01", 4));
  out.put(int64_t(-2));
  EXPECT_EQ(out.take(), std::string("\xFE\xFF\xFF\xFF\xFF\xFF\xFF\xFF", 8));
  out.put(1.5);  // 0x3FF8000000000000
  EXPECT_EQ(out.take(), std::string("\0\0\0\0\0\0\xF8\x3F", 8));
  out.put(-2.0f);  // 0xC0000000
  EXPECT_EQ(out.take(), std::string("\0\0\0\xC0", 4));
  out.put(true);
  out.put(Signed::Minus);
  EXPECT_EQ(out.take(), std::string("\x01\xF9\xFF\xFF\xFF", 5));
  out.put_counted("ab");
  EXPECT_EQ(out.take(), std::string("\x02\0\0\0\0\0\0\0ab", 10));
  const uint16_t array[] = {0x0102, 0x0304};
  out.put_array(array, 2);
  EXPECT_EQ(out.size(), 4u);
  EXPECT_EQ(out.take(), std::string("\x02\x01\x04\x03", 4));
  ByteWriter after(std::string("head"));
  after.put(uint8_t(7));
  EXPECT_EQ(after.take(), std::string("head\x07", 5));
}

TEST(ByteCodec, EveryValueRoundTrips) {
  ByteWriter out;
  out.put(true);
  out.put(false);
  out.put(char('x'));
  out.put(int8_t(-128));
  out.put(uint8_t(255));
  out.put(int16_t(-12345));
  out.put(uint16_t(65535));
  out.put(std::numeric_limits<int32_t>::min());
  out.put(uint32_t(4000000000u));
  out.put(std::numeric_limits<int64_t>::min());
  out.put(std::numeric_limits<uint64_t>::max());
  out.put(Small::B);
  out.put(Signed::Minus);
  out.put(-0.0f);
  out.put(std::numeric_limits<float>::denorm_min());
  out.put(std::numeric_limits<double>::infinity());
  out.put(0.1);
  out.put(std::nan(""));
  const std::vector<double> doubles = {1e300, -0.5, 3};
  const std::vector<int16_t> shorts = {-1, 2, -3, 4};
  out.put_array(doubles.data(), doubles.size());
  out.put_array(shorts.data(), shorts.size());
  out.put_counted(std::string("with\0nul", 8));
  out.put_counted("");
  out.put_bytes("tail");
  const std::string bytes = out.take();

  ByteReader in = reader(bytes);
  EXPECT_TRUE(in.get<bool>("t"));
  EXPECT_FALSE(in.get<bool>("f"));
  EXPECT_EQ(in.get<char>("c"), 'x');
  EXPECT_EQ(in.get<int8_t>("i8"), -128);
  EXPECT_EQ(in.get<uint8_t>("u8"), 255);
  EXPECT_EQ(in.get<int16_t>("i16"), -12345);
  EXPECT_EQ(in.get<uint16_t>("u16"), 65535);
  EXPECT_EQ(in.get<int32_t>("i32"), std::numeric_limits<int32_t>::min());
  EXPECT_EQ(in.get<uint32_t>("u32"), 4000000000u);
  EXPECT_EQ(in.get<int64_t>("i64"), std::numeric_limits<int64_t>::min());
  EXPECT_EQ(in.get<uint64_t>("u64"), std::numeric_limits<uint64_t>::max());
  EXPECT_EQ(in.get<Small>("small"), Small::B);
  EXPECT_EQ(in.get<Signed>("signed"), Signed::Minus);
  const float minus_zero = in.get<float>("-0");
  EXPECT_EQ(minus_zero, 0.0f);
  EXPECT_TRUE(std::signbit(minus_zero));
  EXPECT_EQ(in.get<float>("denormal"), std::numeric_limits<float>::denorm_min());
  EXPECT_EQ(in.get<double>("inf"), std::numeric_limits<double>::infinity());
  EXPECT_EQ(in.get<double>("0.1"), 0.1);
  EXPECT_TRUE(std::isnan(in.get<double>("nan")));
  EXPECT_EQ(in.get_array<double>(3, "doubles"), doubles);
  EXPECT_EQ(in.get_array<int16_t>(4, "shorts"), shorts);
  EXPECT_EQ(in.get_counted("with nul"), std::string_view("with\0nul", 8));
  EXPECT_EQ(in.get_counted("empty"), "");
  EXPECT_EQ(in.left(), 4u);
  EXPECT_EQ(in.get_bytes(4, "tail"), "tail");
  EXPECT_EQ(in.offset(), bytes.size());
  in.finish("the tail");
}

TEST(ByteCodec, ShortBytesNameTheMemberAndTheOffset) {
  ByteWriter out;
  out.put(uint32_t(5));
  out.put(uint16_t(6));
  const std::string bytes = out.take();
  ByteReader in = reader(bytes);
  in.get<uint32_t>("the count");
  EXPECT_EQ(in.offset(), 4u);
  expect_error(Code::InvalidArgument, "data is not a test record: truncated at byte 4 of 6 (reading the width)",
               [&] { in.get<uint32_t>("the width"); });
  EXPECT_EQ(in.offset(), 4u) << "a failed read takes nothing";
  expect_error(Code::InvalidArgument, "truncated at byte 4 of 6 (reading the name of 3 bytes)",
               [&] { in.get_bytes(3, "the name"); });
  expect_error(Code::InvalidArgument, "truncated at byte 4 of 6 (reading the floats: 1 values of 4 bytes)",
               [&] { in.get_array<float>(1, "the floats"); });
  expect_error(Code::InvalidArgument, "truncated at byte 4 of 6 (reading the id length)",
               [&] { in.get_counted("the id"); });
  expect_error(Code::InvalidArgument, "data is not a test record: flag = 2 must be 0 or 1",
               [] { reader(std::string("\x02", 1)).get<bool>("flag"); });
  expect_error(Code::InvalidArgument, "data is not a test record: no good", [&] { in.reject("no good"); });
}

// A forged length or count past the end is truncation, found before anything is allocated for it: were
// 2^62 values allocated, the allocation would throw std::bad_alloc or std::length_error, not Error.
TEST(ByteCodec, ForgedLengthsAreRejectedBeforeAllocating) {
  ByteWriter out;
  out.put(uint64_t(1) << 62);
  out.put_bytes("abc");
  const std::string bytes = out.take();
  expect_error(Code::InvalidArgument, "truncated at byte 8 of 11 (reading the blob of 4611686018427387904 bytes)",
               [&] { reader(bytes).get_counted("the blob"); });
  expect_error(Code::InvalidArgument, "(reading the doubles: 4611686018427387904 values of 8 bytes)", [&] {
    ByteReader in = reader(bytes);
    in.get_array<double>(in.get<uint64_t>("the count"), "the doubles");
  });
  // 2^61 doubles are 2^64 bytes: a product that wraps to 0 must not pass for 0 bytes.
  expect_error(Code::InvalidArgument, "(reading the doubles: 2305843009213693952 values of 8 bytes)",
               [&] { reader(bytes).get_array<double>(uint64_t(1) << 61, "the doubles"); });
}

TEST(ByteCodec, BytesLeftOverAreRejected) {
  ByteReader in = reader("abcde");
  in.get_bytes(2, "the start");
  EXPECT_EQ(in.left(), 3u);
  expect_error(Code::InvalidArgument, "data is not a test record: 3 bytes follow the start",
               [&] { in.finish("the start"); });
  in.get_bytes(3, "the rest");
  in.finish("the rest");
}

}  // namespace
}  // namespace squall
