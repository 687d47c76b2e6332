// The steps a team member takes (backend.hpp). A windowed likelihood: its expansion and product
// against grids written out here, and each backend's step with it against the same backend's step
// with the expanded grid, to the bit (cuda-resident sends only the window and resets the previous
// one on the device: a cell it fails to reset or to write shows up as a difference). A new kernel
// (Backend::set_kernel, a step of another length): the belief steps on as it would from init()
// with that kernel and the same belief. Compiled twice: CPU backends (label unit)
// and, with DTFLOP_WINDOWED_GPU, the CUDA backends (label gpu; skipped without a device).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "model/errors.hpp"
#include "tests/support/gpu.hpp"
#include "workloads/rbe/backend.hpp"

namespace dtflop::rbe {
namespace {

TEST(RbeWindowed, ExpandsToTheGridItDescribes) {
  const Grid g = Grid::unit(5, 4);
  WindowedLikelihood l;
  l.outside = 0.5;
  l.window = {1, 2, 2, 3};  // x 1..2, y 2..3
  l.values = {1, 2, 3, 4};
  const std::vector<double> want = {0.5, 0.5, 0.5, 0.5, 0.5,  //
                                    0.5, 0.5, 0.5, 0.5, 0.5,  //
                                    0.5, 1,   2,   0.5, 0.5,  //
                                    0.5, 3,   4,   0.5, 0.5};
  EXPECT_EQ(expand(l, g), want);
  EXPECT_EQ(l.at(2, 3), 4);
  EXPECT_EQ(l.at(0, 0), 0.5);
  WindowedLikelihood none;  // no window: the value everywhere
  none.outside = 0;
  EXPECT_EQ(expand(none, g), std::vector<double>(20, 0.0));
}

TEST(RbeWindowed, TheProductIsTheCellByCellProduct) {
  const Grid g = Grid::unit(6, 5);
  WindowedLikelihood a, b;
  a.outside = 1;
  a.window = {0, 1, 0, 1};
  a.values = {0.1, 0.2, 0.3, 0.4};
  b.outside = 0.5;
  b.window = {3, 5, 2, 4};
  b.values = std::vector<double>(9, 0.25);
  const WindowedLikelihood p = multiply(a, b, g);
  EXPECT_EQ(p.outside, 0.5);
  EXPECT_EQ(p.window.cells(), 30);  // the union box is the whole grid here
  const std::vector<double> ea = expand(a, g), eb = expand(b, g), ep = expand(p, g);
  for (std::size_t i = 0; i < ep.size(); ++i) EXPECT_EQ(ep[i], ea[i] * eb[i]) << i;
  WindowedLikelihood none;
  const WindowedLikelihood q = multiply(none, none, g);
  EXPECT_EQ(q.window.cells(), 0);
  EXPECT_EQ(q.outside, 1);
}

TEST(RbeWindowed, InvalidLikelihoodsAreRefused) {
  const Grid g = Grid::unit(4, 3);
  WindowedLikelihood l;
  l.window = {2, 4, 0, 0};  // x up to 4 on a grid of 4 columns
  l.values = {1, 1, 1};
  EXPECT_THROW(validate(l, g), InputError);
  l.window = {1, 3, 0, 0};
  l.values = {1, 1};
  EXPECT_THROW(validate(l, g), InputError);
  l.values = {1, -1, 1};
  EXPECT_THROW(validate(l, g), InputError);
  l.values = {1, 1, 1};
  l.outside = std::nan("");
  EXPECT_THROW(validate(l, g), InputError);
  l.outside = 1;
  EXPECT_NO_THROW(validate(l, g));
}

std::vector<std::string> backends_here() {
#ifdef DTFLOP_WINDOWED_GPU
  return {"cuda-seed", "cuda-resident"};
#else
  return {"cpu-seq", "cpu-par"};
#endif
}

// A likelihood of a sensor at (cx, cy): 1 - 0.9 exp(-d^2 / 8) on a window of half-side 4 cells
// (clipped to the grid), `outside` beyond; a detection: 0 beyond, a bump on the window.
WindowedLikelihood sensor(const Grid& g, double cx, double cy, bool hit) {
  WindowedLikelihood l;
  l.outside = hit ? 0 : 1;
  const auto clip = [](double v, std::int64_t n) { return std::min<std::int64_t>(n - 1, std::max<std::int64_t>(0, std::int64_t(std::floor(v)))); };
  l.window = {clip(cx - 4, g.nx()), clip(cx + 4, g.nx()), clip(cy - 4, g.ny()), clip(cy + 4, g.ny())};
  if (cx + 4 < 0 || cx - 4 >= double(g.nx()) || cy + 4 < 0 || cy - 4 >= double(g.ny())) l.window = {};
  for (std::int64_t iy = l.window.iy0; iy <= l.window.iy1 && l.window.cells() > 0; ++iy)
    for (std::int64_t ix = l.window.ix0; ix <= l.window.ix1; ++ix) {
      const double d2 = (ix + 0.5 - cx) * (ix + 0.5 - cx) + (iy + 0.5 - cy) * (iy + 0.5 - cy);
      l.values.push_back(hit ? 0.2 + std::exp(-d2 / 8) : 1 - 0.9 * std::exp(-d2 / 8));
    }
  return l;
}

class BackendWindowed : public ::testing::TestWithParam<std::string> {};

TEST_P(BackendWindowed, StepsAsWithTheExpandedLikelihoodToTheBit) {
#ifdef DTFLOP_WINDOWED_GPU
  DTFLOP_REQUIRE_GPU();
#endif
  BackendOptions o;
  o.poison = true;
  auto windowed = make_backend(GetParam(), o), full = make_backend(GetParam(), o);
  const Problem p = synthetic_problem({70, 50, 5, 5}, 7);
  windowed->init(p);
  full->init(p);
  // Moving sensors; the value beyond the window switching (a detection), windows at the edges and
  // one off the grid, and a full-grid step between windowed ones.
  struct Step {
    double x, y;
    bool hit;
  };
  const std::vector<Step> steps = {{20, 20, false}, {25, 22, false}, {1, 48, false}, {30, 25, true},
                                   {33, 27, true},  {40, 30, false}, {200, 200, false}, {69, 0, false},
                                   {35, 25, false}};
  for (std::size_t k = 0; k < steps.size(); ++k) {
    SCOPED_TRACE("step " + std::to_string(k));
    const WindowedLikelihood l = sensor(p.grid, steps[k].x, steps[k].y, steps[k].hit);
    if (k == 5) {
      (void)windowed->step(expand(l, p.grid));  // a whole grid written between windowed steps
    } else {
      (void)windowed->step(l);
    }
    (void)full->step(expand(l, p.grid));
    ASSERT_EQ(windowed->belief(), full->belief());
  }
}

// Kernels of other sizes in turn (the plan changes with them); after each, a few steps against a
// second backend made again by init() from the first one's belief and the new kernel.
TEST_P(BackendWindowed, ANewKernelKeepsTheBelief) {
#ifdef DTFLOP_WINDOWED_GPU
  DTFLOP_REQUIRE_GPU();
#endif
  auto kept = make_backend(GetParam());
  Problem p = synthetic_problem({90, 60, 5, 5}, 11);
  kept->init(p);
  (void)kept->run(2);
  for (std::int64_t size : {41, 3, 9}) {
    SCOPED_TRACE("kernel " + std::to_string(size));
    const Problem q = synthetic_problem({90, 60, size, size}, 12);
    const std::vector<double> before = kept->belief();
    kept->set_kernel(q.kernel);
    // The belief is kept: the same values (the CPU backends make it again from these: a float32
    // one rounds them once more).
    const std::vector<double> after = kept->belief();
    double largest = 0;
    for (double v : before) largest = std::max(largest, v);
    for (std::size_t i = 0; i < before.size(); ++i) ASSERT_NEAR(after[i], before[i], 1e-6 * largest) << i;
    auto fresh = make_backend(GetParam());
    Problem r = p;
    r.kernel = q.kernel;
    r.prior = after;
    fresh->init(r);
    for (int k = 0; k < 3; ++k) {
      (void)kept->step(p.likelihood);
      (void)fresh->step(p.likelihood);
    }
    const std::vector<double> a = kept->belief(), b = fresh->belief();
    largest = 0;
    for (double v : b) largest = std::max(largest, v);
    for (std::size_t i = 0; i < a.size(); ++i) ASSERT_NEAR(a[i], b[i], 1e-5 * largest) << i;
  }
  // A kernel wider than the grid is refused.
  const MotionKernel wide = MotionKernel::separable(std::vector<double>(91, 1.0 / 91), {1.0});
  EXPECT_THROW(kept->set_kernel(wide), InputError);
}

// The search-and-rescue team's steps that the link stretches need a kernel about as tall as the
// grid (sar/platform.cpp). Every backend takes one through set_kernel, and back, and steps on as
// cpu-seq (float64) does with the same kernels. A 1399-row kernel is taller than any tile of
// cuda-resident's y-pass in shared memory (sm_90): its split passes walk it in chunks of taps
// (resident_geometry.hpp), and back to a small kernel it fuses again.
TEST_P(BackendWindowed, AKernelAsTallAsTheGridStepsAsCpuSeq) {
#ifdef DTFLOP_WINDOWED_GPU
  DTFLOP_REQUIRE_GPU();
#endif
  const Problem p = synthetic_problem({40, 1400, 5, 5}, 21);
  const MotionKernel tall = synthetic_problem({40, 1400, 7, 1399}, 22).kernel;
  auto b = make_backend(GetParam());
  auto ref = make_backend("cpu-seq");
  b->init(p);
  ref->init(p);
  (void)b->run(1);
  (void)ref->run(1);
  for (const MotionKernel* k : {&tall, &p.kernel, &tall}) {
    SCOPED_TRACE("kernel " + std::to_string(k->Ix()) + "x" + std::to_string(k->Iy()));
    b->set_kernel(*k);
    ref->set_kernel(*k);
    for (int i = 0; i < 2; ++i) {
      (void)b->step(p.likelihood);
      (void)ref->step(p.likelihood);
    }
    const std::vector<double> got = b->belief(), want = ref->belief();
    double largest = 0, mass = 0;
    for (double v : want) largest = std::max(largest, v);
    for (double v : got) mass += v * p.grid.cell_area();
    ASSERT_GT(largest, 0);
    EXPECT_NEAR(mass, 1.0, 1e-5);
    for (std::size_t i = 0; i < got.size(); ++i) ASSERT_NEAR(got[i], want[i], 1e-5 * largest) << i;
  }
}

INSTANTIATE_TEST_SUITE_P(Here, BackendWindowed, ::testing::ValuesIn(backends_here()), [](const auto& info) {
  std::string s = info.param;
  for (char& c : s)
    if (c == '-') c = '_';
  return s;
});

}  // namespace
}  // namespace dtflop::rbe
