#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "model/stats.hpp"

namespace dtflop {
namespace {

TEST(Stats, QuartilesFollowLinearInterpolation) {
  // NumPy: np.percentile(range(1, 11), [25, 50, 75]) == [3.25, 5.5, 7.75]
  const std::vector<double> v = {7, 1, 10, 3, 5, 9, 2, 8, 4, 6};  // unsorted on purpose
  const Stats s = summarize(v);
  EXPECT_EQ(s.n, 10u);
  EXPECT_DOUBLE_EQ(s.median, 5.5);
  EXPECT_DOUBLE_EQ(s.p25, 3.25);
  EXPECT_DOUBLE_EQ(s.p75, 7.75);
  EXPECT_DOUBLE_EQ(s.min, 1);
  EXPECT_DOUBLE_EQ(s.max, 10);
  EXPECT_DOUBLE_EQ(s.mean, 5.5);
  EXPECT_DOUBLE_EQ(s.spread(), 4.5 / 5.5);
}

TEST(Stats, ValuesKeepTheMeasuredOrder) {
  const std::vector<double> v = {4, 1, 3, 2, 5};
  const Stats s = summarize(v);
  EXPECT_EQ(s.n, 5u);
  EXPECT_DOUBLE_EQ(s.median, 3);
  EXPECT_DOUBLE_EQ(s.p25, 2);
  EXPECT_DOUBLE_EQ(s.p75, 4);
  EXPECT_DOUBLE_EQ(s.min, 1);
  EXPECT_DOUBLE_EQ(s.max, 5);
  EXPECT_DOUBLE_EQ(s.spread(), 2.0 / 3.0);
  EXPECT_EQ(s.values, (std::vector<double>{4, 1, 3, 2, 5}));  // measured order kept
  const Stats even = summarize(std::vector<double>{1, 2, 3, 4});
  EXPECT_DOUBLE_EQ(even.median, 2.5);
  EXPECT_DOUBLE_EQ(even.p25, 1.75);
}

TEST(Stats, OddCountMedianIsTheMiddleValue) {
  const std::vector<double> v = {3e-6, 1e-6, 100e-6, 2e-6, 2.5e-6};
  const Stats s = summarize(v);
  EXPECT_DOUBLE_EQ(s.median, 2.5e-6);
  // One outlier (100 us) moves the mean far, the median and quartiles not at all.
  EXPECT_GT(s.mean, 20e-6);
  EXPECT_DOUBLE_EQ(s.p25, 2e-6);
  EXPECT_DOUBLE_EQ(s.p75, 3e-6);
  EXPECT_NEAR(s.spread(), 1e-6 / 2.5e-6, 1e-12);
}

TEST(Stats, SingleSampleHasNoSpread) {
  const std::vector<double> v = {0.25};
  const Stats s = summarize(v);
  EXPECT_DOUBLE_EQ(s.median, 0.25);
  EXPECT_DOUBLE_EQ(s.spread(), 0.0);
  EXPECT_EQ(s.values, v);
}

TEST(Stats, SpreadIsRelativeToTheMediansMagnitude) {
  const Stats neg = summarize(std::vector<double>{-4, -1, -3, -2, -5});
  EXPECT_DOUBLE_EQ(neg.median, -3);
  EXPECT_DOUBLE_EQ(neg.spread(), 2.0 / 3.0);
  const Stats zero = summarize(std::vector<double>{-1, 0, 1});
  EXPECT_DOUBLE_EQ(zero.median, 0);
  EXPECT_DOUBLE_EQ(zero.spread(), 0.0);  // no relative spread around a zero median
}

TEST(Stats, RejectsEmptyAndNonFiniteSamples) {
  EXPECT_THROW(summarize(std::vector<double>{}), std::invalid_argument);
  EXPECT_THROW(summarize(std::vector<double>{1.0, std::numeric_limits<double>::quiet_NaN()}),
               std::invalid_argument);
  EXPECT_THROW(summarize(std::vector<double>{1.0, std::numeric_limits<double>::infinity()}),
               std::invalid_argument);
  EXPECT_THROW(summarize(std::vector<double>{1.0, std::nan("")}), std::invalid_argument);
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
}  // namespace dtflop
