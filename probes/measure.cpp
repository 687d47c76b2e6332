#include "probes/measure.hpp"

#include <stdexcept>

#include <fmt/format.h>

namespace dtflop::probes {

Measurement rate_measurement(std::string key, std::string label, std::string unit, double amount,
                             std::span<const double> seconds, std::optional<Param> param,
                             std::string note) {
  Measurement m;
  m.key = std::move(key);
  m.label = std::move(label);
  m.unit = std::move(unit);
  m.stats = summarize(seconds);
  if (!(m.stats.median > 0))
    throw std::invalid_argument(fmt::format("{}: median time {} s is not positive", m.key,
                                            m.stats.median));
  m.value = amount / m.stats.median;
  m.param = param;
  m.note = std::move(note);
  return m;
}

Measurement time_measurement(std::string key, std::string label, std::span<const double> seconds,
                             std::optional<Param> param, std::string note) {
  Measurement m;
  m.key = std::move(key);
  m.label = std::move(label);
  m.unit = std::string("s");
  m.stats = summarize(seconds);
  if (!(m.stats.median > 0))
    throw std::invalid_argument(fmt::format("{}: median time {} s is not positive", m.key,
                                            m.stats.median));
  m.value = m.stats.median;
  m.param = param;
  m.note = std::move(note);
  return m;
}

Measurement per_event_measurement(std::string key, std::string label, const PerEventFit& fit,
                                  std::span<const double> seconds, std::optional<Param> param, std::string note) {
  Measurement m;
  m.key = std::move(key);
  m.label = std::move(label);
  m.unit = std::string("s");
  m.value = fit.per_event;
  m.uncertainty = fit.per_event_hw95;
  m.stats = summarize(seconds);
  m.param = param;
  m.note = std::move(note);
  return m;
}

std::string size_label(std::int64_t bytes) {
  static const char* const units[] = {"B", "KiB", "MiB", "GiB", "TiB"};
  int u = 0;
  std::int64_t v = bytes;
  while (u < 4 && v >= 1024 && v % 1024 == 0) {
    v /= 1024;
    ++u;
  }
  return fmt::format("{} {}", v, units[u]);
}

std::string size_key(std::int64_t bytes) {
  std::string s = size_label(bytes);
  s.erase(s.find(' '), 1);
  return s;
}

}  // namespace dtflop::probes
