// The estimate against a closed form: a Gaussian prior under Gaussian motion (and a Gaussian
// likelihood) stays Gaussian, with the mean and covariance of the Kalman filter. The test builds
// its own point-sampled Gaussians and its own float64 convolution (nothing from the code under
// test but the grid), checks that reference against the closed form, then checks each backend's
// estimate against the reference: cpu-seq (float64) to 1e-9, the float32 backends within what
// float32 rounding allows. Compiled twice: CPU backends (label unit) and, with
// DTFLOP_ESTIMATE_GPU, the CUDA backends (label gpu; skipped without a device).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "model/errors.hpp"
#include "tests/support/gpu.hpp"
#include "workloads/rbe/backend.hpp"
#include "workloads/rbe/estimate.hpp"

namespace dtflop::rbe {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Point samples of N(mean, sigma^2) at integer offsets (a - c), a = 0 .. size - 1.
std::vector<double> gauss1(std::int64_t size, double mean, double sigma) {
  const std::int64_t c = (size - 1) / 2;
  std::vector<double> k(static_cast<std::size_t>(size));
  for (std::int64_t a = 0; a < size; ++a) {
    const double d = double(a - c) - mean;
    k[static_cast<std::size_t>(a)] = std::exp(-d * d / (2 * sigma * sigma));
  }
  return k;
}

// Point samples of an axis-aligned Gaussian density at the cell centres of a unit grid.
std::vector<double> gauss2(const Grid& g, double mx, double my, double sx, double sy) {
  std::vector<double> v(static_cast<std::size_t>(g.cells()));
  for (std::int64_t iy = 0; iy < g.ny(); ++iy)
    for (std::int64_t ix = 0; ix < g.nx(); ++ix) {
      const Point c = g.centre(ix, iy);
      const double dx = (c.x - mx) / sx, dy = (c.y - my) / sy;
      v[static_cast<std::size_t>(g.index(ix, iy))] = std::exp(-0.5 * (dx * dx + dy * dy)) / (2 * kPi * sx * sy);
    }
  return v;
}

struct Case {
  // Grid of unit cells, 96 x 80; prior N((30.5, 35.5), diag(4^2, 3^2)); motion per step
  // N((2, 1), diag(1.5^2, 1.2^2)) cells; likelihood N(z, diag(r^2)) per axis or none.
  Grid grid = Grid::unit(96, 80);
  double m0x = 30.5, m0y = 35.5, s0x = 4, s0y = 3;
  double ux = 2, uy = 1, qx = 1.5, qy = 1.2;
  std::int64_t Ix = 25, Iy = 17;  // reach 6.7 and 5.8 sigma beyond the mean
  bool observe = false;
  double zx = 42.5, zy = 41.5, rx = 5, ry = 4;
  int steps = 10;

