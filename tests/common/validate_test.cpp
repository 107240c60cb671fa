// The validation vocabulary: one message style, the value as sent, the rule it broke.
#include "common/validate.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <initializer_list>
#include <utility>

#include "support/expect_error.h"
#include "support/worst.h"

namespace squall {
namespace {

using test::expect_error;

// The tests' running worst error keeps a NaN, wherever it comes: std::max drops it.
TEST(TestSupport, TheWorstErrorKeepsANaN) {
  const double nan = std::nan("");
  EXPECT_EQ(std::max(1.0, nan), 1.0);
  EXPECT_EQ(test::worse(1.0, 2.0, 0.5), 2.0);
  EXPECT_TRUE(std::isnan(test::worse(1.0, nan)));
  EXPECT_TRUE(std::isnan(test::worse(nan, 3.0)));
  EXPECT_TRUE(std::isnan(test::worse(0.0, 1.0, nan, 2.0)));
}

TEST(Validate, MessagesNameThePathTheValueAndTheRule) {
  EXPECT_EQ(validate::positive("a.b", 2.5), 2.5);
  expect_error(Code::InvalidArgument, "a.b = -3 must be finite and > 0", [] { validate::positive("a.b", -3); });
  expect_error(Code::InvalidArgument, "w = nan must be finite and in (0, 100]",
               [] { validate::positive("w", NAN, 100); });
  expect_error(Code::InvalidArgument, "w = 100.5 must be finite and in (0, 100]",
               [] { validate::positive("w", 100.5, 100); });
  expect_error(Code::InvalidArgument, "x = inf must be finite", [] { validate::finite("x", INFINITY); });
  expect_error(Code::InvalidArgument, "d = -0.001 must be finite and >= 0", [] { validate::non_negative("d", -1e-3); });
  expect_error(Code::InvalidArgument, "g = 0.5 must be finite and in [1, 100]",
               [] { validate::in("g", 0.5, validate::closed(1, 100)); });
  expect_error(Code::InvalidArgument, "n = 17 must be in [1, 16]", [] { validate::in("n", int64_t(17), 1, 16); });
  expect_error(Code::InvalidArgument, "m = 9 must be a known model (0..5)",
               [] { validate::known("m", 9, 6, "model"); });
  EXPECT_EQ(validate::number(0.1), "0.1");
  EXPECT_EQ(validate::number(1e-12), "1e-12");
  // A value just past a bound is not printed as the bound: "1e+09 must be ... in [-1e+09, 1e+09]" said nothing.
  const double past = std::nextafter(1e9, 2e9);
  EXPECT_EQ(validate::number_apart(past, 1e9), "1000000000.0000001");
  EXPECT_EQ(validate::number_apart(1e9, 1e9), "1e+09");
  EXPECT_EQ(validate::number_apart(2e9, 1e9), "2e+09");
  expect_error(Code::InvalidArgument, "t = 1000000000.0000001 must be finite and in [-1e+09, 1e+09]",
               [&] { validate::in("t", past, validate::closed(-1e9, 1e9)); });
}

TEST(Validate, MapsHaveTheirShapeAndEveryValueIsChecked) {
  const float map[] = {0, 0.5f, 1, 2};
  expect_error(Code::InvalidArgument, "obstruction has 4 values, want nx * ny = 6",
               [] { validate::count("obstruction", 4, 6, "nx * ny"); });
  expect_error(Code::InvalidArgument, "obstruction[3] = 2 must be finite and in [0, 1]",
               [&] { validate::each("obstruction", map, 4, validate::closed(0, 1)); });
  validate::each("obstruction", map, 3, validate::closed(0, 1));
  // float32 values against a decimal bound: 1e30 arrives as 1.00000002e30, and is within [-1e30, 1e30]; the
  // next float up is not.
  const float huge[] = {-1e30f, 1e30f, std::nextafter(1e30f, INFINITY)};
  validate::each("table", huge, 2, validate::closed(-1e30, 1e30));
  expect_error(Code::InvalidArgument, "table[2] = 1.00000009e+30 must be finite and in [-1e+30, 1e+30]",
               [&] { validate::each("table", huge, 3, validate::closed(-1e30, 1e30)); });
  expect_error(Code::InvalidArgument, "eye.z = nan must be finite", [] {
    validate::finite_xyz("eye", std::array<double, 3>{1, 2, NAN});
  });
}

TEST(Validate, ClientTextIsEscapedAndCut) {
  EXPECT_EQ(validate::printable("cloud-42"), "cloud-42");
  EXPECT_EQ(validate::printable("a\nb\"c\\d\x7f\xff"), "a\\x0ab\\x22c\\x5cd\\x7f\\xff");
  EXPECT_EQ(validate::printable(std::string(1 << 20, 'x'), 4), "xxxx... (1048576 bytes)");
  EXPECT_EQ(validate::printable(std::string_view("a\0b", 3)), "a\\x00b");
}

// Numbers in text (flags, OBJ files) are read as written in decimal, whatever the locale and whatever
// else strtod would take.
TEST(Validate, DecimalNumbersAreReadWholeAndNothingElse) {
  for (auto [text, value] : std::initializer_list<std::pair<const char*, double>>{
           {"1.5", 1.5}, {"-2", -2}, {"+4e11", 4e11}, {".5", 0.5}, {"7.", 7}, {"1E-3", 1e-3}, {"-0", 0}})
    EXPECT_EQ(validate::decimal(text), value) << text;
  for (const char* text : {"", " 1", "1 ", "0x10", "0x1p3", "inf", "-inf", "nan", "1e999", "-1e999", "1e-999", "1e",
                           "++1", "+-1", "-+1", "1,5", "1.5.2", "12abc", "+"})
    EXPECT_FALSE(validate::decimal(text)) << text;
}

}  // namespace
}  // namespace squall
