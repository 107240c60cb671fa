// The validation vocabulary of every engine: each check takes the request field's path first (given by
// the caller, e.g. "tile.layers[1].wind_speed"), returns the value it accepted, and otherwise throws
// squall::Error(InvalidArgument) with one message style:
//   "<path> = <value> must be <rule>"       e.g. "tile.layers[1].fetch = -3 must be finite and > 0"
//   "<path> has <n> values, want <what> = <m>"   for per-cell maps of the wrong shape
// Limits (cells, bytes, streams, sessions) are not validation: they go through LimitGate.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>

namespace squall::validate {

// A number as messages print it: up to 9 significant digits, "nan", "inf", "-inf".
std::string number(double v);
// number(v), or v with 17 digits where 9 would print it as `other` ("1e+09 must be in [-1e+09, 1e+09]" for one
// ulp past 1e9).
std::string number_apart(double v, double other);
// A 3-vector as messages print it: "(1e+300, 0, 0)".
template <typename Vec3>
std::string xyz(const Vec3& v) {
  std::string text = "(";  // appended: GCC 12 warns falsely (-Wrestrict) on "(" + std::string
  text.append(number(v[0])).append(", ").append(number(v[1])).append(", ").append(number(v[2]));
  return text + ")";
}

// Throws Error(InvalidArgument, path + " = " + value + " must be " + rule).
[[noreturn]] void reject(const std::string& path, const std::string& value, const std::string& rule);
[[noreturn]] void reject(const std::string& path, double value, const std::string& rule);

// An interval of real numbers; an infinite end is unbounded. Its text is the rule of the message:
// "finite", "finite and > 0", "finite and in (0, 100]".
struct Interval {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;
  bool hi_open = false;

  bool contains(double v) const;
  std::string rule() const;
};

inline Interval any() { return {}; }
inline Interval above(double lo) { return {lo, std::numeric_limits<double>::infinity(), true, false}; }
inline Interval at_least(double lo) { return {lo, std::numeric_limits<double>::infinity(), false, false}; }
inline Interval closed(double lo, double hi) { return {lo, hi, false, false}; }
inline Interval open_closed(double lo, double hi) { return {lo, hi, true, false}; }
inline Interval closed_open(double lo, double hi) { return {lo, hi, false, true}; }
inline Interval open(double lo, double hi) { return {lo, hi, true, true}; }

double in(const std::string& path, double v, const Interval& interval);
inline double finite(const std::string& path, double v) { return in(path, v, any()); }
inline double positive(const std::string& path, double v) { return in(path, v, above(0)); }
inline double positive(const std::string& path, double v, double max) { return in(path, v, open_closed(0, max)); }
inline double non_negative(const std::string& path, double v) { return in(path, v, at_least(0)); }
inline double non_negative(const std::string& path, double v, double max) { return in(path, v, closed(0, max)); }

// The three components of a 3-vector in `interval`: "<path>.y = nan must be in [-1e7, 1e7]".
template <typename Vec3>
void in_xyz(const std::string& path, const Vec3& v, const Interval& interval) {
  in(path + ".x", v[0], interval);
  in(path + ".y", v[1], interval);
  in(path + ".z", v[2], interval);
}
// ... and finite: "<path>.y = nan must be finite".
template <typename Vec3>
void finite_xyz(const std::string& path, const Vec3& v) {
  in_xyz(path, v, any());
}

// Integers: "<path> = 17 must be in [1, 16]".
int64_t in(const std::string& path, int64_t v, int64_t lo, int64_t hi);

// A per-cell map must hold exactly `want` values: "<path> has 5 values, want nx * ny = 6".
void count(const std::string& path, size_t have, size_t want, const std::string& what);

// Every value of a map finite and inside the interval: "<path>[17] = nan must be finite".
void each(const std::string& path, const float* values, size_t n, const Interval& interval = any());

// An enum value from a request, in [0, count): "<path> = 9 must be a known <type> (0..5)".
int known(const std::string& path, int value, int count, const std::string& type);

// "<path>[i]"
std::string at(const std::string& path, size_t i);

// A finite decimal number written out whole: an optional sign, digits, a point, an exponent ("-1.5",
// "+4e11"); no hexadecimal, inf, nan, spaces or empty text, and nothing the C locale would read otherwise.
// Nothing when `text` is not one, or is past double's range either way (1e999, 1e-999).
std::optional<double> decimal(std::string_view text);

// Client text as messages and log lines show it: at most `max_bytes` bytes (then "..." and the full
// size), with control characters, '"', '\\' and bytes >= 0x7f written as \xNN. A client's string never
// reaches a message or the log whole or raw: a 1 MiB id would pass gRPC's metadata limit, a newline
// would forge a log line.
std::string printable(std::string_view text, size_t max_bytes = 64);

}  // namespace squall::validate
