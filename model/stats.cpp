#include "model/stats.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include <fmt/format.h>

namespace dtflop {

double Stats::spread() const { return median != 0.0 ? (p75 - p25) / std::fabs(median) : 0.0; }

double quantile_sorted(std::span<const double> sorted, double p) {
  if (sorted.empty()) throw std::invalid_argument("quantile of an empty sample");
  if (!(p >= 0.0 && p <= 1.0))
    throw std::invalid_argument(fmt::format("quantile {} is outside [0, 1]", p));
  const double pos = p * static_cast<double>(sorted.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, sorted.size() - 1);
  const double frac = pos - static_cast<double>(lo);
  return sorted[lo] + frac * (sorted[hi] - sorted[lo]);
}

Stats summarize(std::span<const double> values) {
  if (values.empty()) throw std::invalid_argument("summary of an empty sample");
  for (double v : values)
    if (!std::isfinite(v))
      throw std::invalid_argument(fmt::format("sample holds a non-finite value ({})", v));
  Stats r;
  r.values.assign(values.begin(), values.end());
  std::vector<double> s = r.values;
  std::sort(s.begin(), s.end());
  r.n = s.size();
  r.min = s.front();
  r.max = s.back();
  r.mean = std::accumulate(s.begin(), s.end(), 0.0) / static_cast<double>(s.size());
  r.median = quantile_sorted(s, 0.5);
  r.p25 = quantile_sorted(s, 0.25);
  r.p75 = quantile_sorted(s, 0.75);
  return r;
}

}  // namespace dtflop
