// cuda-bands on a device: G = 1..4 partitions on one GPU (the same-device transport: the band,
// halo and overlap code of the NCCL one) against cuda-resident (the same kernel on the whole
// grid) and the float64 reference, on odd sizes, bands of unequal height, masks and poisoned
// buffers (a halo row not exchanged shows up as NaN); the NCCL transport where two or more GPUs
// are visible. Skipped without a GPU.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "cuda/device.hpp"
#include "model/errors.hpp"
#include "tests/support/gpu.hpp"
#include "tests/workloads/rbe/support.hpp"
#include "workloads/rbe/backend.hpp"
#include "workloads/rbe/band_counts.hpp"

namespace dtflop::rbe {
namespace {

using test::describe;
using test::fresh_seed;
using test::random_problem;
using test::RandomProblem;
using test::relative_l1;

// Problems whose bands are at least as high as the kernel reaches for G <= 4, many of them with
// rows that do not divide by G (bands of unequal height).
const std::vector<RandomProblem>& cases() {
  static const std::vector<RandomProblem> c = {
      {37, 29, 5, 3},    {64, 64, 33, 33},  {100, 75, 1, 17},         {33, 65, 32, 2},
      {50, 41, 16, 8, true, true},          {300, 257, 33, 33, true, true},
      {1001, 999, 9, 100}, {130, 131, 7, 4}, {4, 12, 3, 1}};
  return c;
}

void expect_bands_match(const BackendOptions& o, const RandomProblem& r, std::uint64_t seed, int steps = 3) {
  SCOPED_TRACE(fmt::format("cuda-bands {} partitions on {} GPUs, layout {}: {}", o.partitions, o.gpus,
                           to_string(o.layout), describe(r, seed)));
  const Problem p = random_problem(r, seed);
  auto ref = make_backend("cpu-seq");
  BackendOptions ro;
  ro.layout = o.layout;
  ro.graph = false;
  auto resident = make_backend("cuda-resident", ro);
  auto bands = make_backend("cuda-bands", o);
  try {
    bands->init(p);
  } catch (const InputError& e) {
    // A kernel too tall for the layout's fused tile: cuda-bands refuses the split passes.
    if (std::string(e.what()).find("split passes") != std::string::npos) return;
    throw;
  }
  ref->init(p);
  resident->init(p);
  EXPECT_EQ(bands->options().partitions, o.partitions);
  const auto rr = ref->run(steps), rs = resident->run(steps), rb = bands->run(steps);
  const auto b = bands->belief();
  EXPECT_EQ(test::count_nan(b), 0u);
  // The same kernel and tiles over the same rows: equal to cuda-resident but for the order in
  // which the float64 sum adds the blocks' shares and, with several bands, the lagged
  // normalization (each step's output scaled by another factor: its float32 roundings differ).
  EXPECT_LT(relative_l1(b, resident->belief()), 1e-6);
  EXPECT_LT(relative_l1(b, ref->belief()), 1e-5);
  EXPECT_NEAR(test::mass(b, p.grid), 1.0, 1e-5);
  ASSERT_EQ(rb.sums.size(), std::size_t(steps));
  for (int k = 0; k < steps; ++k) {
    EXPECT_NEAR(rb.sums[std::size_t(k)] / rs.sums[std::size_t(k)], 1.0, 1e-6);
    EXPECT_NEAR(rb.sums[std::size_t(k)] / rr.sums[std::size_t(k)], 1.0, 1e-5);
  }
  if (!p.mask.empty()) {
    for (std::size_t i = 0; i < b.size(); ++i) {
      if (!p.mask[i]) {
        ASSERT_EQ(b[i], 0.0) << "belief outside the target space at cell " << i;
      }
    }
  }
  // A step with a new likelihood, on both.
  std::vector<double> l2(p.likelihood.rbegin(), p.likelihood.rend());
  (void)resident->step(l2);
  (void)bands->step(l2);
  EXPECT_LT(relative_l1(bands->belief(), resident->belief()), 1e-6);
}

TEST(RbeCudaBands, PartitionsOnOneGpuMatchCudaResidentAndTheReference) {
  DTFLOP_REQUIRE_GPU();
  const auto seed = fresh_seed();
  for (const char* layout : {"32x8x16", "32x8x4"})
    for (int G : {1, 2, 3, 4}) {
      BackendOptions o;
      o.partitions = G;
      o.gpus = 1;
      o.layout = parse_layout(layout);
      o.poison = true;
      for (const auto& r : cases()) expect_bands_match(o, r, seed);
    }
}

TEST(RbeCudaBands, RunsAcrossSegments) {
  DTFLOP_REQUIRE_GPU();
  const auto seed = fresh_seed();
  const RandomProblem r{61, 47, 9, 9};
  const Problem p = random_problem(r, seed);
  SCOPED_TRACE(describe(r, seed));
  BackendOptions ro;
  ro.graph = false;
  auto resident = make_backend("cuda-resident", ro);
  BackendOptions o;
  o.partitions = 3;
  o.gpus = 1;
  auto bands = make_backend("cuda-bands", o);
  resident->init(p);
  bands->init(p);
  const std::int64_t steps = kBandSegment + 3;  // two segments, the second of 3 steps
  const auto rs = resident->run(steps), rb = bands->run(steps);
  ASSERT_EQ(rb.sums.size(), std::size_t(steps));
  for (std::int64_t k = 0; k < steps; k += 97) EXPECT_NEAR(rb.sums[std::size_t(k)] / rs.sums[std::size_t(k)], 1.0, 1e-5);
  EXPECT_NEAR(rb.sums.back() / rs.sums.back(), 1.0, 1e-5);
  EXPECT_LT(relative_l1(bands->belief(), resident->belief()), 1e-4);
  EXPECT_GT(rb.median().total, 0.0);
}

TEST(RbeCudaBands, RefusesABandLowerThanTheKernelReaches) {
  DTFLOP_REQUIRE_GPU();
  BackendOptions o;
  o.partitions = 3;
  o.gpus = 1;
  auto bands = make_backend("cuda-bands", o);
  // 60 rows in three bands of 20; the 49-row kernel reaches 24 rows past a cell. (A kernel taller
  // than the grid is refused before the bands are planned.)
  const Problem p = random_problem({64, 60, 9, 49}, 7);
  try {
    bands->init(p);
    FAIL() << "bands lower than the kernel's reach were accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("partitions"), std::string::npos) << e.what();
  }
  EXPECT_THROW((void)bands->belief(), InputError);  // nothing loaded
}

TEST(RbeCudaBands, RefusesMoreGpusThanVisible) {
  DTFLOP_REQUIRE_GPU();
  const int n = cuda::device_count();
  if (n + 1 > kMaxPartitions) GTEST_SKIP() << "more GPUs than cuda-bands takes";
  BackendOptions o;
  o.partitions = n + 1;
  o.gpus = n + 1;
  auto bands = make_backend("cuda-bands", o);
  EXPECT_THROW(bands->init(random_problem({64, 640, 3, 3}, 1)), InputError);
}

TEST(RbeCudaBands, NcclOnePartitionPerGpuMatchesCudaResident) {
  DTFLOP_REQUIRE_GPU();
  const int n = cuda::device_count();
  if (n < 2) GTEST_SKIP() << "the NCCL transport needs two GPUs; this process sees " << n;
  const auto seed = fresh_seed();
  for (int G = 2; G <= std::min(n, 4); ++G) {
    BackendOptions o;
    o.partitions = G;
    o.gpus = G;
    o.poison = true;
    try {  // 40 steps: the lagged normalization's scales well away from cuda-resident's
      for (const auto& r : cases()) expect_bands_match(o, r, seed, 40);
    } catch (const InputError& e) {
      if (std::string(e.what()).find("without NCCL") != std::string::npos) GTEST_SKIP() << e.what();
      throw;
    }
  }
}

}  // namespace
}  // namespace dtflop::rbe
