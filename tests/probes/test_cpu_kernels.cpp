#include <atomic>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "probes/cpu_kernels.hpp"
#include "probes/team.hpp"

namespace dtflop::probes {
namespace {

// The ISAs this CPU can run: generic always, and the best one (and AVX2 below AVX-512).
std::vector<cpu::Isa> runnable() {
  std::vector<cpu::Isa> v = {cpu::Isa::generic};
  const cpu::Isa best = cpu::best_isa();
  if (best == cpu::Isa::avx512) v.push_back(cpu::Isa::avx2);
  if (best != cpu::Isa::generic) v.push_back(best);
  return v;
}

template <typename T>
void check_chains_against_float64(cpu::Isa isa) {
  constexpr bool fp64 = sizeof(T) == 8;
  const int n = cpu::fma_chain_count(isa, fp64);
  ASSERT_GE(n, 8);
  std::vector<T> acc(static_cast<std::size_t>(n));
  std::vector<double> ref(acc.size());
  for (int j = 0; j < n; ++j) acc[static_cast<std::size_t>(j)] = static_cast<T>(0.01 * j - 0.3);
  for (std::size_t j = 0; j < acc.size(); ++j) ref[j] = static_cast<double>(acc[j]);
  // Contracting recurrence: x -> 0.75 x + 0.5 has the fixed point 2.
  const T a = static_cast<T>(0.75), b = static_cast<T>(0.5);
  const std::int64_t steps = 37;
  cpu::fma_chains(isa, steps, a, b, acc.data());
  for (std::size_t j = 0; j < acc.size(); ++j) {
    for (std::int64_t i = 0; i < steps; ++i) ref[j] = ref[j] * 0.75 + 0.5;
    EXPECT_NEAR(static_cast<double>(acc[j]), ref[j], fp64 ? 1e-13 : 1e-6)
        << "chain " << j << " of " << cpu::to_string(isa);
  }
}

TEST(CpuKernels, FmaChainsComputeTheRecurrence) {
  for (cpu::Isa isa : runnable()) {
    check_chains_against_float64<float>(isa);
    check_chains_against_float64<double>(isa);
  }
}

TEST(CpuKernels, ProbeValuesAlternateExactly) {
  // The probe's check: with a = -1, b = 3 every chain alternates between x0 and 3 - x0.
  for (cpu::Isa isa : runnable()) {
    for (std::int64_t steps : {std::int64_t{0}, std::int64_t{1}, std::int64_t{1000}, std::int64_t{1001}}) {
      std::vector<float> acc(static_cast<std::size_t>(cpu::fma_chain_count(isa, false)));
      for (std::size_t j = 0; j < acc.size(); ++j) acc[j] = static_cast<float>(j);
      cpu::fma_chains(isa, steps, -1.0f, 3.0f, acc.data());
      for (std::size_t j = 0; j < acc.size(); ++j)
        ASSERT_EQ(acc[j], steps % 2 ? 3.0f - static_cast<float>(j) : static_cast<float>(j));
    }
  }
}

TEST(CpuKernels, LanesAndChainsAreConsistent) {
  EXPECT_EQ(cpu::lanes(cpu::Isa::avx2, false), 8);
  EXPECT_EQ(cpu::lanes(cpu::Isa::avx2, true), 4);
  EXPECT_EQ(cpu::lanes(cpu::Isa::avx512, false), 16);
  EXPECT_EQ(cpu::lanes(cpu::Isa::generic, true), 2);
  for (cpu::Isa isa : {cpu::Isa::generic, cpu::Isa::avx2, cpu::Isa::avx512})
    for (bool fp64 : {false, true})
      EXPECT_EQ(cpu::fma_chain_count(isa, fp64), 12 * cpu::lanes(isa, fp64));
  EXPECT_FALSE(cpu::has_fma(cpu::Isa::generic));
  EXPECT_TRUE(cpu::has_fma(cpu::Isa::avx2));
}

TEST(CpuKernels, UnsupportedIsaIsRefused) {
  if (cpu::best_isa() == cpu::Isa::avx512) GTEST_SKIP() << "this CPU runs every ISA";
  float acc[192] = {};
  EXPECT_THROW(cpu::fma_chains(cpu::Isa::avx512, 1, 1.0f, 1.0f, acc), std::invalid_argument);
}

TEST(CpuKernels, StreamKernelsHandleAnyLength) {
  for (cpu::Isa isa : runnable()) {
    for (std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{7}, std::size_t{1029}}) {
      std::vector<double> a(n + 1, -1.0), b(n), c(n);
      for (std::size_t i = 0; i < n; ++i) {
        b[i] = 0.5 * static_cast<double>(i);
        c[i] = static_cast<double>(i % 13) - 6;
      }
      cpu::stream_copy(isa, a.data(), b.data(), n);
      for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(a[i], b[i]);
      cpu::stream_triad(isa, a.data(), b.data(), c.data(), 3.0, n);
      for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(a[i], b[i] + 3.0 * c[i]);
      EXPECT_EQ(a[n], -1.0) << "wrote past the end";
    }
  }
}

TEST(CpuKernels, StreamSumAddsEveryElementOnce) {
  for (cpu::Isa isa : runnable()) {
    for (std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{15}, std::size_t{16}, std::size_t{1029}}) {
      std::vector<double> b(n + 1);
      double want = 0;
      for (std::size_t i = 0; i < n; ++i) want += (b[i] = static_cast<double>(i % 97));
      b[n] = 1e6;  // past the end: must not be read
      EXPECT_EQ(cpu::stream_sum(isa, b.data(), n), want) << cpu::to_string(isa) << " n " << n;
    }
  }
}