  Problem problem() const {
    Problem p;
    p.grid = grid;
    p.kernel = MotionKernel::separable(gauss1(Ix, ux, qx), gauss1(Iy, uy, qy));
    p.prior = gauss2(grid, m0x, m0y, s0x, s0y);
    p.likelihood = observe ? gauss2(grid, zx, zy, rx, ry) : std::vector<double>(std::size_t(grid.cells()), 1.0);
    return p;
  }
  // The closed form after `steps` steps: the Kalman filter per axis (no correction without an
  // observation: mean + n u, variance + n q^2).
  struct Moments {
    double mx, my, vx, vy;
  };
  Moments closed_form() const {
    double mx = m0x, my = m0y, vx = s0x * s0x, vy = s0y * s0y;
    for (int n = 0; n < steps; ++n) {
      mx += ux, my += uy, vx += qx * qx, vy += qy * qy;
      if (observe) {
        const double kx = vx / (vx + rx * rx), ky = vy / (vy + ry * ry);
        mx += kx * (zx - mx), my += ky * (zy - my);
        vx *= 1 - kx, vy *= 1 - ky;
      }
    }
    return {mx, my, vx, vy};
  }
  // The test's own float64 RBE: a direct separable convolution (zero belief outside the grid),
  // times the likelihood, normalized to sum x A_c = 1.
  std::vector<double> reference() const {
    const Problem p = problem();
    const std::int64_t nx = grid.nx(), ny = grid.ny(), cx = (Ix - 1) / 2, cy = (Iy - 1) / 2;
    std::vector<double> b = p.prior, u(b.size()), w(b.size());
    auto normalize = [&](std::vector<double>& v) {
      double s = 0;
      for (double x : v) s += x;
      for (double& x : v) x /= s * grid.cell_area();
    };
    normalize(b);
    for (int n = 0; n < steps; ++n) {
      for (std::int64_t iy = 0; iy < ny; ++iy)
        for (std::int64_t ix = 0; ix < nx; ++ix) {
          double acc = 0;
          for (std::int64_t a = 0; a < Ix; ++a) {
            const std::int64_t j = ix - (a - cx);
            if (j >= 0 && j < nx) acc += p.kernel.kx()[std::size_t(a)] * b[std::size_t(iy * nx + j)];
          }
          u[std::size_t(iy * nx + ix)] = acc;
        }
      for (std::int64_t iy = 0; iy < ny; ++iy)
        for (std::int64_t ix = 0; ix < nx; ++ix) {
          double acc = 0;
          for (std::int64_t a = 0; a < Iy; ++a) {
            const std::int64_t j = iy - (a - cy);
            if (j >= 0 && j < ny) acc += p.kernel.ky()[std::size_t(a)] * u[std::size_t(j * nx + ix)];
          }
          w[std::size_t(iy * nx + ix)] = acc * p.likelihood[std::size_t(iy * nx + ix)];
        }
      b = w;
      normalize(b);
    }
    return b;
  }
};

void expect_closed_form(const Case& c) {
  const Estimate e = estimate(c.grid, c.reference());
  const auto m = c.closed_form();
  // Point-sampled Gaussians of spread >= 1 cell keep their moments to far below 1e-6 cells
  // (Poisson summation); the grid holds all but ~1e-7 of the mass.
  EXPECT_NEAR(e.mean_x, m.mx, 1e-5);
  EXPECT_NEAR(e.mean_y, m.my, 1e-5);
  EXPECT_NEAR(e.cov_xx / m.vx, 1.0, 1e-5);
  EXPECT_NEAR(e.cov_yy / m.vy, 1.0, 1e-5);
  EXPECT_NEAR(e.cov_xy, 0.0, 1e-6);
  EXPECT_NEAR(e.mass, 1.0, 1e-12);
  // Entropy of a point-sampled Gaussian on unit cells: ln(2 pi e sqrt(det)).
  EXPECT_NEAR(e.entropy, std::log(2 * kPi * std::exp(1.0) * std::sqrt(m.vx * m.vy)), 1e-5);
  // The MAP cell is the one whose centre is nearest the mean.
  EXPECT_NEAR(e.map_x, m.mx, 0.5 + 1e-9);
  EXPECT_NEAR(e.map_y, m.my, 0.5 + 1e-9);
}

TEST(RbeEstimate, ReferenceFollowsTheClosedFormUnderMotion) { expect_closed_form(Case{}); }

TEST(RbeEstimate, ReferenceFollowsTheKalmanFilterWithAGaussianLikelihood) {
  Case c;
  c.observe = true;
  expect_closed_form(c);
}

TEST(RbeEstimate, RejectsABeliefWithoutMassOrOfAnotherGrid) {
  const Grid g = Grid::unit(4, 3);
  EXPECT_THROW(estimate(g, std::vector<double>(12, 0.0)), InputError);
  EXPECT_THROW(estimate(g, std::vector<double>(11, 1.0)), InputError);
  std::vector<double> nan(12, 1.0);
  nan[5] = std::nan("");
  EXPECT_THROW(estimate(g, nan), InputError);
}

TEST(RbeEstimate, CsvAndJsonHoldEveryStep) {
  const Grid g = Grid::unit(4, 3);
  std::vector<double> b(12, 0.0);
  b[g.index(2, 1)] = 1.0;
  Estimate e = estimate(g, b);
  EXPECT_DOUBLE_EQ(e.mean_x, 2.5);
  EXPECT_DOUBLE_EQ(e.mean_y, 1.5);
  EXPECT_DOUBLE_EQ(e.entropy, 0.0);
  e.step = 7;
  const std::vector<Estimate> rows = {e, e};
  const std::string csv = estimates_csv(rows);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 3);
  EXPECT_NE(csv.find("\n7,0,2.5,1.5,"), std::string::npos);
  const auto j = estimates_json(rows);
  EXPECT_EQ(j["estimates"].size(), 2u);
  EXPECT_EQ(j["estimates"][1]["map_cell"][0], 2);
}

// Each backend's estimate against the float64 reference. float32 backends: a value rounded in
// each of the ~(I_x + I_y + 3) operations of a step, over `steps` steps, moves the belief by a
// relative ~steps (I_x + I_y + 3) 2^-24 ~ 2e-5 at most (in practice far less): the mean by that
// fraction of the belief's spread, the covariance and entropy by that relative amount.
class BackendEstimate : public ::testing::TestWithParam<const char*> {};

TEST_P(BackendEstimate, MatchesTheFloat64ReferenceWithinFloat32Rounding) {
  const std::string name = GetParam();
  auto b = make_backend(name);
#ifdef DTFLOP_ESTIMATE_GPU
  DTFLOP_REQUIRE_GPU();
#endif
  for (bool observe : {false, true}) {
    SCOPED_TRACE(observe ? "with a Gaussian likelihood" : "motion only");
    Case c;
    c.observe = observe;
    b->init(c.problem());
    (void)b->run(c.steps);
    const Estimate got = estimate(c.grid, b->belief());
    const Estimate want = estimate(c.grid, c.reference());
    const bool fp64 = name == "cpu-seq";
    const double rel = fp64 ? 1e-9 : double(c.steps) * double(c.Ix + c.Iy + 3) * std::ldexp(1.0, -24);
    const double spread = std::sqrt(want.cov_xx + want.cov_yy);
    EXPECT_NEAR(got.mean_x, want.mean_x, rel * spread);
    EXPECT_NEAR(got.mean_y, want.mean_y, rel * spread);
    EXPECT_NEAR(got.cov_xx / want.cov_xx, 1.0, rel);
    EXPECT_NEAR(got.cov_yy / want.cov_yy, 1.0, rel);
    EXPECT_NEAR(got.cov_xy, want.cov_xy, rel * spread * spread);
    EXPECT_NEAR(got.entropy / want.entropy, 1.0, rel);
    EXPECT_NEAR(got.mass, 1.0, rel);
    EXPECT_EQ(got.map_ix, want.map_ix);
    EXPECT_EQ(got.map_iy, want.map_iy);
  }
}

#ifdef DTFLOP_ESTIMATE_GPU
INSTANTIATE_TEST_SUITE_P(Cuda, BackendEstimate, ::testing::Values("cuda-seed", "cuda-resident"));
#else
INSTANTIATE_TEST_SUITE_P(Cpu, BackendEstimate, ::testing::Values("cpu-seq", "cpu-par"));
#endif

}  // namespace
}  // namespace dtflop::rbe
