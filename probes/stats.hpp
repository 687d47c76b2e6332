// Statistics of repeated measurements: median, quartiles and the relative spread that
// dtflop reports with every probed figure.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

namespace dtflop::probes {

struct Summary {
  std::size_t n = 0;
  double median = 0;
  double q1 = 0;      // first quartile (linear interpolation between order statistics)
  double q3 = 0;      // third quartile
  double min = 0;
  double max = 0;
  double mean = 0;
  // Relative spread: (q3 - q1) / median, the interquartile range over the median. Zero for a
  // single sample. Robust to the odd slow repetition (a page fault, a context switch).
  double spread = 0;
};

// Quantile p in [0, 1] of `sorted` (ascending), interpolating linearly between order
// statistics (the "type 7" estimator of R and NumPy). Throws std::invalid_argument when
// `sorted` is empty or p is outside [0, 1].
double quantile_sorted(std::span<const double> sorted, double p);

// Summary of `samples`. Throws std::invalid_argument when it is empty or holds a value that
// is not finite (a timer that returned NaN is a bug to report, not a figure to average).
Summary summarize(std::span<const double> samples);

}  // namespace dtflop::probes
