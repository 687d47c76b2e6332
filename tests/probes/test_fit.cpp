#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "probes/fit.hpp"
#include "probes/measure.hpp"

namespace dtflop::probes {
namespace {

std::vector<TransferPoint> sweep(double latency, double bandwidth) {
  std::vector<TransferPoint> p;
  for (double s = 4096; s <= 1024.0 * 1024 * 1024; s *= 2) p.push_back({s, latency + s / bandwidth});
  return p;
}

TEST(LatencyBandwidthFit, RecoversExactModel) {
  const auto p = sweep(11e-6, 54.6e9);
  const auto f = fit_latency_bandwidth(p);
  EXPECT_EQ(f.points, p.size());
  EXPECT_FALSE(f.latency_clamped);
  EXPECT_NEAR(f.latency, 11e-6, 11e-6 * 1e-9);
  EXPECT_NEAR(f.bandwidth, 54.6e9, 54.6e9 * 1e-9);
  EXPECT_LT(f.rms_rel_residual, 1e-12);
  EXPECT_LT(f.latency_hw95, 1e-15);
}

TEST(LatencyBandwidthFit, NoisyDataGiveIntervalsHoldingTheTruth) {
  // 3% multiplicative noise, fixed seed: the figures below are deterministic.
  std::mt19937_64 rng(12345);
  std::normal_distribution<double> noise(0.0, 0.03);
  auto p = sweep(9e-6, 25e9);
  for (auto& x : p) x.seconds *= 1.0 + noise(rng);
  const auto f = fit_latency_bandwidth(p);
  EXPECT_NEAR(f.latency, 9e-6, 0.05 * 9e-6);
  EXPECT_NEAR(f.bandwidth, 25e9, 0.03 * 25e9);
  EXPECT_GT(f.latency_hw95, 0);
  EXPECT_GT(f.bandwidth_hw95, 0);
  EXPECT_LE(std::fabs(f.latency - 9e-6), f.latency_hw95);
  EXPECT_LE(std::fabs(f.bandwidth - 25e9), f.bandwidth_hw95);
  EXPECT_GT(f.rms_rel_residual, 0.01);
  EXPECT_LT(f.rms_rel_residual, 0.06);
  EXPECT_GE(f.max_rel_residual, f.rms_rel_residual);
}

TEST(LatencyBandwidthFit, RelativeWeightingLetsSmallCopiesDecideTheLatency) {
  // The 4 KiB copies alone pin L: with an unweighted fit the 1 GiB copy's 1% noise (200 us)
  // would swamp a 10 us latency. Here the largest copy is 1% slow and L must barely move.
  auto p = sweep(10e-6, 50e9);
  p.back().seconds *= 1.01;
  const auto f = fit_latency_bandwidth(p);
  EXPECT_NEAR(f.latency, 10e-6, 0.02 * 10e-6);
}

TEST(LatencyBandwidthFit, NegativeInterceptIsClampedToZero) {
  // Times shorter than bytes/B by a constant: the unconstrained L would be negative.
  std::vector<TransferPoint> p;
  for (double s = 1 << 20; s <= (1 << 30); s *= 2) p.push_back({s, s / 10e9 - 20e-6});
  const auto f = fit_latency_bandwidth(p);
  EXPECT_TRUE(f.latency_clamped);
  EXPECT_EQ(f.latency, 0.0);
  EXPECT_NEAR(f.bandwidth, 10e9, 0.05 * 10e9);
}

TEST(LatencyBandwidthFit, RejectsBadInput) {
  EXPECT_THROW(fit_latency_bandwidth(std::vector<TransferPoint>{{4096, 1e-5}, {8192, 2e-5}}),
               std::invalid_argument);
  EXPECT_THROW(fit_latency_bandwidth(std::vector<TransferPoint>{{4096, 1e-5}, {8192, 0}, {16384, 3e-5}}),
               std::invalid_argument);
  EXPECT_THROW(fit_latency_bandwidth(std::vector<TransferPoint>{{4096, 1e-5}, {4096, 2e-5}, {4096, 3e-5}}),
               std::invalid_argument);
  EXPECT_THROW(fit_latency_bandwidth(std::vector<TransferPoint>{{4096, 1e-5}, {8192, NAN}, {16384, 3e-5}}),
               std::invalid_argument);
  // Time falling with size: no positive bandwidth.
  EXPECT_THROW(fit_latency_bandwidth(std::vector<TransferPoint>{{4096, 3e-5}, {8192, 2e-5}, {16384, 1e-5}}),
               std::invalid_argument);
}

TEST(PerEventFit, RecoversTheCostPerEventAndTheFixedCost) {
  // 3 us of launch and 9.5 ns an event, 528..8448 events.
  std::vector<TransferPoint> p;
  for (double n = 528; n <= 8448; n *= 2) p.push_back({n, 3e-6 + n * 9.5e-9});
  const PerEventFit f = fit_per_event(p);
  EXPECT_NEAR(f.per_event, 9.5e-9, 9.5e-9 * 1e-9);
  EXPECT_NEAR(f.fixed, 3e-6, 3e-6 * 1e-9);
  EXPECT_FALSE(f.fixed_clamped);
  EXPECT_LT(f.per_event_hw95, 1e-18);
}

// cpu-pixel's all-thread passes: three kinds timed within each pass, passes over two frame sizes
// (11 of each, 2% noise): each kind's slope and the passes' fixed cost, the kinds' intercepts added.
TEST(KindsFit, RecoversEachKindsSlopeAndThePassesFixedCost) {
  std::mt19937_64 rng(2026);
  std::normal_distribution<double> noise(0.0, 0.02);
  const double slope[3] = {0.4e-9, 0.1e-9, 0.19e-9}, fixed[3] = {400e-6, 60e-6, 40e-6};
  const double large[3] = {1048576, 1048576, 4.5e6}, small[3] = {262144, 262144, 1.1e6};
  std::vector<std::vector<TransferPoint>> kinds(3);
  for (int k = 0; k < 3; ++k)
    for (const double* n : {large, small})
      for (int i = 0; i < 11; ++i) kinds[k].push_back({n[k], (fixed[k] + slope[k] * n[k]) * (1 + noise(rng))});
  const KindsFit f = fit_kinds(kinds);
  ASSERT_EQ(f.kinds.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(f.kinds[k].per_event, slope[k], 0.1 * slope[k]) << k;
    EXPECT_LE(std::abs(f.kinds[k].per_event - slope[k]), f.kinds[k].per_event_hw95 * 1.5) << k;
  }
  EXPECT_NEAR(f.fixed, 500e-6, 50e-6);
  EXPECT_GT(f.fixed_hw95, 0);
  EXPECT_LE(std::abs(f.fixed - 500e-6), 1.5 * f.fixed_hw95);
  // Without a fixed part each kind's line goes through (about) zero; one frame size cannot be fitted.
  for (int k = 0; k < 3; ++k)
    for (auto& p : kinds[k]) p.seconds = slope[k] * p.bytes;
  EXPECT_NEAR(fit_kinds(kinds).fixed, 0, 1e-12);
  std::vector<std::vector<TransferPoint>> one_size(1);
  for (int i = 0; i < 5; ++i) one_size[0].push_back({1e6, 1e-3});
  EXPECT_THROW(fit_kinds(one_size), std::invalid_argument);
}

TEST(PerEventFit, IntervalIsTheBandwidthsMappedToACostPerEvent) {
  std::mt19937_64 rng(777);
  std::normal_distribution<double> noise(0.0, 0.02);
  std::vector<TransferPoint> p;
  for (double n = 100; n <= 12800; n *= 2) p.push_back({n, (2e-6 + n * 4e-9) * (1.0 + noise(rng))});
  const PerEventFit e = fit_per_event(p);
  const LatencyBandwidthFit f = fit_latency_bandwidth(p);
  EXPECT_DOUBLE_EQ(e.per_event, 1.0 / f.bandwidth);
  EXPECT_DOUBLE_EQ(e.per_event_hw95, f.bandwidth_hw95 / (f.bandwidth * f.bandwidth));
  EXPECT_DOUBLE_EQ(e.fixed_hw95, f.latency_hw95);
  EXPECT_GT(e.per_event_hw95, 0);
  EXPECT_LE(std::fabs(e.per_event - 4e-9), e.per_event_hw95);
  // Times that fall with the count: no positive cost per event.
  EXPECT_THROW(fit_per_event(std::vector<TransferPoint>{{1, 3e-6}, {2, 2e-6}, {4, 1e-6}}), std::invalid_argument);
}

// A probe's figure from such a fit (gpu-atomics, gpu-centroid): the slope and its interval, the
// statistics of the repetitions it names.
TEST(PerEventFit, MeasurementCarriesTheSlopeAndItsInterval) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0.0, 0.03);
  std::vector<TransferPoint> p;
  for (double n = 1e4; n <= 1.6e5; n *= 2) p.push_back({n, (1e-5 + n * 6e-11) * (1.0 + noise(rng))});
  const PerEventFit f = fit_per_event(p);
  const std::vector<double> last = {2e-5, 1e-5, 3e-5};
  const Measurement m = per_event_measurement("k", "label", f, last, Param::L_GP, "note");
  EXPECT_EQ(m.value, f.per_event);
  ASSERT_TRUE(m.uncertainty.has_value());
  EXPECT_EQ(*m.uncertainty, f.per_event_hw95);
  EXPECT_EQ(m.unit, "s");
  EXPECT_EQ(m.stats.n, 3u);
  EXPECT_EQ(m.stats.median, 2e-5);
  ASSERT_TRUE(m.param.has_value());
  EXPECT_EQ(*m.param, Param::L_GP);
}

TEST(StudentT, MatchesTables) {
  EXPECT_DOUBLE_EQ(student_t95(1), 12.706);
  EXPECT_DOUBLE_EQ(student_t95(17), 2.110);
  EXPECT_DOUBLE_EQ(student_t95(1000), 1.96);
  EXPECT_THROW(student_t95(0), std::invalid_argument);
}

}  // namespace
}  // namespace dtflop::probes
