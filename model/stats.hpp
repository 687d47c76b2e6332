// Statistics of repeated measurements: the median, quartiles and relative spread that dtflop
// reports with every probed figure and every calibration sample (seconds, usually).
//
// One implementation for the probes (probes/), the calibration samples (calibrate/), the CLI
// and the benchmarks. Quantiles are the "type 7" estimator of R and NumPy, so the figures
// can be checked with np.percentile.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

namespace dtflop {

// Summary of the repetitions of one measured quantity.
struct Stats {
  std::size_t n = 0;   // number of repetitions
  double median = 0;
  double p25 = 0;      // first quartile (linear interpolation between order statistics)
  double p75 = 0;      // third quartile
  double min = 0;
  double max = 0;
  double mean = 0;
  std::vector<double> values;  // every repetition, in the order measured

  // Relative spread: (p75 - p25) / |median|, the interquartile range over the median; 0 when
  // the median is 0 and for a single repetition. Robust to the odd slow repetition (a page
  // fault, a context switch).
  double spread() const;
};

// Quantile p in [0, 1] of `sorted` (ascending), interpolating linearly between order
// statistics (the "type 7" estimator of R and NumPy). Throws std::invalid_argument when
// `sorted` is empty or p is outside [0, 1].
double quantile_sorted(std::span<const double> sorted, double p);

// Summary of `values` (kept in `Stats::values` in the order given). Throws
// std::invalid_argument when it is empty or holds a value that is not finite (a timer that
// returned NaN is a bug to report, not a figure to average).
Stats summarize(std::span<const double> values);

}  // namespace dtflop
