#include <gtest/gtest.h>

#include <algorithm>

#include "model/errors.hpp"
#include "model/predict.hpp"
#include "model/terms.hpp"
#include "tests/model/fixtures.hpp"

namespace dtflop {
namespace {

CostCounts sample_counts() {
  CostCounts c;
  c.P = 4;
  c.N_CG = 1'000'000;
  c.N_GC = 500'000;
  c.N_GG = 2'000'000;
  c.N_C = 1'000'000;
  c.N_G = 100'000'000;
  c.transfers_CG = 3;
  c.transfers_GC = 2;
  c.launches = 4;
  c.host_memory = HostMemory::pinned;
  return c;
}

// Does a prediction of `c` with `v` need parameter `p` (staging figures priced when `staged`)?
bool needs(const CostCounts& c, Variant v, Param p, bool staged = false) {
  const auto r = required_params(c, v, Pricing{.staging = staged});
  return std::find(r.begin(), r.end(), p) != r.end();
}

TEST(Predict, SeedVariantIsEquations3_2To3_9) {
  const auto m = test::round_profile();
  const auto p = predict(m, sample_counts(), Variant::seed);
  // By hand: 4 B x 1e6 / 50e9 B/s = 80 us; 4 x 5e5 / 40e9 = 50 us; 4 x 2e6 / 4e12 = 2 us;
  // 1e6 / 100e9 = 10 us (one thread); 1e8 / 50e12 = 2 us.
  EXPECT_DOUBLE_EQ(p.dt_CG, 80e-6);
  EXPECT_DOUBLE_EQ(p.dt_GC, 50e-6);
  EXPECT_DOUBLE_EQ(p.dt_GG, 2e-6);
  EXPECT_DOUBLE_EQ(p.dt_C, 10e-6);
  EXPECT_DOUBLE_EQ(p.dt_G, 2e-6);
  EXPECT_DOUBLE_EQ(p.dt_trans(), 132e-6);
  EXPECT_EQ(p.lat_CG, 0.0);
  EXPECT_EQ(p.lat_launch, 0.0);
  EXPECT_NEAR(p.total, 144e-6, 1e-18);
}

TEST(Predict, LatencyVariantAddsPerTransferAndPerLaunchCosts) {
  const auto m = test::round_profile();
  const auto p = predict(m, sample_counts(), Variant::latency);
  EXPECT_DOUBLE_EQ(p.lat_CG, 3 * 10e-6);
  EXPECT_DOUBLE_EQ(p.lat_GC, 2 * 12e-6);
  EXPECT_DOUBLE_EQ(p.lat_launch, 4 * 3e-6);
  EXPECT_NEAR(p.total, 144e-6 + 30e-6 + 24e-6 + 12e-6, 1e-15);
}

TEST(Predict, ExtendedVariantOverlapsDeviceTrafficAndArithmetic) {
  const auto m = test::round_profile();
  auto c = sample_counts();
  c.N_G = 1'000'000'000;  // 20 us of arithmetic against 2 us of memory traffic
  const auto p = predict(m, c, Variant::extended);
  EXPECT_DOUBLE_EQ(p.dt_G, 20e-6);
  EXPECT_NEAR(p.total, 80e-6 + 50e-6 + 20e-6 + 10e-6 + 30e-6 + 24e-6 + 12e-6, 1e-15);
  // The seed variant sums the two instead.
  EXPECT_NEAR(predict(m, c, Variant::seed).total, 80e-6 + 50e-6 + 2e-6 + 10e-6 + 20e-6, 1e-15);
}

TEST(Predict, ExtendedVariantBoundsCpuWorkByHostMemory) {
  const auto m = test::round_profile();
  CostCounts c;
  c.P = 4;
  c.N_C = 1'000'000;   // 10 us at 100 GFLOP/s
  c.N_CC = 1'000'000;  // 4 MB at 20 GB/s = 200 us
  EXPECT_NEAR(predict(m, c, Variant::extended).dt_C, 200e-6, 1e-15);
  EXPECT_NEAR(predict(m, c, Variant::seed).dt_C, 10e-6, 1e-15);
}

TEST(Predict, TheLastLevelCacheServesTheShareOfTrafficItsWorkingSetLeavesIn) {
  auto m = test::round_profile();
  m.set(Param::B_llc_1, {80e9, Provenance::probed, {}, {}, ""});
  m.set(Param::B_llc, {320e9, Provenance::probed, {}, {}, ""});
  CostCounts c;
  c.P = 4;
  c.N_C = 1'000'000;   // 10 us at 100 GFLOP/s (one thread)
  c.N_CC = 1'000'000;  // 4 MB: 200 us at 20 GB/s from memory, 50 us at 80 GB/s from the cache
  // No working set counted, or no cache size known: all from memory, no B_llc needed.
  EXPECT_NEAR(predict(m, c, Variant::memory).dt_C, 210e-6, 1e-15);
  c.cpu_footprint = 8 << 20;
  EXPECT_EQ(llc_share_missed(m, c), 1.0);
  EXPECT_NEAR(predict(m, c, Variant::memory).dt_C, 210e-6, 1e-15);
  // A 32 MiB cache and an 8 MiB working set: a quarter from memory, three quarters from the cache.
  m.identity.cpu_llc_bytes = 32 << 20;
  EXPECT_DOUBLE_EQ(llc_share_missed(m, c), 0.25);
  EXPECT_NEAR(predict(m, c, Variant::memory).dt_C, 10e-6 + 0.25 * 200e-6 + 0.75 * 50e-6, 1e-15);
  EXPECT_NEAR(predict(m, c, Variant::extended).dt_C, 0.25 * 200e-6 + 0.75 * 50e-6, 1e-15);
  // The cache the probe measured this process to get, where there is one, and not the system's:
  // 16 MiB effective of a reported 480 MiB: half of the 8 MiB working set's traffic from memory.
  m.identity.cpu_llc_bytes = std::int64_t{480} << 20;
  m.identity.cpu_llc_effective_bytes = 16 << 20;
  EXPECT_DOUBLE_EQ(llc_share_missed(m, c), 0.5);
  EXPECT_NEAR(predict(m, c, Variant::extended).dt_C, 0.5 * 200e-6 + 0.5 * 50e-6, 1e-15);
  m.identity.cpu_llc_bytes = 32 << 20;
  m.identity.cpu_llc_effective_bytes = 0;
  // Working sets of the cache's size or more: all from memory.
  c.cpu_footprint = 64 << 20;
  EXPECT_NEAR(predict(m, c, Variant::memory).dt_C, 210e-6, 1e-15);
  // Eight threads on this 8-thread machine use the all-thread figures.
  c.cpu_footprint = 8 << 20;
  c.cpu_threads = 8;
  EXPECT_NEAR(predict(m, c, Variant::extended).dt_C, 0.25 * 4e6 / 60e9 + 0.75 * 4e6 / 320e9, 1e-15);
  // A cache size known but no B_llc: the missing figures are named.
  m.erase(Param::B_llc);
  EXPECT_THROW(predict(m, c, Variant::memory), MissingParameter);
  EXPECT_NO_THROW(predict(m, c, Variant::latency));  // which leaves host traffic out
  // A 64 MiB working set fits the 480 MiB the system reports but not the 16 MiB measured: with a
  // measured cache it is priced from memory alone and needs no B_llc.
  m.identity.cpu_llc_bytes = std::int64_t{480} << 20;
  c.cpu_footprint = 64 << 20;
  EXPECT_THROW(predict(m, c, Variant::memory), MissingParameter);
  m.identity.cpu_llc_effective_bytes = 16 << 20;
  EXPECT_NO_THROW(predict(m, c, Variant::memory));
}

TEST(Predict, MemoryVariantAddsHostTrafficToCpuArithmetic) {
  const auto m = test::round_profile();
  CostCounts c;
  c.P = 4;
  c.N_C = 1'000'000;   // 10 us at 100 GFLOP/s (one thread)
  c.N_CC = 1'000'000;  // 4 MB at 20 GB/s (one thread) = 200 us
  const auto p = predict(m, c, Variant::memory);
  EXPECT_NEAR(p.dt_C, 210e-6, 1e-15);  // summed, where extended takes the larger
  EXPECT_NEAR(p.total, 210e-6, 1e-15);
  EXPECT_NEAR(predict(m, c, Variant::extended).dt_C, 200e-6, 1e-15);
  EXPECT_NEAR(predict(m, c, Variant::latency).dt_C, 10e-6, 1e-15);  // latency leaves host traffic out
  // The device side is the seed's sum, as in the latency variant.
  const auto dev = sample_counts();
  EXPECT_NEAR(predict(m, dev, Variant::memory).total, predict(m, dev, Variant::latency).total, 1e-18);
}

TEST(Predict, SlidingWindowFlopsCostKCwTimesTheOthersInTheMemoryVariants) {
  const auto m = test::round_profile();  // K_CW = 1.5
  CostCounts c;
  c.N_C = 1'000'000;  // 10 us at 100 GFLOP/s (one thread)
  c.N_CW = 400'000;   // of which 4 us are sliding-window FLOPs: 6 us at K_CW = 1.5
  EXPECT_NEAR(predict(m, c, Variant::memory).dt_C, 12e-6, 1e-15);
  EXPECT_NEAR(predict(m, c, Variant::extended).dt_C, 12e-6, 1e-15);  // no host traffic to overlap
  // The seed and latency variants price every FLOP alike.
  EXPECT_NEAR(predict(m, c, Variant::seed).dt_C, 10e-6, 1e-15);
  EXPECT_NEAR(predict(m, c, Variant::latency).dt_C, 10e-6, 1e-15);
  // The extended variant overlaps the priced arithmetic with host traffic: 4 MB at 20 GB/s.
  c.N_CC = 1'000'000;
  EXPECT_NEAR(predict(m, c, Variant::extended).dt_C, 200e-6, 1e-15);
  c.N_CC = 10'000;  // 2 us of traffic under 12 us of arithmetic
  EXPECT_NEAR(predict(m, c, Variant::extended).dt_C, 12e-6, 1e-15);
  // K_CW is needed only where sliding-window FLOPs are counted, and only by those variants.
  EXPECT_TRUE(needs(c, Variant::memory, Param::K_CW));
  EXPECT_TRUE(needs(c, Variant::extended, Param::K_CW));
  EXPECT_FALSE(needs(c, Variant::latency, Param::K_CW));
  CostCounts plain = c;
  plain.N_CW = 0;
  EXPECT_FALSE(needs(plain, Variant::memory, Param::K_CW));
  auto without = m;
  without.erase(Param::K_CW);
  EXPECT_NO_THROW(predict(without, plain, Variant::memory));
  try {
    predict(without, c, Variant::memory);
    ADD_FAILURE() << "no MissingParameter";
  } catch (const MissingParameter& e) {
    EXPECT_NE(std::string(e.what()).find("K_CW"), std::string::npos) << e.what();
    // The cpu-window probe measures it: the message sends the user to a probe.
    EXPECT_NE(std::string(e.what()).find("dtflop probe"), std::string::npos) << e.what();
  }
  // More sliding-window FLOPs than FLOPs: inconsistent counts.
  c.N_CW = c.N_C + 1;
  EXPECT_THROW(predict(m, c, Variant::memory), InputError);
  c.N_CW = -1;
  EXPECT_THROW(predict(m, c, Variant::latency), InputError);
}

TEST(Predict, ChainedWindowFlopsCostKCdTimesTheOthersBesideTheSlidingWindowOnes) {
  auto m = test::round_profile();  // K_CW = 1.5, V_C1 100 GFLOP/s
  m.set(Param::K_CD, Parameter{4.0, Provenance::probed, {}, {}, {}});
  CostCounts c;
  c.N_C = 1'000'000;  // 10 us at the FMA rate
  c.N_CW = 200'000;   // 2 us -> 3 us at K_CW = 1.5
  c.N_CD = 500'000;   // 5 us -> 20 us at K_CD = 4
  EXPECT_NEAR(predict(m, c, Variant::memory).dt_C, (3e5 + 3e5 + 2e6) / 100e9, 1e-15);
  EXPECT_NEAR(predict(m, c, Variant::extended).dt_C, 26e-6, 1e-15);
  EXPECT_NEAR(predict(m, c, Variant::latency).dt_C, 10e-6, 1e-15);  // every FLOP alike
  EXPECT_TRUE(needs(c, Variant::memory, Param::K_CD));
  EXPECT_FALSE(needs(c, Variant::latency, Param::K_CD));
  CostCounts none = c;
  none.N_CD = 0;
  EXPECT_FALSE(needs(none, Variant::memory, Param::K_CD));
  // Aligned-window FLOPs at K_CA.
  m.set(Param::K_CA, Parameter{2.0, Provenance::probed, {}, {}, {}});
  c.N_CA = 100'000;  // 1 us -> 2 us
  EXPECT_NEAR(predict(m, c, Variant::memory).dt_C, (3e5 + 3e5 + 2e6 + 1e5) / 100e9, 1e-15);
  EXPECT_NEAR(predict(m, c, Variant::latency).dt_C, 10e-6, 1e-15);
  EXPECT_TRUE(needs(c, Variant::memory, Param::K_CA));
  c.N_CA = 0;
  // A FLOP is of one kind of window at most.
  c.N_CD = 900'000;
  EXPECT_THROW(predict(m, c, Variant::memory), InputError);
}

TEST(Predict, PixelStepsOnSeveralThreadsCostLPixelAllWhereTheProfileHasIt) {
  auto m = test::round_profile();
  m.set(Param::L_pixel, Parameter{2e-9, Provenance::probed, {}, {}, {}});
  CostCounts c;
  c.pixel_steps = 1'000'000;
  c.cpu_threads = 2;
  // A profile without L_pixel_all (probed before it, or fitted so) prices every step at L_pixel.
  EXPECT_NEAR(predict(m, c, Variant::latency).lat_pixel, 2e-3, 1e-15);
  m.set(Param::L_pixel_all, Parameter{0.8e-9, Provenance::probed, {}, {}, {}});
  EXPECT_NEAR(predict(m, c, Variant::latency).lat_pixel, 0.8e-3, 1e-15);
  // One thread is L_pixel whatever the profile holds.
  c.cpu_threads = 1;
  EXPECT_NEAR(predict(m, c, Variant::latency).lat_pixel, 2e-3, 1e-15);
  // A fit finds L_pixel_all from samples on several threads, L_pixel from those on one.
  const auto fit_needs = [](const CostCounts& k, Param p) {
    const auto r = required_params(k, Variant::latency,
                                   Pricing{.staging = true, .all_threads = true, .serial = true, .graph = true, .pixel_all = true});
    return std::find(r.begin(), r.end(), p) != r.end();
  };
  EXPECT_TRUE(fit_needs(c, Param::L_pixel));
  EXPECT_FALSE(fit_needs(c, Param::L_pixel_all));
  c.cpu_threads = 2;
  EXPECT_TRUE(fit_needs(c, Param::L_pixel_all));
  EXPECT_FALSE(fit_needs(c, Param::L_pixel));
}

// Where the profile has the figures of each kind of pixel step (cpu-pixel times them apart), a
// labelled pixel costs L_label, a histogram's count L_hist and every other step L_scan; the
// richest figures the profile has price them.
TEST(Predict, PixelStepsArePricedByKindWhereTheProfileHasTheThreeFigures) {
  auto m = test::round_profile();
  m.set(Param::L_pixel, Parameter{2e-9, Provenance::probed, {}, {}, {}});
  CostCounts c;
  c.pixel_steps = 1'000'000;
  c.label_steps = 200'000;
  c.hist_steps = 100'000;
  c.cpu_threads = 1;
  // Without the three (a profile probed before the kinds were apart, or some of them), every
  // step at L_pixel.
  EXPECT_NEAR(predict(m, c, Variant::latency).lat_pixel, 2e-3, 1e-15);
  m.set(Param::L_label, Parameter{7e-9, Provenance::probed, {}, {}, {}});
  m.set(Param::L_scan, Parameter{1e-9, Provenance::probed, {}, {}, {}});
  EXPECT_NEAR(predict(m, c, Variant::latency).lat_pixel, 2e-3, 1e-15);
  m.set(Param::L_hist, Parameter{0.5e-9, Provenance::probed, {}, {}, {}});
  // 2e5 x 7 ns + 1e5 x 0.5 ns + 7e5 x 1 ns = 1.4 ms + 0.05 ms + 0.7 ms.
  EXPECT_NEAR(predict(m, c, Variant::latency).lat_pixel, 1.4e-3 + 0.05e-3 + 0.7e-3, 1e-15);
  // Counts that never say which steps label or count (stores written before them) keep L_pixel.
  CostCounts old = c;
  old.label_steps = old.hist_steps = 0;
  EXPECT_NEAR(predict(m, old, Variant::latency).lat_pixel, 2e-3, 1e-15);
  // The seed variant has no pixel term at all.
  EXPECT_EQ(predict(m, c, Variant::seed).lat_pixel, 0);
  // A step is of one kind at most.
  CostCounts over = c;
  over.hist_steps = 900'000;
  EXPECT_THROW(predict(m, over, Variant::latency), InputError);
  // On several threads: the _all figures where the profile has the three; else L_pixel_all where
  // it has that; else the one-thread kinds.
  c.cpu_threads = 2;
  EXPECT_NEAR(predict(m, c, Variant::latency).lat_pixel, 1.4e-3 + 0.05e-3 + 0.7e-3, 1e-15);
  m.set(Param::L_pixel_all, Parameter{1e-9, Provenance::probed, {}, {}, {}});
  EXPECT_NEAR(predict(m, c, Variant::latency).lat_pixel, 1e-3, 1e-15);
  m.set(Param::L_label_all, Parameter{2e-9, Provenance::probed, {}, {}, {}});
  m.set(Param::L_hist_all, Parameter{0.5e-9, Provenance::probed, {}, {}, {}});
  m.set(Param::L_scan_all, Parameter{0.5e-9, Provenance::probed, {}, {}, {}});
  EXPECT_NEAR(predict(m, c, Variant::latency).lat_pixel, 0.4e-3 + 0.05e-3 + 0.35e-3, 1e-15);
  // Only the kinds the counts have are needed: every step a labelled one needs no L_scan or L_hist.
  CostCounts all_label = c;
  all_label.label_steps = all_label.pixel_steps;
  all_label.hist_steps = 0;
  const auto r = required_params(all_label, Variant::latency, Pricing{.pixel_kinds = true, .pixel_kinds_all = true});
  EXPECT_EQ(std::count(r.begin(), r.end(), Param::L_label_all), 1);
  EXPECT_EQ(std::count(r.begin(), r.end(), Param::L_hist_all), 0);
  EXPECT_EQ(std::count(r.begin(), r.end(), Param::L_scan_all), 0);
  // A fit finds the kinds' figures from samples that count them, L_pixel from those that do not.
  const Pricing fit{.pixel_all = true, .pixel_kinds = true, .pixel_kinds_all = true};
  c.cpu_threads = 1;
  const auto one = required_params(c, Variant::latency, fit);
  for (Param p : {Param::L_label, Param::L_hist, Param::L_scan}) EXPECT_EQ(std::count(one.begin(), one.end(), p), 1);
  EXPECT_EQ(std::count(one.begin(), one.end(), Param::L_pixel), 0);
  const auto before = required_params(old, Variant::latency, fit);
  EXPECT_EQ(std::count(before.begin(), before.end(), Param::L_pixel), 1);
  EXPECT_EQ(std::count(before.begin(), before.end(), Param::L_label), 0);
}

// Priced by kind, the pixel passes' memory traffic is in the kinds' figures (timed on such passes):
// dt_CC prices the rest of N_CC only. On several threads a frame's passes cost L_pass_all each
// beside their steps, where the profile has it.
TEST(Predict, PixelPassesCarryTheirTrafficAndOnSeveralThreadsAFixedCost) {
  auto m = test::round_profile();  // B_host_1 20 GB/s, B_host 60 GB/s
  m.set(Param::L_pixel, Parameter{2e-9, Provenance::probed, {}, {}, {}});
  m.set(Param::L_pixel_all, Parameter{1e-9, Provenance::probed, {}, {}, {}});
  CostCounts c;
  c.P = 8;
  c.N_CC = 1'000'000;
  c.N_CC_pixel = 750'000;
  c.pixel_steps = 1'000'000;
  c.label_steps = 200'000;
  c.hist_steps = 100'000;
  c.pixel_passes = 2;
  c.cpu_threads = 1;
  // One figure for every step (no kinds): N_CC whole, 8 MB at 20 GB/s; no fixed cost.
  EXPECT_NEAR(predict(m, c, Variant::memory).dt_CC, 8e6 / 20e9, 1e-15);
  EXPECT_NEAR(predict(m, c, Variant::memory).lat_pixel, 2e-3, 1e-15);
  for (Param p : {Param::L_label, Param::L_label_all}) m.set(p, Parameter{7e-9, Provenance::probed, {}, {}, {}});
  for (Param p : {Param::L_hist, Param::L_hist_all}) m.set(p, Parameter{0.5e-9, Provenance::probed, {}, {}, {}});
  for (Param p : {Param::L_scan, Param::L_scan_all}) m.set(p, Parameter{1e-9, Provenance::probed, {}, {}, {}});
  // By kind: 250'000 values, 2 MB at 20 GB/s.
  EXPECT_NEAR(predict(m, c, Variant::memory).dt_CC, 2e6 / 20e9, 1e-15);
  const double steps = 1.4e-3 + 0.05e-3 + 0.7e-3;
  EXPECT_NEAR(predict(m, c, Variant::memory).lat_pixel, steps, 1e-15);
  // One thread has no fixed cost even where the profile has L_pass_all.
  m.set(Param::L_pass_all, Parameter{300e-6, Provenance::probed, {}, {}, {}});
  EXPECT_NEAR(predict(m, c, Variant::memory).lat_pixel, steps, 1e-15);
  c.cpu_threads = 2;
  EXPECT_NEAR(predict(m, c, Variant::memory).lat_pixel, steps + 2 * 300e-6, 1e-15);
  const double two_threads_by_kind = predict(m, c, Variant::memory).dt_CC;  // 250'000 values
  EXPECT_GT(two_threads_by_kind, 0);
  auto needs = required_params(c, Variant::memory, Pricing::of(m));
  EXPECT_EQ(std::count(needs.begin(), needs.end(), Param::L_pass_all), 1);
  // Without L_pass_all the _all kinds price the steps alone; so do the L_pixel_all figure's
  // profiles, with every value of N_CC at the bandwidth.
  m.erase(Param::L_pass_all);
  EXPECT_NEAR(predict(m, c, Variant::memory).lat_pixel, steps, 1e-15);
  for (Param p : {Param::L_label_all, Param::L_hist_all, Param::L_scan_all}) m.erase(p);
  EXPECT_NEAR(predict(m, c, Variant::memory).lat_pixel, 1e-3, 1e-15);
  EXPECT_NEAR(predict(m, c, Variant::memory).dt_CC, 4 * two_threads_by_kind, 1e-15);  // all 1'000'000
  // Every value a pixel pass's, priced by kind: no bandwidth needed.
  c.cpu_threads = 1;
  c.N_CC_pixel = c.N_CC;
  EXPECT_EQ(predict(m, c, Variant::memory).dt_CC, 0);
  needs = required_params(c, Variant::memory, Pricing::of(m));
  EXPECT_EQ(std::count(needs.begin(), needs.end(), Param::B_host_1), 0);
  // The part cannot exceed its whole.
  c.N_CC_pixel = c.N_CC + 1;
  EXPECT_THROW(predict(m, c, Variant::memory), InputError);
}

TEST(Predict, WindowsOnSeveralThreadsUseTheAllThreadRatiosWhereTheProfileHasThem) {
  auto m = test::round_profile();  // K_CW = 1.5, V_C1 100 GFLOP/s
  m.set(Param::K_CA, Parameter{2.0, Provenance::probed, {}, {}, {}});
  CostCounts c;
  c.N_C = 1'000'000;
  c.N_CW = 200'000;
  c.N_CA = 100'000;
  c.cpu_threads = 4;
  CostCounts plain = c;  // the same FLOPs at the CPU rate of 4 threads (2.3)
  plain.N_CW = plain.N_CA = 0;
  const double v = 1e6 / predict(m, plain, Variant::memory).dt_C_arith;
  const auto needs_with = [&](Param p) {
    const auto r = required_params(c, Variant::memory, Pricing{.all_threads = true});  // as Pricing::of(m) sets it
    return std::find(r.begin(), r.end(), p) != r.end();
  };
  // A profile without the all-thread ratios (made before them) prices with the one-thread ones.
  EXPECT_NEAR(predict(m, c, Variant::memory).dt_C_arith, (1e6 + 0.5 * 2e5 + 1.0 * 1e5) / v, 1e-15);
  m.set(Param::K_CW_all, Parameter{1.1, Provenance::probed, {}, {}, {}});
  m.set(Param::K_CA_all, Parameter{1.25, Provenance::probed, {}, {}, {}});
  EXPECT_NEAR(predict(m, c, Variant::memory).dt_C_arith, (1e6 + 0.1 * 2e5 + 0.25 * 1e5) / v, 1e-15);
  EXPECT_TRUE(needs_with(Param::K_CW_all));
  EXPECT_FALSE(needs_with(Param::K_CW));
  // One thread keeps the one-thread ratios, whatever the profile holds.
  c.cpu_threads = 1;
  EXPECT_NEAR(predict(m, c, Variant::memory).dt_C_arith,
              (1e6 + 0.5 * 2e5 + 1.0 * 1e5) / m.get(Param::V_C1_fp32).value, 1e-15);
  EXPECT_FALSE(needs_with(Param::K_CA_all));
  EXPECT_TRUE(needs_with(Param::K_CA));
  // A fit of multi-threaded samples finds the _all ratios.
  c.cpu_threads = 2;
  const auto r = required_params(c, Variant::extended, Pricing{.all_threads = true});
  EXPECT_NE(std::find(r.begin(), r.end(), Param::K_CA_all), r.end());
  EXPECT_EQ(std::find(r.begin(), r.end(), Param::K_CA), r.end());
}

TEST(Predict, ASerialChainRunsAtItsOwnRateOnOneThread) {
  auto m = test::round_profile();  // V_C1_fp32 100 GFLOP/s
  m.set(Param::V_CS, Parameter{1e9, Provenance::probed, {}, {}, {}});
  CostCounts c;
  c.N_C = 1'000'001;  // a host sum of 10^6 values and one multiplication
  c.N_CS = 1'000'000;
  // latency+: 1 ms for the chain at 1 GFLOP/s, 10 ps for the multiplication at the FMA rate.
  for (Variant v : {Variant::latency, Variant::memory, Variant::extended})
    EXPECT_NEAR(predict(m, c, v).dt_C, 1e-3 + 1.0 / 100e9, 1e-15) << to_string(v);
  EXPECT_NEAR(predict(m, c, Variant::seed).dt_C, 1'000'001 / 100e9, 1e-15);  // the seed: one rate
  const auto serial_needs = [&](Variant v) {
    const auto r = required_params(c, v, Pricing{.serial = true});
    return std::find(r.begin(), r.end(), Param::V_CS) != r.end();
  };
  EXPECT_TRUE(serial_needs(Variant::latency));
  EXPECT_FALSE(serial_needs(Variant::seed));
  // A profile without V_CS (made before the probe measured it) prices the chain at the CPU rate,
  // as it was fitted to, rather than failing.
  EXPECT_FALSE(needs(c, Variant::latency, Param::V_CS));
  auto before = m;
  before.erase(Param::V_CS);
  EXPECT_NEAR(predict(before, c, Variant::latency).dt_C, 1'000'001 / 100e9, 1e-15);
  // The chain is one thread's, whatever cpu_threads is.
  c.cpu_threads = 16;
  EXPECT_NEAR(predict(m, c, Variant::latency).dt_C - 1e-3, 1.0 / m.get(Param::V_C_fp32).value, 1e-15);
  // Only the chain: no CPU rate needed.
  c.N_C = c.N_CS;
  auto chain_only = m;
  chain_only.erase(Param::V_C1_fp32);
  chain_only.erase(Param::V_C_fp32);
  EXPECT_NEAR(predict(chain_only, c, Variant::latency).dt_C, 1e-3, 1e-15);
  // Not more than N_C, nor with the window kinds together.
  c.N_CW = 1;
  EXPECT_THROW(predict(m, c, Variant::latency), InputError);
}

// lat_GM: a GPU field kernel takes one point's chain (N_GM) at V_GM, added to the kernels' time in
// the latency variants; the seed prices none of it; a profile without V_GM prices it not at all
// (the fields' FLOPs are in N_G at the GPU's rate, as the profiles made before the probe were).
TEST(Predict, AGpuThreadsMlsChainAddsItsOwnTime) {
  auto m = test::round_profile();  // V_G_fp32 = 50 TFLOP/s
  m.set(Param::V_GM, Parameter{4e8, Provenance::probed, {}, {}, {}});
  CostCounts c;
  c.precision = Precision::fp32;
  c.N_G = 1'000'000'000;  // 20 us at the FMA rate
  c.N_GM = 40'000;        // 100 us on one thread's chain
  const double flops = 1e9 / m.get(Param::V_G_fp32).value;
  for (Variant v : {Variant::latency, Variant::memory, Variant::extended}) {
    const Prediction p = predict(m, c, v);
    EXPECT_NEAR(p.lat_GM, 1e-4, 1e-15) << to_string(v);
    EXPECT_NEAR(phase_seconds(p, Phase::G), flops + 1e-4, 1e-15) << to_string(v);
    EXPECT_NEAR(p.device_overheads(), 1e-4, 1e-15) << to_string(v);
  }
  EXPECT_EQ(predict(m, c, Variant::seed).lat_GM, 0.0);
  const auto has = [](const std::vector<Param>& r, Param p) { return std::find(r.begin(), r.end(), p) != r.end(); };
  EXPECT_TRUE(has(required_params(c, Variant::latency, Pricing{.gpu_mls = true}), Param::V_GM));
  EXPECT_FALSE(has(required_params(c, Variant::latency), Param::V_GM));
  EXPECT_FALSE(has(required_params(c, Variant::seed, Pricing{.gpu_mls = true}), Param::V_GM));
  auto before = m;
  before.erase(Param::V_GM);
  EXPECT_EQ(predict(before, c, Variant::latency).lat_GM, 0.0);
  EXPECT_NEAR(phase_seconds(predict(before, c, Variant::latency), Phase::G), flops, 1e-15);
  EXPECT_FALSE(has(priced_params(before, c, Variant::latency), Param::V_GM));
}

// lat_GP: the device's per-dot pixel classification (gpu_pixel_steps) at L_GP, added to the
// kernels' time in the latency variants where the profile has L_GP (the gpu-centroid probe or a
// fit gives it); the seed prices none of it, and a profile without it prices the work by its bytes
// alone, as before.
TEST(Predict, TheDevicesPixelClassificationAddsItsOwnTime) {
  auto m = test::round_profile();
  m.set(Param::L_GP, Parameter{6e-11, Provenance::fitted, {}, {}, {}});
  CostCounts c;
  c.precision = Precision::fp32;
  c.N_G = 1'000'000'000;             // 20 us at the FMA rate
  c.gpu_pixel_steps = 1'000'000;     // 60 us at 60 ps a step
  const double flops = 1e9 / m.get(Param::V_G_fp32).value;
  for (Variant v : {Variant::latency, Variant::memory, Variant::extended}) {
    const Prediction p = predict(m, c, v);
    EXPECT_NEAR(p.lat_GP, 6e-5, 1e-15) << to_string(v);
    EXPECT_NEAR(phase_seconds(p, Phase::G), flops + 6e-5, 1e-15) << to_string(v);
    EXPECT_NEAR(p.device_overheads(), 6e-5, 1e-15) << to_string(v);
  }
  EXPECT_EQ(predict(m, c, Variant::seed).lat_GP, 0.0);
  const auto has = [](const std::vector<Param>& r, Param p) { return std::find(r.begin(), r.end(), p) != r.end(); };
  EXPECT_TRUE(has(required_params(c, Variant::latency, Pricing{.gpu_pixel = true}), Param::L_GP));
  EXPECT_FALSE(has(required_params(c, Variant::latency), Param::L_GP));
  EXPECT_FALSE(has(required_params(c, Variant::seed, Pricing{.gpu_pixel = true}), Param::L_GP));
  auto probed = m;
  probed.erase(Param::L_GP);
  EXPECT_EQ(predict(probed, c, Variant::latency).lat_GP, 0.0);
  EXPECT_NEAR(phase_seconds(predict(probed, c, Variant::latency), Phase::G), flops, 1e-15);
  EXPECT_FALSE(has(priced_params(probed, c, Variant::latency), Param::L_GP));
}

// lat_GF: the device's whole-frame passes (gpu_frame_pixels) at L_GF in the latency variants where
// the profile has L_GF, their values (N_GG_frame) then out of dt_GG (the probe timed such passes,
// traffic included); the seed, and a profile without L_GF, price all of N_GG by its bytes as before.
TEST(Predict, TheDevicesWholeFramePassesArePricedByThePixel) {
  auto m = test::round_profile();
  m.erase(Param::B_L2);  // all of N_GG at B_GG
  m.set(Param::L_GF, Parameter{3e-12, Provenance::probed, {}, {}, {}});
  CostCounts c;
  c.P = 4;
  c.N_GG = 30'000'000;            // 120 MB, of which
  c.N_GG_frame = 20'000'000;      // 80 MB move in the frame passes
  c.gpu_frame_pixels = 60'000'000;  // 6 passes over 10 MP: 180 us at 3 ps a pixel
  const double B = m.get(Param::B_GG).value;
  for (Variant v : {Variant::latency, Variant::memory, Variant::extended}) {
    const Prediction p = predict(m, c, v);
    EXPECT_NEAR(p.lat_GF, 1.8e-4, 1e-15) << to_string(v);
    EXPECT_NEAR(p.dt_GG, 4.0 * 10'000'000 / B, 1e-15) << to_string(v);  // the rest of the kernels' values
    EXPECT_NEAR(phase_seconds(p, Phase::G), 1.8e-4 + 4e7 / B, 1e-15) << to_string(v);
  }
  const Prediction seed = predict(m, c, Variant::seed);
  EXPECT_EQ(seed.lat_GF, 0.0);
  EXPECT_NEAR(seed.dt_GG, 4.0 * 30'000'000 / B, 1e-15);
  const auto has = [](const std::vector<Param>& r, Param p) { return std::find(r.begin(), r.end(), p) != r.end(); };
  EXPECT_TRUE(has(required_params(c, Variant::latency, Pricing{.gpu_frame = true}), Param::L_GF));
  EXPECT_FALSE(has(required_params(c, Variant::latency), Param::L_GF));
  EXPECT_FALSE(has(required_params(c, Variant::seed, Pricing{.gpu_frame = true}), Param::L_GF));
  auto before = m;  // a profile made before the gpu-frame-pass probe
  before.erase(Param::L_GF);
  EXPECT_EQ(predict(before, c, Variant::latency).lat_GF, 0.0);
  EXPECT_NEAR(predict(before, c, Variant::latency).dt_GG, 4.0 * 30'000'000 / B, 1e-15);
  EXPECT_FALSE(has(priced_params(before, c, Variant::latency), Param::L_GF));
  // Every value a frame pass's: nothing else of N_GG to price, and no bandwidth needed for it.
  c.N_GG = c.N_GG_frame;
  EXPECT_EQ(predict(m, c, Variant::latency).dt_GG, 0.0);
  EXPECT_FALSE(has(required_params(c, Variant::latency, Pricing{.gpu_frame = true}), Param::B_GG));
}

TEST(Predict, MlsFieldFlopsRunAtTheirOwnRateOnOneThreadOrAll) {
  auto m = test::round_profile();  // V_C1_fp64 and V_C_fp64 as the fixture sets them
  m.set(Param::V_CM, Parameter{2e9, Provenance::probed, {}, {}, {}});
  CostCounts c;
  c.precision = Precision::fp64;
  c.N_C = 3'000'000;   // 10^6 FLOPs of image analysis at the CPU rate
  c.N_CM = 2'000'000;  // and 2 x 10^6 of MLS fields at V_CM
  const double rest = 1e6 / m.get(Param::V_C1_fp64).value;
  // latency+: 1 ms for the fields at 2 GFLOP/s; the seed: every FLOP at the CPU rate.
  for (Variant v : {Variant::latency, Variant::memory, Variant::extended})
    EXPECT_NEAR(predict(m, c, v).dt_C, 1e-3 + rest, 1e-15) << to_string(v);
  EXPECT_NEAR(predict(m, c, Variant::seed).dt_C, 3e6 / m.get(Param::V_C1_fp64).value, 1e-15);
  const auto has = [](const std::vector<Param>& r, Param p) { return std::find(r.begin(), r.end(), p) != r.end(); };
  EXPECT_TRUE(has(required_params(c, Variant::latency, Pricing{.mls = true}), Param::V_CM));
  EXPECT_FALSE(has(required_params(c, Variant::seed, Pricing{.mls = true}), Param::V_CM));
  // A profile without V_CM (made before the probe) prices them at the CPU rate, as it was fitted.
  EXPECT_FALSE(needs(c, Variant::latency, Param::V_CM));
  auto before = m;
  before.erase(Param::V_CM);
  EXPECT_NEAR(predict(before, c, Variant::latency).dt_C, 3e6 / m.get(Param::V_C1_fp64).value, 1e-15);
  // Several threads: V_CM_all where the profile has it, else V_CM; the rest at the all-thread rate.
  c.cpu_threads = 4;
  const double rest_all = 1e6 / cpu_rate(m, Precision::fp64, 4);
  EXPECT_NEAR(predict(m, c, Variant::latency).dt_C, 1e-3 + rest_all, 1e-15);
  m.set(Param::V_CM_all, Parameter{8e9, Provenance::probed, {}, {}, {}});
  EXPECT_NEAR(predict(m, c, Variant::latency).dt_C, 0.25e-3 + rest_all, 1e-15);
  EXPECT_TRUE(has(priced_params(m, c, Variant::latency), Param::V_CM_all));
  EXPECT_FALSE(has(priced_params(m, c, Variant::latency), Param::V_CM));
  // V_CM_all alone (a cpu-par calibration carries no V_CM) prices them on several threads; on one
  // thread such a profile has no rate of theirs and prices them at the CPU rate.
  auto all_only = m;
  all_only.erase(Param::V_CM);
  EXPECT_NEAR(predict(all_only, c, Variant::latency).dt_C, 0.25e-3 + rest_all, 1e-15);
  EXPECT_TRUE(has(priced_params(all_only, c, Variant::latency), Param::V_CM_all));
  auto one = c;
  one.cpu_threads = 1;
  EXPECT_NEAR(predict(all_only, one, Variant::latency).dt_C, 3e6 / m.get(Param::V_C1_fp64).value, 1e-15);
  // Only fields: no CPU rate needed.
  c.N_C = c.N_CM;
  auto fields_only = m;
  fields_only.erase(Param::V_C1_fp64);
  fields_only.erase(Param::V_C_fp64);
  EXPECT_NEAR(predict(fields_only, c, Variant::latency).dt_C, 0.25e-3, 1e-15);
  // Not more than N_C together with the other kinds.
  c.N_CS = 1;
  EXPECT_THROW(predict(m, c, Variant::latency), InputError);
}

TEST(Predict, AcrossRowGpuFlopsCostKGrTimesTheOthersInTheLatencyVariants) {
  const auto m = test::round_profile();  // K_GR = 2, V_G_fp32 = 50 TFLOP/s
  CostCounts c;
  c.N_G = 100'000'000;  // 2 us
  c.N_GR = 25'000'000;  // of which 0.5 us across rows: 1 us at K_GR = 2
  EXPECT_NEAR(predict(m, c, Variant::seed).dt_G, 2e-6, 1e-18);  // eq. 3.9 as the seed wrote it
  for (Variant v : {Variant::latency, Variant::memory, Variant::extended})
    EXPECT_NEAR(predict(m, c, v).dt_G, 2.5e-6, 1e-18) << to_string(v);
  // Extended overlaps the priced arithmetic with device traffic: 2.5 us against 4 MB at 4 TB/s.
  c.N_GG = 1'000'000;
  EXPECT_NEAR(predict(m, c, Variant::extended).total, 2.5e-6, 1e-18);
  EXPECT_TRUE(needs(c, Variant::latency, Param::K_GR));
  EXPECT_FALSE(needs(c, Variant::seed, Param::K_GR));
  CostCounts plain = c;
  plain.N_GR = 0;
  EXPECT_FALSE(needs(plain, Variant::latency, Param::K_GR));
  auto without = m;
  without.erase(Param::K_GR);
  EXPECT_NO_THROW(predict(without, plain, Variant::latency));
  EXPECT_THROW(predict(without, c, Variant::latency), MissingParameter);
  c.N_GR = c.N_G + 1;
  EXPECT_THROW(predict(m, c, Variant::seed), InputError);
}

TEST(Predict, AlongRowGpuFlopsCostKGwTimesTheOthersWhereTheProfileHasKGw) {
  auto m = test::round_profile();  // K_GR = 2, V_G_fp32 = 50 TFLOP/s, no K_GW
  CostCounts c;
  c.N_G = 100'000'000;  // 2 us
  c.N_GR = 25'000'000;  // 0.5 us across rows: 1 us at K_GR = 2
  c.N_GW = 50'000'000;  // 1 us along a row: 8 us at K_GW = 8
  // A profile made before the probe measured K_GW prices them at the GPU's rate, as it was fitted.
  EXPECT_NEAR(predict(m, c, Variant::latency).dt_G, 2.5e-6, 1e-18);
  EXPECT_FALSE(needs(c, Variant::latency, Param::K_GW));
  m.set(Param::K_GW, {8.0});
  EXPECT_NEAR(predict(m, c, Variant::seed).dt_G, 2e-6, 1e-18);  // the seed's eq. 3.9 as written
  for (Variant v : {Variant::latency, Variant::memory, Variant::extended})
    EXPECT_NEAR(predict(m, c, v).dt_G, 9.5e-6, 1e-18) << to_string(v);
  const auto latency = required_params(c, Variant::latency, Pricing::of(m)),
             seed = required_params(c, Variant::seed, Pricing::of(m));
  EXPECT_NE(std::find(latency.begin(), latency.end(), Param::K_GW), latency.end());
  EXPECT_EQ(std::find(seed.begin(), seed.end(), Param::K_GW), seed.end());
  // Across rows and along one together are at most N_G.
  c.N_GW = c.N_G - c.N_GR + 1;
  EXPECT_THROW(predict(m, c, Variant::latency), InputError);
}

TEST(Predict, HostTimedLapsPayARoundTripInTheirComponent) {
  const auto m = test::round_profile();  // L_wait = 20 us, L_CG_pinned = 10 us, L_launch = 3 us
  CostCounts c;
  c.host_memory = HostMemory::pinned;
  c.transfers_CG = 3;  // 30 us
  c.laps_CG = 2;       // 40 us more, in the copies' component
  c.launches = 2;      // 6 us
  c.laps_G = 1;        // 20 us, in the kernels'
  c.transfers_GC = 1;  // 12 us
  c.laps_GC = 1;       // 20 us
  for (Variant v : {Variant::latency, Variant::memory, Variant::extended}) {
    const Prediction p = predict(m, c, v);
    EXPECT_NEAR(p.lat_lap_CG, 40e-6, 1e-18);
    EXPECT_NEAR(phase_seconds(p, Phase::CG), 70e-6, 1e-18) << to_string(v);
    EXPECT_NEAR(phase_seconds(p, Phase::G), 26e-6, 1e-18) << to_string(v);
    EXPECT_NEAR(phase_seconds(p, Phase::GC), 32e-6, 1e-18) << to_string(v);
    EXPECT_NEAR(p.lat_wait, 0, 0);  // none outside the components
    EXPECT_NEAR(p.total, 128e-6, 1e-18) << to_string(v);
  }
  EXPECT_NEAR(predict(m, c, Variant::seed).total, 0, 0);  // the seed's model has no latencies
  EXPECT_TRUE(needs(c, Variant::latency, Param::L_wait));
  EXPECT_FALSE(needs(c, Variant::seed, Param::L_wait));
}

TEST(Predict, TheGpuL2ServesTheShareOfKernelTrafficItsWorkingSetLeavesIn) {
  auto m = test::round_profile();
  m.set(Param::B_GG, {2e12});
  m.set(Param::B_L2, {8e12});
  m.identity.gpu_l2_bytes = 50'000'000;
  CostCounts c;
  c.P = 4;
  c.N_GG = 1'000'000;           // 4 MB through the kernels
  c.gpu_footprint = 10'000'000;  // a fifth of the L2: 0.2 of the bytes at B_GG, 0.8 at B_L2
  const double mixed = 4e6 * (0.2 / 2e12 + 0.8 / 8e12), device = 4e6 / 2e12;
  for (Variant v : {Variant::latency, Variant::memory, Variant::extended})
    EXPECT_NEAR(predict(m, c, v).dt_GG, mixed, 1e-18) << to_string(v);
  EXPECT_NEAR(predict(m, c, Variant::seed).dt_GG, device, 1e-18);  // eq. 3.7 as the seed wrote it
  // A working set the L2 cannot hold, one not counted, an L2 of unknown size, a profile without B_L2.
  CostCounts big = c;
  big.gpu_footprint = 50'000'000;
  EXPECT_NEAR(predict(m, big, Variant::latency).dt_GG, device, 1e-18);
  CostCounts uncounted = c;
  uncounted.gpu_footprint = 0;
  EXPECT_NEAR(predict(m, uncounted, Variant::latency).dt_GG, device, 1e-18);
  auto unknown = m;
  unknown.identity.gpu_l2_bytes = 0;
  EXPECT_NEAR(predict(unknown, c, Variant::latency).dt_GG, device, 1e-18);
  auto without = m;
  without.erase(Param::B_L2);
  EXPECT_NEAR(predict(without, c, Variant::latency).dt_GG, device, 1e-18);
  // A fit that is to find B_L2 asks for it where the working set fits.
  auto r = required_params(c, Variant::latency, Pricing{.gpu_l2_bytes = 50'000'000});
  EXPECT_NE(std::find(r.begin(), r.end(), Param::B_L2), r.end());
  r = required_params(big, Variant::latency, Pricing{.gpu_l2_bytes = 50'000'000});
  EXPECT_EQ(std::find(r.begin(), r.end(), Param::B_L2), r.end());
}

TEST(Predict, KernelsOfAGraphCostLGraphWhereTheProfileHasIt) {
  auto m = test::round_profile();
  m.set(Param::L_launch, {4e-6});
  m.set(Param::L_graph, {1e-6});
  CostCounts c;
  c.launches = 10;
  c.graph_launches = 6;
  const Prediction p = predict(m, c, Variant::latency);
  EXPECT_NEAR(p.lat_launch, 4 * 4e-6, 1e-18);
  EXPECT_NEAR(p.lat_graph, 6 * 1e-6, 1e-18);
  EXPECT_NEAR(p.total, 4 * 4e-6 + 6e-6, 1e-18);
  // Every launch a graph's: no L_launch needed.
  CostCounts all = c;
  all.graph_launches = 10;
  auto no_launch = m;
  no_launch.erase(Param::L_launch);
  EXPECT_NEAR(predict(no_launch, all, Variant::latency).total, 10e-6, 1e-18);
  // A profile without L_graph prices every launch at L_launch, as before the count existed.
  auto without = m;
  without.erase(Param::L_graph);
  const Prediction q = predict(without, c, Variant::latency);
  EXPECT_NEAR(q.lat_launch, 10 * 4e-6, 1e-18);
  EXPECT_EQ(q.lat_graph, 0);
  EXPECT_EQ(predict(m, c, Variant::seed).total, 0);  // the seed has no launch costs
  // More graph kernels than launches is no computation.
  c.graph_launches = 11;
  EXPECT_THROW(predict(m, c, Variant::latency), InputError);
}

TEST(Predict, ThreadSyncsWavesAndHostWaitsAreFixedCostsOfTheLatencyVariants) {
  const auto m = test::round_profile();
  CostCounts c;
  c.P = 4;
  c.N_C = 6'000'000;  // 10 us on 8 threads (600 GFLOP/s)
  c.cpu_threads = 8;
  c.cpu_syncs = 3;    // 3 x 5 us
  c.N_G = 50'000'000; // 1 us
  c.launches = 2;     // 2 x 3 us
  c.waves = 4;        // 4 x 2 us
  c.host_waits = 1;   // 20 us, in the total only
  c.N_GS = 6'000'000; // 24 MB of tile fills at 8 TB/s: 3 us, added to the kernels' time
  c.atomics = 400;    // 400 x 5 ns one after another: 2 us, added to the kernels' time
  EXPECT_NEAR(predict(m, c, Variant::seed).total, 11e-6, 1e-15);  // the seed has none of them
  for (auto v : {Variant::latency, Variant::memory, Variant::extended}) {
    const auto p = predict(m, c, v);
    EXPECT_NEAR(p.lat_sync, 15e-6, 1e-15) << to_string(v);
    EXPECT_NEAR(p.dt_C, 25e-6, 1e-15) << to_string(v);  // syncs are CPU time
    EXPECT_NEAR(p.lat_wave, 8e-6, 1e-15) << to_string(v);
    EXPECT_NEAR(p.lat_wait, 20e-6, 1e-15) << to_string(v);
    EXPECT_NEAR(p.dt_GS, 3e-6, 1e-15) << to_string(v);
    EXPECT_NEAR(p.lat_atomic, 2e-6, 1e-15) << to_string(v);
    // Outside extended's max(dt_GG, dt_G): a block fills its tile before computing on it, and
    // the atomics queue after the blocks.
    EXPECT_NEAR(p.total, 25e-6 + 1e-6 + 6e-6 + 8e-6 + 20e-6 + 3e-6 + 2e-6, 1e-15) << to_string(v);
  }
  auto m2 = m;
  m2.erase(Param::L_sync);
  m2.erase(Param::L_wave);
  m2.erase(Param::L_wait);
  m2.erase(Param::B_GS);
  m2.erase(Param::L_atomic);
  try {
    predict(m2, c, Variant::latency);
    FAIL() << "expected MissingParameter";
  } catch (const MissingParameter& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("L_sync"), std::string::npos) << w;
    EXPECT_NE(w.find("L_wave"), std::string::npos) << w;
    EXPECT_NE(w.find("L_wait"), std::string::npos) << w;
    EXPECT_NE(w.find("B_GS"), std::string::npos) << w;
    EXPECT_NE(w.find("L_atomic"), std::string::npos) << w;
  }
}

// The grid matching's steps: at L_match, or at L_tree on a profile made before the cpu-match probe
// (which then names L_tree as what it needs, and says nothing of L_match).
TEST(Predict, MatchStepsAreAtLMatchOrOnAnOlderProfileAtLTree) {
  auto m = test::round_profile();
  m.set(Param::L_tree, {40e-9, Provenance::probed, {}, {}, ""});
  CostCounts c;
  c.P = 8;
  c.precision = Precision::fp64;
  c.N_C = 1'000'000;
  c.match_steps = 10'000;
  const double arith = 1e6 / m.get(Param::V_C1_fp64).value;
  EXPECT_EQ(predict(m, c, Variant::seed).lat_match, 0);
  const auto older = predict(m, c, Variant::latency);
  EXPECT_NEAR(older.lat_match, 10'000 * 40e-9, 1e-15);
  EXPECT_NEAR(older.dt_C, arith + 4e-4, 1e-15);
  auto needs = required_params(c, Variant::latency, Pricing::of(m));
  EXPECT_EQ(std::count(needs.begin(), needs.end(), Param::L_tree), 1);
  EXPECT_EQ(std::count(needs.begin(), needs.end(), Param::L_match), 0);
  m.set(Param::L_match, {12e-9, Provenance::probed, {}, {}, ""});
  EXPECT_NEAR(predict(m, c, Variant::latency).lat_match, 10'000 * 12e-9, 1e-15);
  needs = required_params(c, Variant::latency, Pricing::of(m));
  EXPECT_EQ(std::count(needs.begin(), needs.end(), Param::L_match), 1);
  EXPECT_EQ(std::count(needs.begin(), needs.end(), Param::L_tree), 0);
}

// The host's pass over component records: at L_record in the latency variants, in the CPU phase; not
// priced (and not needed) on a profile made before the cpu-records probe.
TEST(Predict, RecordStepsAreAtLRecordOrNotPricedOnAnOlderProfile) {
  auto m = test::round_profile();
  CostCounts c;
  c.P = 8;
  c.precision = Precision::fp64;
  c.N_C = 1'000'000;
  c.record_steps = 6'000;
  const double arith = 1e6 / m.get(Param::V_C1_fp64).value;
  const auto older = predict(m, c, Variant::latency);
  EXPECT_EQ(older.lat_record, 0);
  EXPECT_NEAR(older.dt_C, arith, 1e-15);
  auto needs = required_params(c, Variant::latency, Pricing::of(m));
  EXPECT_EQ(std::count(needs.begin(), needs.end(), Param::L_record), 0);
  m.set(Param::L_record, {4e-9, Provenance::probed, {}, {}, ""});
  EXPECT_EQ(predict(m, c, Variant::seed).lat_record, 0);
  const auto p = predict(m, c, Variant::latency);
  EXPECT_NEAR(p.lat_record, 6'000 * 4e-9, 1e-15);
  EXPECT_NEAR(p.dt_C, arith + 6'000 * 4e-9, 1e-15);
  EXPECT_NEAR(p.total, predict(m, c, Variant::latency).dt_C, 1e-15);
  needs = required_params(c, Variant::latency, Pricing::of(m));
  EXPECT_EQ(std::count(needs.begin(), needs.end(), Param::L_record), 1);
}

TEST(Predict, PixelAndTreeStepsAreFixedCostsOfTheCpuPhaseInTheLatencyVariants) {
  auto m = test::round_profile();
  m.set(Param::L_pixel, {1.5e-9, Provenance::fitted, {}, {}, ""});
  m.set(Param::L_tree, {40e-9, Provenance::fitted, {}, {}, ""});
  CostCounts c;
  c.P = 8;
  c.precision = Precision::fp64;
  c.N_C = 1'000'000;
  c.pixel_steps = 2'000'000;  // 2e6 x 1.5 ns = 3 ms
  c.tree_steps = 50'000;      // 5e4 x 40 ns = 2 ms
  const double arith = 1e6 / m.get(Param::V_C1_fp64).value;
  // The seed has neither: its CPU time is its FLOPs.
  const auto seed = predict(m, c, Variant::seed);
  EXPECT_EQ(seed.lat_pixel, 0);
  EXPECT_NEAR(seed.total, arith, 1e-15);
  const auto seed_needs = required_params(c, Variant::seed);
  EXPECT_EQ(std::count(seed_needs.begin(), seed_needs.end(), Param::L_pixel), 0);
  const auto latency_needs = required_params(c, Variant::latency);
  EXPECT_EQ(std::count(latency_needs.begin(), latency_needs.end(), Param::L_pixel), 1);
  for (auto v : {Variant::latency, Variant::memory, Variant::extended}) {
    const auto p = predict(m, c, v);
    EXPECT_NEAR(p.lat_pixel, 3e-3, 1e-15) << to_string(v);
    EXPECT_NEAR(p.lat_tree, 2e-3, 1e-15) << to_string(v);
    // CPU time, added (not overlapped, not even in extended) to the arithmetic.
    EXPECT_NEAR(p.dt_C, arith + 5e-3, 1e-15) << to_string(v);
    EXPECT_NEAR(p.total, arith + 5e-3, 1e-15) << to_string(v);
  }
  // Fitted, not probed: a profile without it names it and sends the user to the calibration.
  auto without = m;
  without.erase(Param::L_pixel);
  try {
    predict(without, c, Variant::latency);
    FAIL() << "expected MissingParameter";
  } catch (const MissingParameter& e) {
    EXPECT_NE(std::string(e.what()).find("L_pixel"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(predict(without, c, Variant::seed));
  // Counts without pixel steps need no L_pixel.
  c.pixel_steps = 0;
  EXPECT_NO_THROW(predict(without, c, Variant::memory));
}

TEST(Predict, PageableMemoryUsesPageableFigures) {
  const auto m = test::round_profile();
  auto c = sample_counts();
  c.host_memory = HostMemory::pageable;
  const auto p = predict(m, c, Variant::latency);
  EXPECT_DOUBLE_EQ(p.dt_CG, 4e6 / 10e9);
  EXPECT_DOUBLE_EQ(p.dt_GC, 2e6 / 8e9);
  EXPECT_DOUBLE_EQ(p.lat_CG, 3 * 20e-6);
  EXPECT_DOUBLE_EQ(p.lat_GC, 2 * 25e-6);
}

TEST(Predict, PageableDeviceToHostCopiesAreStagedByTheirSize) {
  auto m = test::round_profile();
  auto c = sample_counts();  // 2 MB device->host in 2 copies
  c.host_memory = HostMemory::pageable;
  c.copies_GC = {{1'500'000, 1}, {500'000, 1}};
  // No staging figures in the profile: every byte at B_GC_pageable, as before.
  auto plain_profile = m;
  plain_profile.erase(Param::S_GC_flat);
  EXPECT_DOUBLE_EQ(predict(plain_profile, c, Variant::latency).dt_GC, 2e6 / 8e9);
  // The round profile's: 5 GB/s for the first 400 kB, 200 kB free after them.
  // 1.5 MB: its first 400 kB at 5 GB/s (80 us), the next 200 kB free, the last 900 kB at 8 GB/s
  // (112.5 us). 500 kB: 80 us, and nothing past the flat stretch.
  EXPECT_DOUBLE_EQ(staged_copy_seconds(m, 1'500'000), 80e-6 + 112.5e-6);
  EXPECT_DOUBLE_EQ(staged_copy_seconds(m, 500'000), 80e-6);
  EXPECT_DOUBLE_EQ(staged_copy_seconds(m, 100'000), 20e-6);
  for (auto v : {Variant::latency, Variant::memory, Variant::extended}) {
    const auto p = predict(m, c, v);
    EXPECT_NEAR(p.dt_GC, 272.5e-6, 1e-15) << to_string(v);
    EXPECT_DOUBLE_EQ(p.lat_GC, 2 * 25e-6) << to_string(v);  // the latency per copy stays
  }
  EXPECT_DOUBLE_EQ(predict(m, c, Variant::seed).dt_GC, 2e6 / 8e9);  // the seed's eq. 3.6
  auto pinned = c;
  pinned.host_memory = HostMemory::pinned;  // no staging: the DMA reaches host memory directly
  EXPECT_DOUBLE_EQ(predict(m, pinned, Variant::latency).dt_GC, 2e6 / 40e9);
  auto unsized = c;
  unsized.copies_GC.clear();
  EXPECT_DOUBLE_EQ(predict(m, unsized, Variant::latency).dt_GC, 2e6 / 8e9);
  // The sizes must add up to the counts.
  auto wrong = c;
  wrong.copies_GC = {{1'500'000, 2}};
  EXPECT_THROW(predict(m, wrong, Variant::latency), InputError);
  // A fit is to find the staging figures wherever sized pageable copies are.
  EXPECT_TRUE(needs(c, Variant::latency, Param::S_GC_flat, true));
  EXPECT_FALSE(needs(c, Variant::latency, Param::S_GC_flat, false));
}

TEST(Predict, CpuRateScalesWithThreadsAndCaps) {
  const auto m = test::round_profile();  // 8 hardware threads, 100 GFLOP/s each, 600 all
  EXPECT_DOUBLE_EQ(cpu_rate(m, Precision::fp32, 1), 100e9);
  EXPECT_DOUBLE_EQ(cpu_rate(m, Precision::fp32, 4), 400e9);
  EXPECT_DOUBLE_EQ(cpu_rate(m, Precision::fp32, 7), 600e9);  // capped
  EXPECT_DOUBLE_EQ(cpu_rate(m, Precision::fp32, 8), 600e9);
  EXPECT_DOUBLE_EQ(cpu_rate(m, Precision::fp64, 1), 50e9);
  EXPECT_DOUBLE_EQ(host_bandwidth(m, 2), 40e9);
}

TEST(Predict, Fp64UsesFp64Rates) {
  const auto m = test::round_profile();
  CostCounts c;
  c.P = 8;
  c.precision = Precision::fp64;
  c.N_G = 25'000'000;
  c.N_C = 50'000'000;
  const auto p = predict(m, c, Variant::seed);
  EXPECT_DOUBLE_EQ(p.dt_G, 1e-6);
  EXPECT_DOUBLE_EQ(p.dt_C, 1e-3);
}

TEST(Predict, MissingParametersAreNamedAllAtOnce) {
  auto m = test::round_profile();
  m.erase(Param::V_G_fp32);
  m.erase(Param::B_GG);
  try {
    predict(m, sample_counts(), Variant::seed);
    FAIL() << "expected MissingParameter";
  } catch (const MissingParameter& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("V_G_fp32"), std::string::npos) << w;
    EXPECT_NE(w.find("B_GG"), std::string::npos) << w;
  }
  // A CPU-only computation needs no GPU figure.
  CostCounts cpu;
  cpu.N_C = 1000;
  EXPECT_NO_THROW(predict(m, cpu, Variant::extended));
}

TEST(Predict, SeedVariantNeedsNoLatencies) {
  auto m = test::round_profile();
  m.erase(Param::L_CG_pinned);
  m.erase(Param::L_launch);
  EXPECT_NO_THROW(predict(m, sample_counts(), Variant::seed));
  EXPECT_THROW(predict(m, sample_counts(), Variant::latency), MissingParameter);
}

TEST(Predict, DeadlineIsEquation3_1) {
  const auto m = test::round_profile();
  const auto p = predict(m, sample_counts(), Variant::seed);
  EXPECT_TRUE(meets_deadline(p, 144e-6 + 1e-12));
  EXPECT_TRUE(meets_deadline(p, p.total));
  EXPECT_FALSE(meets_deadline(p, 143e-6));
}

TEST(Predict, VariantNamesRoundTrip) {
  for (auto v : all_variants()) EXPECT_EQ(variant_from_string(to_string(v)), v);
  EXPECT_EQ(variant_names(), "seed, latency, memory or extended");
  EXPECT_FALSE(variant_from_string("magic").has_value());
}

TEST(CostCounts, ScaleAndAdd) {
  auto c = sample_counts();
  auto d = c.scaled(3);
  EXPECT_EQ(d.N_CG, 3'000'000);
  EXPECT_EQ(d.launches, 12);
  c.waves = 2;
  c.cpu_syncs = 5;
  c.host_waits = 7;
  c.copies_GC = {{1000, 2}, {24, 1}};
  c.N_C = 10;
  c.N_CW = 4;
  c.N_GR = 1;
  d = c.scaled(3);
  EXPECT_EQ(d.N_CW, 12);
  EXPECT_EQ(d.N_GR, 3);
  EXPECT_EQ(d.copies_GC, (std::vector<CopySize>{{1000, 6}, {24, 3}}));
  EXPECT_EQ(d.host_waits, 21);
  EXPECT_EQ(d.waves, 6);
  EXPECT_EQ(d.cpu_syncs, 15);
  EXPECT_EQ(d.P, 4);
  auto e = c;
  e += c;
  e += c;
  EXPECT_EQ(e, d);
}

}  // namespace
}  // namespace dtflop