// Both window kernels against the correlation written out in float64, on values whose every
// partial sum is exact, for rows of one group and of several.
TEST(CpuKernels, WindowKernelsComputeTheCorrelation) {
  for (std::int64_t taps : {1, 5, 33}) {
    for (int groups : {1, 3}) {
      const std::int64_t nc = groups * cpu::kWindowChainedGroup, nw = groups * cpu::kWindowWideGroup;
      std::vector<double> in64(static_cast<std::size_t>(nw + taps - 1)), k64(static_cast<std::size_t>(taps));
      for (std::size_t i = 0; i < in64.size(); ++i) in64[i] = static_cast<double>((i * 5 + 1) % 13) - 6;
      for (std::size_t a = 0; a < k64.size(); ++a) k64[a] = static_cast<double>(a % 4) + 1;
      std::vector<float> in32(in64.begin(), in64.end()), k32(k64.begin(), k64.end());
      auto expect = [&](std::int64_t x, bool reversed) {
        double s = 0;
        for (std::int64_t a = 0; a < taps; ++a)
          s += k64[static_cast<std::size_t>(a)] * in64[static_cast<std::size_t>(reversed ? x + taps - 1 - a : x + a)];
        return s;
      };
      std::vector<double> out64(static_cast<std::size_t>(nc), -1e300);
      EXPECT_EQ(cpu::window_chained(in64.data(), k64.data(), taps, nc, out64.data()), 2.0 * nc * taps);
      for (std::int64_t x = 0; x < nc; ++x) EXPECT_EQ(out64[static_cast<std::size_t>(x)], expect(x, true)) << x;
      std::vector<float> out32(static_cast<std::size_t>(nw), -1e30f);
      EXPECT_EQ(cpu::window_wide(in32.data(), k32.data(), taps, nw, out32.data()), 2.0 * nw * taps);
      for (std::int64_t x = 0; x < nw; ++x) EXPECT_EQ(out32[static_cast<std::size_t>(x)], expect(x, false)) << x;
    }
  }
}

TEST(Team, RunsEveryWorkerAtOnceAndReportsErrors) {
  Team team(3);
  EXPECT_EQ(team.size(), 3);
  std::atomic<int> mask{0};
  std::atomic<int> arrived{0};
  const double t = team.run([&](int w) {
    mask |= 1 << w;
    // Every worker must be running at the same time: wait for the others.
    ++arrived;
    while (arrived.load() < 3) {
    }
  });
  EXPECT_EQ(mask.load(), 0b111);
  EXPECT_GT(t, 0.0);
  EXPECT_THROW(team.run([](int w) {
                 if (w == 2) throw std::runtime_error("worker 2 failed");
               }),
               std::runtime_error);
  // Still usable after an error.
  mask = 0;
  team.run([&](int w) { mask |= 1 << w; });
  EXPECT_EQ(mask.load(), 0b111);
  EXPECT_THROW(Team(0), std::invalid_argument);
}

TEST(Team, UsableCpusIsPositive) { EXPECT_GE(usable_cpus(), 1); }

}  // namespace
}  // namespace dtflop::probes
