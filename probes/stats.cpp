#include "probes/stats.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include <fmt/format.h>

namespace dtflop::probes {

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

Summary summarize(std::span<const double> samples) {
  if (samples.empty()) throw std::invalid_argument("summary of an empty sample");
  std::vector<double> s(samples.begin(), samples.end());
  for (double v : s)
    if (!std::isfinite(v))
      throw std::invalid_argument(fmt::format("sample holds a non-finite value ({})", v));
  std::sort(s.begin(), s.end());
  Summary r;
  r.n = s.size();
  r.min = s.front();
  r.max = s.back();
  r.mean = std::accumulate(s.begin(), s.end(), 0.0) / static_cast<double>(s.size());
  r.median = quantile_sorted(s, 0.5);
  r.q1 = quantile_sorted(s, 0.25);
  r.q3 = quantile_sorted(s, 0.75);
  r.spread = r.median != 0.0 ? (r.q3 - r.q1) / std::fabs(r.median) : 0.0;
  return r;
}

}  // namespace dtflop::probes
