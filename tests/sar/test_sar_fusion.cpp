// Belief fusion on each RBE backend (Backend::wire_belief, Backend::fuse): against the float64
// reference fusions of the wire beliefs (rbe::fuse_beliefs, sar::loglinear_pool, written apart from
// the backends), every platform of a team computing the same fused belief, the fused belief
// stepping on like a prior, a failed fusion keeping the belief, and the exact counts against
// formulas written out by hand. Built twice: test_sar_fusion (CPU backends) and
// test_sar_fusion_gpu (DTFLOP_FUSION_GPU: cuda-seed and cuda-resident, label gpu; skipped without
// a device).
#include <algorithm>
#include <cmath>
#include <span>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "model/errors.hpp"
#include "sar/fusion.hpp"
#include "tests/support/gpu.hpp"
#include "workloads/rbe/backend.hpp"
#include "workloads/rbe/fusion_counts.hpp"
#include "workloads/rbe/likelihood.hpp"

namespace dtflop::rbe {
namespace {

struct Case {
  std::string backend;
  int threads = 0;
};

std::vector<Case> cases() {
#ifdef DTFLOP_FUSION_GPU
  return {{"cuda-seed"}, {"cuda-resident"}};
#else
  return {{"cpu-seq"}, {"cpu-par", 1}, {"cpu-par", 2}, {"cpu-par", 3}};
#endif
}

std::string label(const Case& c) { return c.backend + (c.threads ? " x" + std::to_string(c.threads) : ""); }

// A backend that has run a few steps of a synthetic problem (seed: which one).
std::unique_ptr<Backend> platform(const Case& c, const Shape& shape, std::uint64_t seed) {
  BackendOptions o;
  o.threads = c.threads;
  auto b = make_backend(c.backend, o);
  b->init(synthetic_problem(shape, seed));
  (void)b->run(3);
  return b;
}

double max_abs(const std::vector<double>& v) {
  double m = 0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

// max |a - b| / max |b|.
double rel_diff(const std::vector<double>& a, const std::vector<double>& b) {
  EXPECT_EQ(a.size(), b.size());
  double d = 0;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) d = std::max(d, std::abs(a[i] - b[i]));
  return d / max_abs(b);
}

std::vector<double> widen(const std::vector<float>& w) { return {w.begin(), w.end()}; }

class Fusion : public ::testing::Test {
 protected:
  void SetUp() override {
#ifdef DTFLOP_FUSION_GPU
    DTFLOP_REQUIRE_GPU();
#endif
  }
};

// A grid whose rows are not a multiple of anything the backends block by (cuda-resident pads rows).
const Shape kShape{53, 37, 5, 3};

TEST_F(Fusion, WireBeliefIsTheBeliefInFloat32) {
  for (const Case& c : cases()) {
    auto b = platform(c, kShape, 1);
    const auto w = b->wire_belief();
    ASSERT_EQ(w.size(), std::size_t(kShape.cells())) << label(c);
    EXPECT_LT(rel_diff(widen(w), b->belief()), 1e-6) << label(c);
    const Grid g = synthetic_problem(kShape, 1).grid;
    double integral = 0;
    for (float v : w) integral += v;
    EXPECT_NEAR(integral * g.cell_area(), 1.0, 1e-5) << label(c);
  }
}

TEST_F(Fusion, EachRuleMatchesTheFloat64ReferenceAtEveryPosition) {
  const Grid g = synthetic_problem(kShape, 1).grid;
  for (const Case& c : cases())
    for (FusionRule rule : {FusionRule::product, FusionRule::loglinear})
      for (std::size_t position : {std::size_t{0}, std::size_t{1}, std::size_t{2}}) {
        auto own = platform(c, kShape, 10);
        // The others' wire beliefs (from cpu-seq, as another platform would send them).
        std::vector<std::vector<float>> wires;
        for (std::uint64_t seed : {11u, 12u}) wires.push_back(platform({"cpu-seq"}, kShape, seed)->wire_belief());
        const std::vector<float> mine = own->wire_belief();
        // The reference: float64 fusion of the three wire beliefs in team order.
        std::vector<std::vector<double>> all = {widen(wires[0]), widen(wires[1])};
        all.insert(all.begin() + std::ptrdiff_t(position), widen(mine));
        const auto expected = rule == FusionRule::product ? fuse_beliefs(g, all) : sar::loglinear_pool(g, all);
        const std::vector<std::span<const float>> others(wires.begin(), wires.end());
        own->fuse(rule, others, position);
        const auto got = own->belief();
        EXPECT_LT(rel_diff(got, expected), 2e-6)
            << label(c) << " " << to_string(rule) << " at position " << position;
      }
}

TEST_F(Fusion, EveryPlatformOfATeamHoldsTheSameFusedBelief) {
  for (const Case& c : cases())
    for (FusionRule rule : {FusionRule::product, FusionRule::loglinear}) {
      std::vector<std::unique_ptr<Backend>> team;
      for (std::uint64_t seed : {21u, 22u, 23u}) team.push_back(platform(c, kShape, seed));
      std::vector<std::vector<float>> wires;
      for (auto& p : team) wires.push_back(p->wire_belief());
      for (std::size_t r = 0; r < team.size(); ++r) {
        std::vector<std::span<const float>> others;
        for (std::size_t p = 0; p < wires.size(); ++p)
          if (p != r) others.emplace_back(wires[p]);
        team[r]->fuse(rule, others, r);
      }
      const auto b0 = team[0]->belief();
      // Same values in the same order: the same products (the sums may be added in another
      // order on a GPU, so a few ulps of the normalization).
      EXPECT_LT(rel_diff(team[1]->belief(), b0), 1e-12) << label(c) << " " << to_string(rule);
      EXPECT_LT(rel_diff(team[2]->belief(), b0), 1e-12) << label(c) << " " << to_string(rule);
    }
}

TEST_F(Fusion, AFusedBeliefStepsOnLikeAPrior) {
  // After a fusion the backend's next step must equal a step from the fused belief as a prior
  // (checks the fused normalization every backend keeps its own way).
  for (const Case& c : cases()) {
    auto own = platform(c, kShape, 31);
    const auto other = platform({"cpu-seq"}, kShape, 32)->wire_belief();
    const std::vector<std::span<const float>> others = {other};
    own->fuse(FusionRule::product, others, 1);
    Problem p = synthetic_problem(kShape, 31);
    p.prior = own->belief();
    auto ref = make_backend("cpu-seq");
    ref->init(p);
    (void)own->step(p.likelihood);
    (void)ref->step(p.likelihood);
    EXPECT_LT(rel_diff(own->belief(), ref->belief()), 1e-5) << label(c);
  }
}

TEST_F(Fusion, BeliefsThatDoNotOverlapAreRefusedAndTheBeliefKept) {
  for (const Case& c : cases())
    for (FusionRule rule : {FusionRule::product, FusionRule::loglinear}) {
      auto own = platform(c, kShape, 41);
      const auto before = own->belief();
      const std::vector<float> nothing(std::size_t(kShape.cells()), 0.0f);
      const std::vector<std::span<const float>> others = {nothing};
      EXPECT_THROW(own->fuse(rule, others, 0), NumericalError) << label(c);
      EXPECT_LT(rel_diff(own->belief(), before), 1e-12) << label(c);
      (void)own->step(synthetic_problem(kShape, 41).likelihood);  // still usable
    }
}

TEST_F(Fusion, BadSizesAndPositionsAreInputErrors) {
  for (const Case& c : cases()) {
    auto own = platform(c, kShape, 51);
    const std::vector<float> small(10, 1.0f), fine(std::size_t(kShape.cells()), 1.0f);
    EXPECT_THROW(own->fuse(FusionRule::product, std::vector<std::span<const float>>{small}, 0), InputError);
    EXPECT_THROW(own->fuse(FusionRule::product, std::vector<std::span<const float>>{}, 0), InputError);
    EXPECT_THROW(own->fuse(FusionRule::product, std::vector<std::span<const float>>{fine}, 2), InputError);
  }
}

#ifndef DTFLOP_FUSION_GPU
// The counts, written out by hand for n = 1000 cells and m = 3 platforms (k = 2 others); a log or
// an exp is 13 FLOPs. Product: 3 FLOPs a cell; log-linear: 3 x 13 + 2 + 1 + 13 + 1 = 56.
TEST(FusionCounts, EachBackendsCountsMatchTheFormulas) {
  const std::int64_t n = 1000;
  EXPECT_EQ(fusion_flops_per_cell(FusionRule::product, 3), 3);
  EXPECT_EQ(fusion_flops_per_cell(FusionRule::loglinear, 3), 56);

  CostCounts c = cpu_seq_fusion_counts(n, FusionRule::product, 3);
  EXPECT_EQ(c.N_C, 3000 + 1 + 1000);
  EXPECT_EQ(c.N_CC, 4000 + 1000);  // 2 x 1000 float32 values = 1000 float64 values
  EXPECT_EQ(c.P, 8);
  EXPECT_EQ(c.cpu_syncs, 0);
  EXPECT_EQ(cpu_seq_fusion_counts(n, FusionRule::loglinear, 3).N_C, 56000 + 1 + 1 + 1000);
  EXPECT_EQ(cpu_seq_wire_counts(n).N_CC, 1500);

  c = cpu_par_fusion_counts(n, FusionRule::product, 3, 2);
  EXPECT_EQ(c.N_C, 3000 + 1000 + 2);
  EXPECT_EQ(c.N_CC, 4000);
  EXPECT_EQ(c.P, 4);
  EXPECT_EQ(c.cpu_syncs, 1);
  EXPECT_EQ(cpu_par_fusion_counts(n, FusionRule::product, 3, 1).cpu_syncs, 0);
  EXPECT_EQ(cpu_par_fusion_counts(n, FusionRule::loglinear, 3, 2).N_C, 56000 + 1000 + 1 + 2);
  EXPECT_EQ(cpu_par_wire_counts(n, 2).N_C, 1000);

  // CUDA: 1000 cells fit one block of 256 x 8; on 132 multiprocessors, one wave.
  c = cuda_resident_fusion_counts(n, FusionRule::product, 3, 132);
  EXPECT_EQ(c.N_G, 3000 + 1000 + 2 * 256);
  EXPECT_EQ(c.N_GG, 4000 + 2 + 2 + 2 + 4);
  EXPECT_EQ(c.N_CG, 2000);
  EXPECT_EQ(c.transfers_CG, 2);
  EXPECT_EQ(c.N_GC, 2);
  EXPECT_EQ(c.transfers_GC, 1);
  EXPECT_EQ(c.launches, 1);
  EXPECT_EQ(c.waves, 1);
  EXPECT_EQ(c.atomics, 1);
  EXPECT_EQ(c.host_waits, 1);
  EXPECT_EQ(c.N_C, 0);
  EXPECT_EQ(cuda_resident_fusion_counts(n, FusionRule::loglinear, 3, 132).N_C, 1);
  // 4000 x 4000 cells: 7813 blocks, 60 waves on 132 multiprocessors.
  c = cuda_resident_fusion_counts(16000000, FusionRule::product, 3, 132);
  EXPECT_EQ(c.atomics, 7813);
  EXPECT_EQ(c.waves, 60);
  EXPECT_EQ(c.N_GG, 4 * 16000000LL + 2 + 2 * 7813 + 2 * 7813 + 4);

  c = cuda_resident_wire_counts(n, 132);
  EXPECT_EQ(c.N_G, 1000 + 2 * 256);
  EXPECT_EQ(c.N_GC, 1000);
  EXPECT_EQ(c.copies_GC, (std::vector<CopySize>{{4000, 1}}));
  EXPECT_EQ(c.launches, 1);

  c = cuda_seed_fusion_counts(n, FusionRule::product, 3, 132);
  EXPECT_EQ(c.N_CG, 3000);
  EXPECT_EQ(c.transfers_CG, 3);
  EXPECT_EQ(c.N_G, 3000 + 1000);
  EXPECT_EQ(c.N_GG, 4000 + 2 + 2 + 2000);
  EXPECT_EQ(c.N_GC, 2 + 1000);
  EXPECT_EQ(c.transfers_GC, 2);
  EXPECT_EQ(c.launches, 2);
  EXPECT_EQ(c.waves, 2);
  EXPECT_EQ(c.host_waits, 2);
  EXPECT_EQ(c.N_C, 2);
  EXPECT_NO_THROW(check_consistent(c));
  EXPECT_EQ(cuda_seed_wire_counts(n).N_CC, 2000);

  EXPECT_THROW(cpu_par_fusion_counts(n, FusionRule::product, 1, 2), InputError);
  EXPECT_THROW(cuda_resident_fusion_counts(n, FusionRule::product, 3, 0), InputError);
  EXPECT_THROW(cpu_seq_fusion_counts(0, FusionRule::product, 3), InputError);
}

TEST(FusionCounts, TheBackendsDeclareTheirOwnCounts) {
  const Shape s{100, 10, 3, 3};
  BackendOptions o;
  o.threads = 2;
  o.gpu_sms = 132;
  EXPECT_EQ(make_backend("cpu-seq", o)->fusion_counts(s, FusionRule::product, 3, o),
            cpu_seq_fusion_counts(1000, FusionRule::product, 3));
  EXPECT_EQ(make_backend("cpu-par", o)->fusion_counts(s, FusionRule::loglinear, 4, o),
            cpu_par_fusion_counts(1000, FusionRule::loglinear, 4, 2));
  EXPECT_EQ(make_backend("cuda-resident", o)->fusion_counts(s, FusionRule::product, 3, o),
            cuda_resident_fusion_counts(1000, FusionRule::product, 3, 132));
  EXPECT_EQ(make_backend("cuda-seed", o)->wire_counts(s, o), cuda_seed_wire_counts(1000));
}
#endif

}  // namespace
}  // namespace dtflop::rbe
