// Order statistics of repeated timings: medians, quartiles and the spread dtflop reports.
#pragma once

#include <vector>

namespace dtflop::calib {

// Summary of the repetitions of one measured quantity (seconds).
struct Stats {
  double median = 0;
  double p25 = 0;  // first quartile
  double p75 = 0;  // third quartile
  double min = 0;
  double max = 0;
  std::vector<double> values;  // every repetition, in the order measured

  // Relative spread: interquartile range over the median (0 when the median is 0).
  double spread() const { return median > 0 ? (p75 - p25) / median : 0; }
};

// Quantile q in [0, 1] of `sorted` (ascending), interpolated linearly between order
// statistics (the "type 7" definition). `sorted` must not be empty.
double quantile_sorted(const std::vector<double>& sorted, double q);

// Throws std::invalid_argument on an empty vector or a non-finite value.
Stats summarize(std::vector<double> values);

}  // namespace dtflop::calib
