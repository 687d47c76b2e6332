// Backend::summarize: the estimate and the footprint sums a control reads, computed where the
// belief lives, against the float64 reference of the same belief (estimate(), footprint_sums());
// the reference footprint against a closed form; the counts against formulas written out by hand
// (summary_counts.hpp). Compiled twice: CPU backends (label unit) and, with DTFLOP_SUMMARY_GPU,
// the CUDA backends (label gpu; skipped without a device).
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "model/errors.hpp"
#include "tests/support/gpu.hpp"
#include "workloads/rbe/backend.hpp"
#include "workloads/rbe/estimate.hpp"
#include "workloads/rbe/fusion_counts.hpp"
#include "workloads/rbe/summary_counts.hpp"

namespace dtflop::rbe {
namespace {

// A belief on one cell: each footprint sum is that cell's probability times peak exp(-d^2 / (2
// s^2)), written out here; a point whose window misses the cell, or lies off the grid, sums 0.
TEST(RbeSummary, FootprintOfOneCellIsTheGaussianAtItsDistance) {
  const Grid g(-2, 3, -1, 1, 50, 20);  // cells 0.1 x 0.1
  std::vector<double> b(std::size_t(g.cells()), 0.0);
  b[std::size_t(g.index(20, 10))] = 1 / g.cell_area();  // centre (0.05, 0.05), p = 1
  const Footprint f{0.9, 0.2, 0.8};
  const std::vector<Point> at = {{0.05, 0.05}, {0.35, -0.25}, {0.9, 0.05}, {10, 10}, {0.85, 0.05}};
  const std::vector<double> got = footprint_sums(g, b, f, at);
  ASSERT_EQ(got.size(), at.size());
  EXPECT_NEAR(got[0], 0.9, 1e-15);
  EXPECT_NEAR(got[1], 0.9 * std::exp(-(0.09 + 0.09) / 0.08), 1e-15);
  EXPECT_EQ(got[2], 0.0);  // 0.85 away: outside the square of half-side 0.8
  EXPECT_EQ(got[3], 0.0);  // off the grid
  EXPECT_NEAR(got[4], 0.9 * std::exp(-0.64 / 0.08), 1e-15);  // its window's last cell
}

TEST(RbeSummary, WindowsAreClippedToTheGrid) {
  const Grid g = Grid::unit(10, 8);
  const Footprint f{1, 1, 2};
  EXPECT_EQ(footprint_window(g, f, {5, 4}).cells(), 5 * 5);  // cells 3..7 x 2..6
  EXPECT_EQ(footprint_window(g, f, {0.5, 0.5}).cells(), 3 * 3);
  EXPECT_EQ(footprint_window(g, f, {-5, 4}).cells(), 0);
  const std::vector<Point> at = {{5, 4}, {0.5, 0.5}, {-5, 4}};
  const WindowCells w = window_cells(g, f, at);
  EXPECT_EQ(w.total, 34);
  EXPECT_EQ(w.largest, 25);
}

TEST(RbeSummary, BadFootprintsAndPointsAreRefused) {
  const Grid g = Grid::unit(4, 3);
  const std::vector<double> b(12, 1.0);
  const std::vector<Point> ok = {{1, 1}};
  EXPECT_THROW(footprint_sums(g, b, {1, 0, 1}, ok), InputError);
  EXPECT_THROW(footprint_sums(g, b, {1, 1, -1}, ok), InputError);
  EXPECT_THROW(footprint_sums(g, b, {std::nan(""), 1, 1}, ok), InputError);
  const std::vector<Point> bad = {{std::nan(""), 1}};
  EXPECT_THROW(footprint_sums(g, b, {1, 1, 1}, bad), InputError);
  EXPECT_THROW(footprint_sums(g, std::vector<double>(11, 1.0), {1, 1, 1}, ok), InputError);
}

// Counts written out by hand (summary_counts.hpp) on a 10 x 8 unit grid, points whose windows
// hold 25 and 9 cells.
TEST(RbeSummary, CountsFollowTheFormulas) {
  const Grid g = Grid::unit(10, 8);
  const Footprint f{1, 1, 2};
  const std::vector<Point> at = {{5, 4}, {0.5, 0.5}};
  const std::int64_t n = 80, W = 34;
  CostCounts seq = host_summary_counts(g, f, at, BeliefCopy::in_place);
  EXPECT_EQ(seq.N_C, n * 46 + 8 + W * 32);
  EXPECT_EQ(seq.N_CC, 2 * n + W);
  EXPECT_EQ(seq.P, 8);
  EXPECT_EQ(seq.precision, Precision::fp64);
  CostCounts par = host_summary_counts(g, f, at, BeliefCopy::float32_scaled);
  EXPECT_EQ(par.N_C, n + n * 46 + 8 + W * 32);
  EXPECT_EQ(par.N_CC, n + 40 + 2 * n + W);
  EXPECT_EQ(host_summary_counts(g, f, at, BeliefCopy::float32).N_C, seq.N_C);

  CostCounts dev = cuda_resident_summary_counts(g, f, at, 4);
  // One block of 2048 cells for the moments; one per point for the footprints.
  EXPECT_EQ(dev.N_G, n * 32 + W * 27);
  EXPECT_EQ(dev.N_GG, 2 * (9 + 2) + n + 16 + 4 + W + 2 * 2);
  EXPECT_EQ(dev.atomics, 8 + 2);
  EXPECT_EQ(dev.launches, 2);
  EXPECT_EQ(dev.waves, 1 + 1);
  EXPECT_EQ(dev.N_CG, 16);
  EXPECT_EQ(dev.transfers_CG, 1);
  EXPECT_EQ(dev.N_GC, 22);
  EXPECT_EQ(dev.transfers_GC, 1);
  ASSERT_EQ(dev.copies_GC.size(), 1u);
  EXPECT_EQ(dev.copies_GC[0].bytes, 88);
  EXPECT_EQ(dev.host_waits, 1);
  EXPECT_EQ(dev.N_C, 35 + 1 + 2);
  EXPECT_EQ(dev.precision, Precision::fp64);
  // A large grid: B blocks of 2048 cells on S multiprocessors; no points: one kernel.
  const Grid big = Grid::unit(1000, 700);
  const CostCounts d2 = cuda_resident_summary_counts(big, f, {}, 132);
  const std::int64_t B = (700000 + 2047) / 2048;
  EXPECT_EQ(B, fusion_blocks(700000));
  EXPECT_EQ(d2.launches, 1);
  EXPECT_EQ(d2.waves, (B + 131) / 132);
  EXPECT_EQ(d2.atomics, 8 * B);
  EXPECT_EQ(d2.N_CG, 0);
  EXPECT_THROW(cuda_resident_summary_counts(g, f, at, 0), InputError);
}

// A problem with structure: a Gaussian prior off the grid's centre on a grid of non-square
// cells, a likelihood that is zero over part of the grid (zero cells), `steps` steps.
Problem summary_problem(std::int64_t nx, std::int64_t ny) {
  Problem p;
  p.grid = Grid(-3, 15, -4, 4, nx, ny);
  p.kernel = make_kernel(GaussianMotion{0.05, 0.02, 0.03, 0.02, 0}, p.grid, 7, 5);
  p.prior.resize(std::size_t(p.grid.cells()));
  p.likelihood.resize(p.prior.size());
  for (std::int64_t iy = 0; iy < ny; ++iy)
    for (std::int64_t ix = 0; ix < nx; ++ix) {
      const Point c = p.grid.centre(ix, iy);
      const double dx = (c.x - 2.0) / 0.6, dy = (c.y - 1.0) / 0.4;
      const std::size_t i = std::size_t(p.grid.index(ix, iy));
      p.prior[i] = std::exp(-0.5 * (dx * dx + dy * dy)) + 1e-3;
      p.likelihood[i] = c.x < 1.5 ? 0.0 : 1 - 0.9 * std::exp(-((c.x - 2.3) * (c.x - 2.3) + c.y * c.y) / 0.08);
    }
  return p;
}

std::vector<std::string> backends_here() {
#ifdef DTFLOP_SUMMARY_GPU
  return {"cuda-seed", "cuda-resident"};
#else
  return {"cpu-seq", "cpu-par"};
#endif
}

void expect_summary_matches(Backend& b, const Grid& g, const Footprint& f, const std::vector<Point>& at) {
  const std::vector<double> belief = b.belief();
  const Estimate want = estimate(g, belief);
  const std::vector<double> want_f = footprint_sums(g, belief, f, at);
  const Summary got = b.summarize(f, at);
  // The same float values summed in float64 in another order: ~1e-16 n relative at worst.
  const double extent = std::hypot(g.x_max() - g.x_min(), g.y_max() - g.y_min());
  EXPECT_NEAR(got.estimate.mean_x, want.mean_x, 1e-10 * extent);
  EXPECT_NEAR(got.estimate.mean_y, want.mean_y, 1e-10 * extent);
  const double var = want.cov_xx + want.cov_yy;
  EXPECT_NEAR(got.estimate.cov_xx, want.cov_xx, 1e-8 * var);
  EXPECT_NEAR(got.estimate.cov_xy, want.cov_xy, 1e-8 * var);
  EXPECT_NEAR(got.estimate.cov_yy, want.cov_yy, 1e-8 * var);
  EXPECT_NEAR(got.estimate.entropy, want.entropy, 1e-9 * (1 + std::abs(want.entropy)));
  EXPECT_NEAR(got.estimate.mass, want.mass, 1e-10);
  EXPECT_EQ(got.estimate.map_ix, want.map_ix);
  EXPECT_EQ(got.estimate.map_iy, want.map_iy);
  EXPECT_DOUBLE_EQ(got.estimate.map_x, want.map_x);
  EXPECT_DOUBLE_EQ(got.estimate.map_y, want.map_y);
  ASSERT_EQ(got.footprints.size(), at.size());
  double largest = 0;
  for (double v : want_f) largest = std::max(largest, v);
  for (std::size_t j = 0; j < at.size(); ++j)
    EXPECT_NEAR(got.footprints[j], want_f[j], 1e-10 * largest + 1e-300) << "point " << j;
}

class BackendSummary : public ::testing::TestWithParam<std::string> {};

TEST_P(BackendSummary, MatchesTheFloat64ReferenceOfItsOwnBelief) {
#ifdef DTFLOP_SUMMARY_GPU
  DTFLOP_REQUIRE_GPU();
#endif
  // 180 x 80: one block's worth of cells a few times over; 1000 x 700: hundreds of blocks, and
  // windows of thousands of cells.
  for (const auto& [nx, ny] : {std::pair<std::int64_t, std::int64_t>{180, 80}, {1000, 700}}) {
    SCOPED_TRACE(std::to_string(nx) + "x" + std::to_string(ny));
    auto b = make_backend(GetParam());
    const Problem p = summary_problem(nx, ny);
    b->init(p);
    const Footprint f{0.95, 0.2, 0.8};
    // Inside, on an edge, off the grid, and the MAP's neighbourhood.
    const std::vector<Point> at = {{2.0, 1.0}, {2.4, 0.1}, {-3.0, 0.0}, {14.9, 3.9}, {-10, -10}, {2.2, 0.9}};
    expect_summary_matches(*b, p.grid, f, at);  // the prior
    (void)b->run(3);
    expect_summary_matches(*b, p.grid, f, at);  // after steps with zero cells
    // After a fusion with a shifted copy of its own belief.
    std::vector<float> other = b->wire_belief();
    for (std::int64_t iy = ny - 1; iy >= 0; --iy)
      for (std::int64_t ix = nx - 1; ix >= 1; --ix) other[std::size_t(iy * nx + ix)] = other[std::size_t(iy * nx + ix - 1)];
    const std::vector<std::span<const float>> others = {other};
    b->fuse(FusionRule::product, others, 0);
    expect_summary_matches(*b, p.grid, f, at);
    expect_summary_matches(*b, p.grid, f, {});  // no points: the estimate only
  }
}

// A flat belief: every cell ties for the MAP, which is the first cell (0, 0), as estimate() has
// it; the entropy is ln n_g and the mean the grid's centre.
TEST_P(BackendSummary, TiesGoToTheFirstCellAndAFlatBeliefHasEntropyLnN) {
#ifdef DTFLOP_SUMMARY_GPU
  DTFLOP_REQUIRE_GPU();
#endif
  auto b = make_backend(GetParam());
  Problem p;
  p.grid = Grid(0, 6, 0, 4, 300, 200);
  p.kernel = MotionKernel::separable({1.0}, {1.0});
  p.prior.assign(std::size_t(p.grid.cells()), 2.0);
  p.likelihood.assign(p.prior.size(), 1.0);
  b->init(p);
  const Summary s = b->summarize({1, 0.1, 0.4}, {});
  EXPECT_EQ(s.estimate.map_ix, 0);
  EXPECT_EQ(s.estimate.map_iy, 0);
  EXPECT_NEAR(s.estimate.entropy, std::log(60000.0), 1e-9);
  EXPECT_NEAR(s.estimate.mean_x, 3.0, 1e-9);
  EXPECT_NEAR(s.estimate.mean_y, 2.0, 1e-9);
  EXPECT_NEAR(s.estimate.cov_xx, (6.0 * 6.0 - 0.02 * 0.02) / 12, 1e-9);  // a discrete uniform
  EXPECT_NEAR(s.estimate.mass, 1.0, 1e-6);  // a float32 belief's normalization
  EXPECT_THROW(b->summarize({1, -1, 1}, {}), InputError);
}

INSTANTIATE_TEST_SUITE_P(Here, BackendSummary, ::testing::ValuesIn(backends_here()),
                         [](const auto& info) {
                           std::string s = info.param;
                           for (char& c : s)
                             if (c == '-') c = '_';
                           return s;
                         });

}  // namespace
}  // namespace dtflop::rbe
