#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "probes/fit.hpp"

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

TEST(StudentT, MatchesTables) {
  EXPECT_DOUBLE_EQ(student_t95(1), 12.706);
  EXPECT_DOUBLE_EQ(student_t95(17), 2.110);
  EXPECT_DOUBLE_EQ(student_t95(1000), 1.96);
  EXPECT_THROW(student_t95(0), std::invalid_argument);
}

}  // namespace
}  // namespace dtflop::probes
