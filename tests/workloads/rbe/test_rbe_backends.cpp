// The CPU backends against the float64 reference (cpu-seq) and against a direct evaluation of
// eqs. 4.10-4.12; fresh random inputs each run; numerical safety; the registry.
#include <gtest/gtest.h>

#include <cmath>

#include "model/errors.hpp"
#include "tests/workloads/rbe/support.hpp"
#include "workloads/rbe/backend.hpp"
#include "workloads/rbe/likelihood.hpp"

namespace dtflop::rbe {
namespace {

using test::describe;
using test::fresh_seed;
using test::random_problem;
using test::RandomProblem;
using test::relative_l1;

// Eqs. 4.10-4.12 evaluated directly, cell by cell, for one step (independent of cpu-seq).
std::vector<double> direct_step(const Problem& p) {
  const std::int64_t nx = p.grid.nx(), ny = p.grid.ny(), Ix = p.kernel.Ix(), Iy = p.kernel.Iy();
  const std::int64_t cx = (Ix - 1) / 2, cy = (Iy - 1) / 2;
  std::vector<double> prior = p.prior, q(prior.size());
  double s = 0;
  for (std::size_t i = 0; i < prior.size(); ++i) {
    if (!p.mask.empty() && !p.mask[i]) prior[i] = 0;
    s += prior[i];
  }
  for (auto& v : prior) v /= s * p.grid.cell_area();
  double total = 0;
  for (std::int64_t y = 0; y < ny; ++y)
    for (std::int64_t x = 0; x < nx; ++x) {
      double acc = 0;
      for (std::int64_t b = 0; b < Iy; ++b)
        for (std::int64_t a = 0; a < Ix; ++a) {
          const std::int64_t sx = x - (a - cx), sy = y - (b - cy);
          if (sx >= 0 && sx < nx && sy >= 0 && sy < ny) acc += p.kernel.at(a, b) * prior[std::size_t(sy * nx + sx)];
        }
      const auto i = std::size_t(y * nx + x);
      const double l = (!p.mask.empty() && !p.mask[i]) ? 0 : p.likelihood[i];
      q[i] = l * acc;
      total += q[i];
    }
  for (auto& v : q) v /= total * p.grid.cell_area();
  return q;
}

TEST(RbeCpuSeq, OneStepEqualsEquations4_10To4_12) {
  const auto seed = fresh_seed();
  for (const RandomProblem r : {RandomProblem{17, 12, 5, 3, true, false}, RandomProblem{16, 21, 4, 6, false, true},
                                RandomProblem{9, 9, 9, 1, true, true}}) {
    SCOPED_TRACE(describe(r, seed));
    const Problem p = random_problem(r, seed);
    auto b = make_backend("cpu-seq");
    b->init(p);
    b->run(1);
    EXPECT_LT(relative_l1(b->belief(), direct_step(p)), 1e-13);
  }
}

TEST(RbeCpuSeq, SeparableAndFullPredictionAgreeOnASeparableKernel) {
  const auto seed = fresh_seed();
  const RandomProblem r{23, 18, 7, 5};
  SCOPED_TRACE(describe(r, seed));
  const Problem p = random_problem(r, seed);
  BackendOptions full;
  full.prediction = Convolution::full;
  auto a = make_backend("cpu-seq"), b = make_backend("cpu-seq", full);
  a->init(p);
  b->init(p);
  a->run(3);
  b->run(3);
  EXPECT_LT(relative_l1(a->belief(), b->belief()), 1e-13);
}

// cpu-par (float32) against cpu-seq (float64): odd and even sizes, kernels 1..201, grids not
// a multiple of any block, masks, separable and full kernels; poisoned buffers.
TEST(RbeCpuPar, MatchesCpuSeqWithin1e5) {
  const auto seed = fresh_seed();
  std::vector<RandomProblem> cases = {
      {1, 1, 1, 1},     {2, 3, 1, 2},      {37, 29, 5, 3},     {64, 64, 33, 33},  {100, 75, 1, 17},
      {33, 65, 32, 2},  {211, 205, 201, 201}, {203, 64, 201, 9}, {50, 41, 16, 8, true, true},
      {31, 27, 7, 5, false, false}, {40, 33, 12, 9, false, true}, {129, 130, 65, 64, true, true}};
  for (const auto& r : cases) {
    SCOPED_TRACE(describe(r, seed));
    const Problem p = random_problem(r, seed);
    BackendOptions o;
    o.poison = true;
    auto ref = make_backend("cpu-seq");
    auto par = make_backend("cpu-par", o);
    ref->init(p);
    par->init(p);
    const auto rr = ref->run(3);
    const auto rp = par->run(3);
    const auto b = par->belief();
    EXPECT_EQ(test::count_nan(b), 0u);
    EXPECT_LT(relative_l1(b, ref->belief()), 1e-5);
    EXPECT_NEAR(test::mass(b, p.grid), 1.0, 1e-6);
    ASSERT_EQ(rp.sums.size(), 3u);
    for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(rp.sums[k] / rr.sums[k], 1.0, 1e-5);
    if (!p.mask.empty()) {
      for (std::size_t i = 0; i < b.size(); ++i)
        if (!p.mask[i]) {
          ASSERT_EQ(b[i], 0.0) << "belief outside the target space at cell " << i;
        }
    }
  }
}

TEST(RbeCpuPar, ThreadCountDoesNotChangeTheResult) {
  const auto seed = fresh_seed();
  const Problem p = random_problem({70, 61, 9, 11}, seed);
  BackendOptions one, two, five;
  one.threads = 1;
  two.threads = 2;
  five.threads = 5;  // more threads than this machine may have: the pieces go round unevenly
  auto a = make_backend("cpu-par", one), b = make_backend("cpu-par", two), c = make_backend("cpu-par", five);
  a->init(p);
  b->init(p);
  c->init(p);
  a->run(4);
  b->run(4);
  c->run(4);
  EXPECT_LT(relative_l1(a->belief(), b->belief()), 1e-6);
  EXPECT_LT(relative_l1(a->belief(), c->belief()), 1e-6);
  EXPECT_EQ(a->step_counts(p.shape(), one).cpu_threads, 1);
  EXPECT_EQ(b->step_counts(p.shape(), two).cpu_threads, 2);
}

TEST(RbeBackends, StepWithNewLikelihoodsAndTimings) {
  const auto seed = fresh_seed();
  const Problem p = random_problem({30, 20, 5, 5, true, true}, seed);
  for (const char* name : {"cpu-seq", "cpu-par"}) {
    SCOPED_TRACE(name);
    auto b = make_backend(name);
    b->init(p);
    const auto l = likelihood(p.grid, NegativeObservation{p.grid.centre(10, 10), 0.8, 1.0});
    const StepTimes t = b->step(l);
    EXPECT_GT(t.total, 0);
    EXPECT_GT(t.part(StepPart::predict), 0);
    EXPECT_LE(t.part(StepPart::predict), t.total);
    const auto r = b->run(5);
    EXPECT_EQ(r.samples.size(), 5u);
    EXPECT_GT(r.median().total, 0);
    EXPECT_GT(r.wall_seconds, 0);
    const auto comps = r.components();
    EXPECT_NE(std::find(comps.begin(), comps.end(), StepPart::correct), comps.end());
    EXPECT_THROW(b->step(std::vector<double>(3, 1.0)), InputError);  // wrong size
    EXPECT_THROW(b->run(0), InputError);
  }
}

// Long runs of negative observations (1 - P_d, P_d up to 0.999 right where the belief is) must
// neither underflow to all zeros nor produce NaN: the belief moves away and stays normalized.
TEST(RbeNumerics, LongRunsOfNegativeObservationsStayNormalized) {
  const Problem p = test::negative_observation_problem();
  const Grid& g = p.grid;
  for (const char* name : {"cpu-seq", "cpu-par"}) {
    SCOPED_TRACE(name);
    auto b = make_backend(name);
    b->init(p);
    const double centre_before = b->belief()[std::size_t(g.index(24, 24))];
    const auto r = b->run(3000);
    const auto belief = b->belief();
    EXPECT_EQ(test::count_nan(belief), 0u);
    EXPECT_NEAR(test::mass(belief, g), 1.0, 1e-5);
    // The mass has left the sensor's footprint: the centre holds far less than at the start.
    EXPECT_LT(belief[std::size_t(g.index(24, 24))], 1e-2 * centre_before);
    for (double s : r.sums) ASSERT_TRUE(s > 0 && std::isfinite(s));
  }
}

// A correction whose sum is zero is an error with a clear message, never a silent NaN; the
// backend refuses to go on until init() again.
TEST(RbeNumerics, ZeroSumCorrectionIsReportedAsAnError) {
  const Grid g = Grid::unit(20, 20);
  Problem p;
  p.grid = g;
  p.kernel = MotionKernel::separable({1.0}, {1.0});  // the belief does not move
  p.prior.assign(400, 0);
  p.prior[std::size_t(g.index(3, 3))] = 1;
  p.likelihood.assign(400, 1);
  std::vector<double> blind(400, 1.0);
  blind[std::size_t(g.index(3, 3))] = 0;  // zero exactly where the belief lives
  for (const char* name : {"cpu-seq", "cpu-par"}) {
    SCOPED_TRACE(name);
    auto b = make_backend(name);
    b->init(p);
    b->run(2);
    try {
      b->step(blind);
      FAIL() << "expected a NumericalError";
    } catch (const NumericalError& e) {
      EXPECT_EQ(e.step(), 2);
      EXPECT_NE(std::string(e.what()).find("sum of likelihood x predicted belief is zero"), std::string::npos)
          << e.what();
    }
    EXPECT_THROW(b->belief(), NumericalError);
    EXPECT_THROW(b->run(1), NumericalError);
    b->init(p);  // recovers
    EXPECT_NO_THROW(b->run(1));
  }
}

TEST(RbeProblem, InvalidProblemsAreRejectedWithAMessage) {
  Problem p = random_problem({10, 10, 3, 3}, 1);
  auto b = make_backend("cpu-par");
  auto expect_message = [&](const Problem& bad, const char* text) {
    try {
      b->init(bad);
      ADD_FAILURE() << "expected InputError containing '" << text << "'";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
    }
  };
  Problem q = p;
  q.prior.pop_back();
  expect_message(q, "prior has 99 values");
  q = p;
  q.likelihood[5] = -1;
  expect_message(q, "likelihood value 5");
  q = p;
  q.prior.assign(100, 0);
  expect_message(q, "no probability mass");
  q = p;
  q.mask.assign(100, 0);
  expect_message(q, "inside the target-space mask");
  q = p;
  q.kernel = MotionKernel::separable(std::vector<double>(11, 1.0), {1.0});
  expect_message(q, "larger than the grid");
  EXPECT_THROW(b->belief(), InputError);  // nothing loaded
}

TEST(RbeRegistry, ListsEveryBackendAndRejectsUnknownNames) {
  std::vector<std::string> names;
  for (const auto& b : backends()) names.push_back(b.name);
  EXPECT_EQ(names, (std::vector<std::string>{"cpu-par", "cpu-seq", "cuda-bands", "cuda-resident", "cuda-seed"}));
  try {
    make_backend("cuda-fast");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cpu-par, cpu-seq, cuda-bands, cuda-resident, cuda-seed"), std::string::npos);
  }
  // CUDA backends can be made (and counted) without a device; init() needs one.
  auto r = make_backend("cuda-resident");
  EXPECT_TRUE(r->needs_gpu());
  EXPECT_GT(r->step_counts({100, 100, 5, 5}, {}).N_G, 0);
  if (!cuda_unavailable_reason().empty()) {
    EXPECT_THROW(r->init(random_problem({10, 10, 3, 3}, 1)), DeviceUnavailable);
  }
}

TEST(RbeRegistry, SeparableOnlyBackendsRejectFullKernels) {
  const Problem p = random_problem({20, 20, 3, 3, false}, 3);
  auto r = make_backend("cuda-resident");
  if (cuda_unavailable_reason().empty()) {
    try {
      r->init(p);
      FAIL();
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("separable"), std::string::npos);
    }
  }
  BackendOptions sep;
  sep.prediction = Convolution::separable;
  EXPECT_THROW(make_backend("cpu-seq", sep)->init(p), InputError);
}

}  // namespace
}  // namespace dtflop::rbe
