#include "calibrate/stats.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace dtflop::calib {

double quantile_sorted(const std::vector<double>& s, double q) {
  if (s.empty()) throw std::invalid_argument("quantile of no values");
  const double pos = std::clamp(q, 0.0, 1.0) * static_cast<double>(s.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const auto hi = std::min(lo + 1, s.size() - 1);
  const double frac = pos - static_cast<double>(lo);
  return s[lo] + frac * (s[hi] - s[lo]);
}

Stats summarize(std::vector<double> values) {
  if (values.empty()) throw std::invalid_argument("summarize: no values");
  for (double v : values)
    if (!std::isfinite(v)) throw std::invalid_argument("summarize: a value is not finite");
  Stats st;
  st.values = values;
  std::sort(values.begin(), values.end());
  st.min = values.front();
  st.max = values.back();
  st.median = quantile_sorted(values, 0.5);
  st.p25 = quantile_sorted(values, 0.25);
  st.p75 = quantile_sorted(values, 0.75);
  return st;
}

}  // namespace dtflop::calib
