#include "model/units.hpp"

#include <cctype>
#include <charconv>
#include <cmath>
#include <string>
#include <thread>
#include <algorithm>

#include <fmt/format.h>

#include "model/errors.hpp"

namespace dtflop {

namespace {

// Splits "12.5ms" into 12.5 and "ms". Returns false when there is no leading number.
bool split_number(std::string_view text, double& value, std::string& suffix) {
  std::string s(text);
  size_t used = 0;
  try {
    value = std::stod(s, &used);
  } catch (...) {
    return false;
  }
  suffix = s.substr(used);
  while (!suffix.empty() && std::isspace(static_cast<unsigned char>(suffix.front()))) suffix.erase(0, 1);
  return std::isfinite(value);
}

}  // namespace

double parse_duration(std::string_view text, std::string_view what) {
  double v = 0;
  std::string unit;
  if (!split_number(text, v, unit))
    throw InputError(fmt::format("{} '{}' is not a duration; write e.g. 1ms, 250us or 0.5s", what, text));
  double scale = 0;
  if (unit.empty() || unit == "s") scale = 1;
  else if (unit == "ms") scale = 1e-3;
  else if (unit == "us") scale = 1e-6;
  else if (unit == "ns") scale = 1e-9;
  else
    throw InputError(fmt::format("{} '{}' has unknown unit '{}'; use s, ms, us or ns", what, text, unit));
  if (v <= 0)
    throw InputError(fmt::format("{} '{}' must be positive", what, text));
  return v * scale;
}

std::int64_t parse_bytes(std::string_view text, std::string_view what) {
  double v = 0;
  std::string unit;
  if (!split_number(text, v, unit))
    throw InputError(fmt::format("{} '{}' is not a size; write e.g. 4KiB, 16MiB or 1GiB", what, text));
  double scale = 0;
  if (unit.empty() || unit == "B") scale = 1;
  else if (unit == "KiB") scale = 1024.0;
  else if (unit == "MiB") scale = 1024.0 * 1024;
  else if (unit == "GiB") scale = 1024.0 * 1024 * 1024;
  else if (unit == "kB" || unit == "KB") scale = 1e3;
  else if (unit == "MB") scale = 1e6;
  else if (unit == "GB") scale = 1e9;
  else
    throw InputError(fmt::format("{} '{}' has unknown unit '{}'; use B, KiB, MiB, GiB, kB, MB or GB",
                                 what, text, unit));
  if (v <= 0) throw InputError(fmt::format("{} '{}' must be positive", what, text));
  return static_cast<std::int64_t>(std::llround(v * scale));
}

int checked_threads(std::int64_t requested, std::string_view what) {
  const std::int64_t hw = std::max<std::int64_t>(1, std::thread::hardware_concurrency());
  if (requested < 0 || requested > hw)
    throw InputError(fmt::format("{} {} is outside 0..{}: this machine has {} hardware threads; give at most that "
                                 "(0: all)",
                                 what, requested, hw, hw));
  return requested == 0 ? static_cast<int>(hw) : static_cast<int>(requested);
}

Size2 parse_size2(std::string_view text, std::string_view what, std::int64_t max) {
  auto parse_int = [&](std::string_view part) -> std::int64_t {
    std::int64_t v = 0;
    auto [p, ec] = std::from_chars(part.data(), part.data() + part.size(), v);
    if (part.empty() || ec != std::errc() || p != part.data() + part.size())
      throw InputError(fmt::format("{} '{}' is not a size; write WxH with whole numbers, e.g. 1000x1000",
                                   what, text));
    return v;
  };
  const auto x = text.find('x');
  Size2 s;
  if (x == std::string_view::npos) {
    s.x = s.y = parse_int(text);
  } else {
    s.x = parse_int(text.substr(0, x));
    s.y = parse_int(text.substr(x + 1));
  }
  if (s.x < 1 || s.y < 1)
    throw InputError(fmt::format("{} '{}' must be at least 1 in each direction", what, text));
  if (s.x > max || s.y > max)
    throw InputError(fmt::format("{} '{}' is larger than the {} this command accepts per side",
                                 what, text, max));
  return s;
}

namespace {
std::string scaled(double v, std::string_view unit, double base, const char* const* prefixes, int n) {
  int i = 0;
  double a = std::fabs(v);
  while (i + 1 < n && a >= base) {
    a /= base;
    v /= base;
    ++i;
  }
  return fmt::format("{:.3g} {}{}", v, prefixes[i], unit);
}
}  // namespace

std::string format_duration(double s) {
  const double a = std::fabs(s);
  if (a == 0) return "0 s";
  if (a < 1e-6) return fmt::format("{:.3g} ns", s * 1e9);
  if (a < 1e-3) return fmt::format("{:.3g} us", s * 1e6);
  if (a < 1) return fmt::format("{:.3g} ms", s * 1e3);
  return fmt::format("{:.3g} s", s);
}

std::string format_bandwidth(double b) {
  static const char* const p[] = {"", "k", "M", "G", "T", "P"};
  return scaled(b, "B/s", 1000, p, 6);
}

std::string format_rate(double f) {
  static const char* const p[] = {"", "k", "M", "G", "T", "P"};
  return scaled(f, "FLOP/s", 1000, p, 6);
}

std::string format_bytes(double b) {
  static const char* const p[] = {"", "Ki", "Mi", "Gi", "Ti"};
  return scaled(b, "B", 1024, p, 5);
}

std::string format_quantity(double v, std::string_view unit) {
  if (unit == "B/s") return format_bandwidth(v);
  if (unit == "FLOP/s") return format_rate(v);
  if (unit == "s") return format_duration(v);
  if (unit == "B") return format_bytes(v);
  return fmt::format("{:.4g} {}", v, unit);
}

}  // namespace dtflop
