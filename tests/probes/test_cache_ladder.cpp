// The knee rule of cpu-memory's cache ladder (probes/cache_ladder.hpp) on synthetic ladders whose
// knee is known, and the ladder's sizes.
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "probes/cache_ladder.hpp"

namespace dtflop::probes {
namespace {

constexpr std::int64_t MiB = 1 << 20;

// Sizes 4, 8, 16, ... MiB (`count` of them), each with bandwidth f(size in MiB).
template <typename F>
std::vector<LadderPoint> ladder(int count, F f) {
  std::vector<LadderPoint> v;
  for (int i = 0; i < count; ++i) {
    const std::int64_t b = (std::int64_t{4} << i) * MiB;
    v.push_back({b, f(static_cast<double>(b / MiB))});
  }
  return v;
}

TEST(CacheKnee, StepFromCacheToMemoryGivesTheLastSizeOnTheCachePlateau) {
  // 30 GB/s up to 32 MiB, 10 GB/s from 64 MiB: 4..32 on the plateau, 64..1024 off it.
  const auto l = ladder(9, [](double mib) { return mib <= 32 ? 30e9 : 10e9; });
  const CacheKnee k = find_cache_knee(l);
  ASSERT_TRUE(k.bytes.has_value()) << k.why;
  EXPECT_EQ(k.above, 32 * MiB);
  EXPECT_EQ(k.below, 64 * MiB);
  // The threshold is the plateaus' geometric mean, so a step is crossed half-way in log size:
  // at sqrt(32 x 64) MiB.
  EXPECT_NEAR(static_cast<double>(*k.bytes), std::sqrt(32.0 * 64.0) * MiB, 1.0);
  EXPECT_DOUBLE_EQ(k.cache_plateau, 30e9);
  EXPECT_DOUBLE_EQ(k.memory_plateau, 10e9);
  EXPECT_NEAR(k.threshold, std::sqrt(300.0) * 1e9, 1e3);
}

TEST(CacheKnee, GradualFallIsCutWhereItCrossesTheGeometricMean) {
  // 40 GB/s to 8 MiB, then halving per doubling down to 10 GB/s at 32 MiB and beyond: the
  // threshold is 20 GB/s, met at 16 MiB (exactly) and missed at 32.
  const auto l = ladder(8, [](double mib) { return mib <= 8 ? 40e9 : std::max(10e9, 40e9 * 8 / mib); });
  const CacheKnee k = find_cache_knee(l);
  ASSERT_TRUE(k.bytes.has_value()) << k.why;
  EXPECT_EQ(k.above, 16 * MiB);
  EXPECT_EQ(*k.bytes, 16 * MiB);
}

TEST(CacheKnee, ThePointsBesideTheThresholdPlaceTheKneeBetweenThem) {
  // 30 GB/s to 32 MiB, 20 at 64, 10 beyond: threshold sqrt(300) = 17.3 GB/s, crossed between
  // 64 MiB (20) and 128 MiB (10) where log(20 / 17.3) / log(20 / 10) = 0.2075 of the octave has
  // passed: 64 x 2^0.2075 = 73.9 MiB. A point just above or just below the threshold moves the
  // knee a little, not a whole ladder step.
  auto at = [](double at64) {
    return find_cache_knee(ladder(9, [at64](double mib) { return mib <= 32 ? 30e9 : mib == 64 ? at64 : 10e9; }));
  };
  const CacheKnee k = at(20e9);
  ASSERT_TRUE(k.bytes.has_value()) << k.why;
  const double f = std::log(20.0 / std::sqrt(300.0)) / std::log(2.0);
  EXPECT_NEAR(static_cast<double>(*k.bytes), 64.0 * std::pow(2.0, f) * MiB, 1.0);
  const CacheKnee up = at(17.4e9), down = at(17.2e9);
  ASSERT_TRUE(up.bytes && down.bytes);
  EXPECT_EQ(up.above, 64 * MiB);
  EXPECT_EQ(down.above, 32 * MiB);
  EXPECT_LT(static_cast<double>(*up.bytes - *down.bytes), 0.02 * static_cast<double>(*up.bytes));
}

TEST(CacheKnee, TheCachePlateauIsTheHighestPointNotTheFirst) {
  // The first size reads slower (page-table warm-up, say); the plateau is 30 GB/s at 8-64 MiB.
  const auto l = ladder(9, [](double mib) { return mib == 4 ? 20e9 : mib <= 64 ? 30e9 : 8e9; });
  const CacheKnee k = find_cache_knee(l);
  ASSERT_TRUE(k.bytes.has_value()) << k.why;
  EXPECT_EQ(k.above, 64 * MiB);
}

TEST(CacheKnee, FlatLadderHasNoKnee) {
  const auto l = ladder(9, [](double mib) { return 12e9 + 1e6 * mib; });  // under 1.3x apart
  const CacheKnee k = find_cache_knee(l);
  EXPECT_FALSE(k.bytes.has_value());
  EXPECT_NE(k.why.find("no step"), std::string::npos) << k.why;
}

TEST(CacheKnee, FallAmongTheLargestSizesLeavesNoMemoryPlateau) {
  // The fall comes at the second-largest size: nothing beyond it says what memory reads at.
  const auto l = ladder(8, [](double mib) { return mib < 256 ? 30e9 : 10e9; });
  const CacheKnee k = find_cache_knee(l);
  EXPECT_FALSE(k.bytes.has_value());
  EXPECT_NE(k.why.find("no memory plateau"), std::string::npos) << k.why;
}

TEST(CacheKnee, ClimbingBackAboveTheThresholdIsNoSingleKnee) {
  // 30 GB/s to 16 MiB, a fall, 30 GB/s again at 128 MiB, then memory.
  const auto l = ladder(10, [](double mib) { return mib <= 16 || mib == 128 ? 30e9 : 10e9; });
  const CacheKnee k = find_cache_knee(l);
  EXPECT_FALSE(k.bytes.has_value());
  EXPECT_NE(k.why.find("climbs back"), std::string::npos) << k.why;
}

TEST(CacheKnee, ShortLadderHasNoKnee) {
  const auto l = ladder(4, [](double mib) { return mib <= 8 ? 30e9 : 10e9; });
  EXPECT_FALSE(find_cache_knee(l).bytes.has_value());
}

TEST(CacheKnee, RefusesLaddersThatAreNotAscendingOrNotPositive) {
  auto l = ladder(6, [](double) { return 10e9; });
  std::swap(l[2], l[3]);
  EXPECT_THROW(find_cache_knee(l), std::invalid_argument);
  l = ladder(6, [](double) { return 10e9; });
  l[4].bandwidth = 0;
  EXPECT_THROW(find_cache_knee(l), std::invalid_argument);
  l[4].bandwidth = std::nan("");
  EXPECT_THROW(find_cache_knee(l), std::invalid_argument);
  l[4].bandwidth = 10e9;
  l[0].bytes = 0;
  EXPECT_THROW(find_cache_knee(l), std::invalid_argument);
}

TEST(LadderSizes, DoublesPerOctaveAndClosesOnTheLast) {
  // Two steps an octave from 4 MiB: 4, 5.66, 8, 11.3, 16 MiB, ... each rounded down to 64 KiB.
  const auto s = ladder_sizes(4 * MiB, 16 * MiB, 2);
  const std::vector<std::int64_t> want = {4 * MiB, 5760 * 1024, 8 * MiB, 11584 * 1024, 16 * MiB};
  EXPECT_EQ(s, want);
  // 100 MiB is not on the ladder of 4 MiB's doublings (64, 128): it closes it.
  const auto t = ladder_sizes(4 * MiB, 100 * MiB, 1);
  ASSERT_EQ(t.size(), 6u);
  EXPECT_EQ(t[4], 64 * MiB);
  EXPECT_EQ(t.back(), 100 * MiB);
  EXPECT_EQ(ladder_sizes(4 * MiB, 4 * MiB, 4), std::vector<std::int64_t>{4 * MiB});
  EXPECT_THROW(ladder_sizes(0, 4 * MiB, 2), std::invalid_argument);
  EXPECT_THROW(ladder_sizes(8 * MiB, 4 * MiB, 2), std::invalid_argument);
  EXPECT_THROW(ladder_sizes(4 * MiB, 8 * MiB, 0), std::invalid_argument);
}

}  // namespace
}  // namespace dtflop::probes
