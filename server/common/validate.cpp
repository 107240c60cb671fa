#include "common/validate.h"

#include <cfloat>
#include <charconv>
#include <cmath>
#include <cstdio>

#include "common/error.h"

namespace squall::validate {

std::string number(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", v);
  return text;
}

void reject(const std::string& path, const std::string& value, const std::string& rule) {
  fail(Code::InvalidArgument, path + " = " + value + " must be " + rule);
}

void reject(const std::string& path, double value, const std::string& rule) { reject(path, number(value), rule); }

bool Interval::contains(double v) const {
  if (!std::isfinite(v)) return false;
  bool lo_ok = lo_open ? v > lo : v >= lo;
  bool hi_ok = hi_open ? v < hi : v <= hi;
  return lo_ok && hi_ok;
}

std::string Interval::rule() const {
  const bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
  if (!has_lo && !has_hi) return "finite";
  if (!has_hi) return std::string("finite and ") + (lo_open ? "> " : ">= ") + number(lo);
  if (!has_lo) return std::string("finite and ") + (hi_open ? "< " : "<= ") + number(hi);
  return std::string("finite and in ") + (lo_open ? "(" : "[") + number(lo) + ", " + number(hi) + (hi_open ? ")" : "]");
}

std::string number_apart(double v, double other) {
  const std::string text = number(v);
  if (v == other || text != number(other)) return text;
  char exact[32];
  std::snprintf(exact, sizeof exact, "%.17g", v);
  return exact;
}

double in(const std::string& path, double v, const Interval& interval) {
  if (!interval.contains(v))
    reject(path, number_apart(v, v < interval.lo ? interval.lo : interval.hi), interval.rule());
  return v;
}

int64_t in(const std::string& path, int64_t v, int64_t lo, int64_t hi) {
  if (v < lo || v > hi) reject(path, std::to_string(v), "in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return v;
}

void count(const std::string& path, size_t have, size_t want, const std::string& what) {
  if (have != want)
    fail(Code::InvalidArgument,
         path + " has " + std::to_string(have) + " values, want " + what + " = " + std::to_string(want));
}

void each(const std::string& path, const float* values, size_t n, const Interval& interval) {
  // float32 values against bounds stated in decimal: each bound as its nearest float, so that 1e30, which
  // arrives as 1.00000002e30, is within [-1e30, 1e30].
  auto nearest_float = [](double b) { return std::abs(b) <= FLT_MAX ? double(float(b)) : b; };
  Interval nearest = interval;
  nearest.lo = nearest_float(interval.lo), nearest.hi = nearest_float(interval.hi);
  for (size_t i = 0; i < n; ++i)
    if (!nearest.contains(values[i]))
      reject(at(path, i), number_apart(values[i], values[i] < interval.lo ? interval.lo : interval.hi),
             interval.rule());
}

int known(const std::string& path, int value, int count, const std::string& type) {
  if (value < 0 || value >= count)
    reject(path, std::to_string(value), "a known " + type + " (0.." + std::to_string(count - 1) + ")");
  return value;
}

std::string at(const std::string& path, size_t i) { return path + "[" + std::to_string(i) + "]"; }

std::string printable(std::string_view text, size_t max_bytes) {
  static const char kHex[] = "0123456789abcdef";
  std::string out;
  for (size_t i = 0; i < text.size() && i < max_bytes; ++i) {
    unsigned char c = static_cast<unsigned char>(text[i]);
    if (c < 0x20 || c >= 0x7f || c == '"' || c == '\\')
      out += std::string("\\x") + kHex[c >> 4] + kHex[c & 15];
    else
      out += char(c);
  }
  if (text.size() > max_bytes) out += "... (" + std::to_string(text.size()) + " bytes)";
  return out;
}

std::optional<double> decimal(std::string_view text) {
  if (text.starts_with('+')) {  // from_chars reads '-' only
    text.remove_prefix(1);
    if (text.starts_with('-')) return {};
  }
  double v = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), v, std::chars_format::general);
  if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(v)) return {};
  return v;
}

}  // namespace squall::validate
