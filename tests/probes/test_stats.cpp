#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "probes/stats.hpp"

namespace dtflop::probes {
namespace {

TEST(Stats, QuartilesFollowLinearInterpolation) {
  // NumPy: np.percentile(range(1, 11), [25, 50, 75]) == [3.25, 5.5, 7.75]
  const std::vector<double> v = {7, 1, 10, 3, 5, 9, 2, 8, 4, 6};  // unsorted on purpose
  const Summary s = summarize(v);
  EXPECT_EQ(s.n, 10u);
  EXPECT_DOUBLE_EQ(s.median, 5.5);
  EXPECT_DOUBLE_EQ(s.q1, 3.25);
  EXPECT_DOUBLE_EQ(s.q3, 7.75);
  EXPECT_DOUBLE_EQ(s.min, 1);
  EXPECT_DOUBLE_EQ(s.max, 10);
  EXPECT_DOUBLE_EQ(s.mean, 5.5);
  EXPECT_DOUBLE_EQ(s.spread, 4.5 / 5.5);
}

TEST(Stats, OddCountMedianIsTheMiddleValue) {
  const std::vector<double> v = {3e-6, 1e-6, 100e-6, 2e-6, 2.5e-6};
  const Summary s = summarize(v);
  EXPECT_DOUBLE_EQ(s.median, 2.5e-6);
  // One outlier (100 us) moves the mean far, the median and quartiles not at all.
  EXPECT_GT(s.mean, 20e-6);
  EXPECT_DOUBLE_EQ(s.q1, 2e-6);
  EXPECT_DOUBLE_EQ(s.q3, 3e-6);
  EXPECT_NEAR(s.spread, 1e-6 / 2.5e-6, 1e-12);
}

TEST(Stats, SingleSampleHasNoSpread) {
  const std::vector<double> v = {0.25};
  const Summary s = summarize(v);
  EXPECT_DOUBLE_EQ(s.median, 0.25);
  EXPECT_DOUBLE_EQ(s.spread, 0.0);
}

TEST(Stats, RejectsEmptyAndNonFiniteSamples) {
  EXPECT_THROW(summarize(std::vector<double>{}), std::invalid_argument);
  EXPECT_THROW(summarize(std::vector<double>{1.0, std::numeric_limits<double>::quiet_NaN()}),
               std::invalid_argument);
  EXPECT_THROW(summarize(std::vector<double>{1.0, std::numeric_limits<double>::infinity()}),
               std::invalid_argument);
}

TEST(Stats, QuantileChecksItsArguments) {
  const std::vector<double> v = {1, 2, 3};
  EXPECT_DOUBLE_EQ(quantile_sorted(v, 0.0), 1);
  EXPECT_DOUBLE_EQ(quantile_sorted(v, 1.0), 3);
  EXPECT_DOUBLE_EQ(quantile_sorted(v, 0.75), 2.5);
  EXPECT_THROW(quantile_sorted(v, 1.5), std::invalid_argument);
  EXPECT_THROW(quantile_sorted(v, -0.1), std::invalid_argument);
  EXPECT_THROW(quantile_sorted(std::vector<double>{}, 0.5), std::invalid_argument);
}

}  // namespace
}  // namespace dtflop::probes
