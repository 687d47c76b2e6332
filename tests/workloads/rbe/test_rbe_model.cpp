// Grid (4.7, masks), motion model (5.23 moments, kernels, the 99.7% helper), likelihoods (4.6)
// and fusion (4.13, 5.8-5.9), against values worked out by hand or by Monte Carlo.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <random>

#include "model/errors.hpp"
#include "tests/workloads/rbe/support.hpp"
#include "workloads/rbe/likelihood.hpp"
#include "workloads/rbe/motion.hpp"

namespace dtflop::rbe {
namespace {

TEST(RbeGrid, CentresAndAreaFollowEq4_7) {
  const Grid g(-2, 2, 0, 1, 8, 4);  // dx = 0.5, dy = 0.25
  EXPECT_DOUBLE_EQ(g.dx(), 0.5);
  EXPECT_DOUBLE_EQ(g.dy(), 0.25);
  EXPECT_DOUBLE_EQ(g.cell_area(), 0.125);
  // (i - 0.5) dx + x_min with one-based i: zero-based ix = 0 -> -1.75, ix = 7 -> 1.75.
  EXPECT_DOUBLE_EQ(g.centre(0, 0).x, -1.75);
  EXPECT_DOUBLE_EQ(g.centre(7, 3).x, 1.75);
  EXPECT_DOUBLE_EQ(g.centre(0, 3).y, 0.875);
  EXPECT_EQ(g.index(3, 2), 2 * 8 + 3);
  EXPECT_THROW(Grid(1, 1, 0, 1, 4, 4), InputError);
  EXPECT_THROW(Grid(0, 1, 0, 1, 0, 4), InputError);
  EXPECT_THROW(Grid(0, NAN, 0, 1, 4, 4), InputError);
}

TEST(RbeGrid, MaskSelectsCellsWhoseCentreIsInsideThePolygon) {
  const Grid g = Grid::unit(10, 10);
  // The lower-left triangle x + y < 10: centres (i + 0.5, j + 0.5) inside iff i + j + 1 < 10.
  const Polygon tri = {{0, 0}, {10, 0}, {0, 10}};
  const auto m = g.mask(tri);
  int inside = 0;
  for (int j = 0; j < 10; ++j)
    for (int i = 0; i < 10; ++i) {
      EXPECT_EQ(m[std::size_t(g.index(i, j))], (i + j + 1 < 10) ? 1 : 0) << i << "," << j;
      inside += m[std::size_t(g.index(i, j))];
    }
  EXPECT_EQ(inside, 45);
  EXPECT_THROW(g.mask({{0, 0}, {1, 1}}), InputError);
}

TEST(RbeMotion, DriftMomentsMatchMonteCarlo) {
  // Seed Test 4: v ~ N(0.1, 0.02) km/s, heading ~ N(0, 0.7) rad, dt = 10 s; and a rotated one.
  for (double heading : {0.0, 0.6}) {
    const DriftModel d{0.1, 0.02, heading, 0.7, 10};
    const GaussianMotion m = moments(d);
    std::mt19937_64 rng(12345);
    std::normal_distribution<double> v(d.speed_mean, d.speed_sigma), g(d.heading_mean, d.heading_sigma);
    const int n = 400000;
    double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
    for (int i = 0; i < n; ++i) {
      const double vv = v(rng), gg = g(rng);
      const double x = d.dt * vv * std::cos(gg), y = d.dt * vv * std::sin(gg);
      sx += x, sy += y, sxx += x * x, syy += y * y, sxy += x * y;
    }
    const double mx = sx / n, my = sy / n;
    const double vx = sxx / n - mx * mx, vy = syy / n - my * my, cxy = sxy / n - mx * my;
    EXPECT_NEAR(m.mean_x, mx, 3e-3);
    EXPECT_NEAR(m.mean_y, my, 3e-3);
    EXPECT_NEAR(m.sigma_x, std::sqrt(vx), 3e-3);
    EXPECT_NEAR(m.sigma_y, std::sqrt(vy), 3e-3);
    EXPECT_NEAR(m.rho, cxy / std::sqrt(vx * vy), 1e-2);
    EXPECT_EQ(m.axis_aligned(), heading == 0.0);
  }
  EXPECT_THROW(moments({0.1, 0, 0, 0, 1}), InputError);  // no spread
  EXPECT_THROW(moments({0.1, -1, 0, 0.1, 1}), InputError);
}

TEST(RbeMotion, AxisAlignedMotionGivesASeparableNormalizedKernel) {
  const Grid g = Grid::unit(50, 50);
  const GaussianMotion m{1.0, -0.5, 2.0, 1.5, 0};
  const auto k = make_kernel(m, g, 13, 9);
  ASSERT_TRUE(k.is_separable());
  EXPECT_NEAR(k.sum(), 1.0, 1e-12);
  // Entry a is the mass over displacement (a - c) +- 0.5 cells: the peak sits at the mean.
  const auto& kx = k.kx();
  const auto peak = std::max_element(kx.begin(), kx.end()) - kx.begin();
  EXPECT_EQ(peak - kernel_centre(13), 1);
  // Ratio of two entries equals the ratio of the normal's cell masses.
  auto cell = [](double lo, double mean, double s) {
    auto Phi = [](double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); };
    return Phi((lo + 1 - mean) / s) - Phi((lo - mean) / s);
  };
  EXPECT_NEAR(kx[2] / kx[8], cell(2 - 6 - 0.5, 1, 2) / cell(8 - 6 - 0.5, 1, 2), 1e-12);
}

TEST(RbeMotion, CorrelatedMotionGivesAFullKernelWithTheRightCorrelation) {
  const Grid g = Grid::unit(60, 60);
  const GaussianMotion m{0, 0, 3.0, 2.0, 0.6};
  const auto k = make_kernel(m, g, 31, 25);
  ASSERT_FALSE(k.is_separable());
  EXPECT_NEAR(k.sum(), 1.0, 1e-12);
  double sx = 0, sy = 0, sxy = 0;
  for (int b = 0; b < 25; ++b)
    for (int a = 0; a < 31; ++a) {
      const double x = a - 15, y = b - 12, w = k.at(a, b);
      sx += w * x * x, sy += w * y * y, sxy += w * x * y;
    }
  // Cell binning adds 1/12 to each variance.
  EXPECT_NEAR(sx, 9.0 + 1.0 / 12, 0.02);
  EXPECT_NEAR(sy, 4.0 + 1.0 / 12, 0.02);
  EXPECT_NEAR(sxy / std::sqrt(sx * sy), 0.6 * 6 / std::sqrt((9 + 1.0 / 12) * (4 + 1.0 / 12)), 0.01);
}

TEST(RbeMotion, SmallestKernelHolding997PerCentOfTheMass) {
  const Grid g = Grid::unit(200, 200);
  // Centred Gaussian, sigma 2 cells in x, 1 cell in y.
  const GaussianMotion m{0, 0, 2.0, 1.0, 0};
  const auto k = kernel_size_for_mass(m, g);
  EXPECT_GE(kernel_mass(m, g, k.Ix, k.Iy), 0.997);
  EXPECT_LT(kernel_mass(m, g, k.Ix - 1, k.Iy), 0.997);
  EXPECT_LT(kernel_mass(m, g, k.Ix, k.Iy - 1), 0.997);
  // About +-3 sigma each way: 3 sigma_x = 6 cells -> 13 wide; 3 sigma_y -> 7 (+-1 for the split).
  EXPECT_NEAR(double(k.Ix), 13, 2);
  EXPECT_NEAR(double(k.Iy), 7, 2);
  // A drift needs a wider kernel to hold the same mass.
  const auto kd = kernel_size_for_mass({5, 0, 2.0, 1.0, 0}, g);
  EXPECT_GT(kd.Ix, k.Ix + 5);
  // A custom fraction, and errors.
  EXPECT_LE(kernel_size_for_mass(m, g, 0.5).Ix, k.Ix);
  EXPECT_THROW(kernel_size_for_mass(m, g, 1.0), InputError);
  EXPECT_THROW(kernel_size_for_mass({0, 0, 50, 50, 0}, Grid::unit(20, 20)), InputError);
}

TEST(RbeLikelihood, PositiveObservationIsAGaussianWidenedByDistance) {
  const Grid g(-5, 5, -5, 5, 200, 200);
  PositiveObservation o{{1, -1}, {1, -1}, 0.2, 0.1};
  auto l = likelihood(g, o);
  double integral = std::accumulate(l.begin(), l.end(), 0.0) * g.cell_area();
  EXPECT_NEAR(integral, 1.0, 1e-3);  // a density
  const auto peak = std::max_element(l.begin(), l.end()) - l.begin();
  const Point c = g.centre(peak % 200, peak / 200);
  EXPECT_NEAR(c.x, 1, g.dx());
  EXPECT_NEAR(c.y, -1, g.dy());
  // The same observation seen from 4 km away: sigma 0.2 + 0.1 x 4 = 0.6, peak 1/(2 pi 0.36).
  o.sensor = {1, 3};
  l = likelihood(g, o);
  EXPECT_NEAR(*std::max_element(l.begin(), l.end()), 1 / (2 * M_PI * 0.36), 0.01 / (2 * M_PI * 0.36));
  EXPECT_THROW(likelihood(g, PositiveObservation{{0, 0}, {0, 0}, 0, 0}), InputError);
}

TEST(RbeLikelihood, NegativeObservationIsOneMinusGaussianDetection) {
  const Grid g(-1, 1, -1, 1, 21, 21);
  const auto l = likelihood(g, NegativeObservation{{0, 0}, 0.9, 0.2});
  EXPECT_NEAR(l[std::size_t(g.index(10, 10))], 1 - 0.9, 1e-12);  // centre cell at (0, 0)
  const Point c = g.centre(15, 10);                               // 0.476 away
  EXPECT_NEAR(l[std::size_t(g.index(15, 10))], 1 - 0.9 * std::exp(-c.x * c.x / (2 * 0.04)), 1e-12);
  EXPECT_GT(l[0], 0.999);
  EXPECT_THROW(likelihood(g, NegativeObservation{{0, 0}, 1.5, 0.2}), InputError);
}

TEST(RbeFusion, ObservationFusionMultipliesLikelihoods) {
  const std::vector<std::vector<double>> ls = {{1, 2, 3}, {0.5, 0.5, 2}, {2, 0, 1}};
  EXPECT_EQ(fuse_observations(ls), (std::vector<double>{1, 0, 6}));
  EXPECT_THROW(fuse_observations(std::vector<std::vector<double>>{}), InputError);
  EXPECT_THROW(fuse_observations(std::vector<std::vector<double>>{{1, 2}, {1}}), InputError);
  const auto c = observation_fusion_counts(1000, 3);
  EXPECT_EQ(c.N_C, 2000);
}

TEST(RbeFusion, BeliefFusionMultipliesAndNormalizes) {
  const Grid g(0, 2, 0, 1, 2, 2);  // A_c = 0.5
  const std::vector<std::vector<double>> bs = {{1, 1, 0, 0}, {0.5, 1.5, 1, 0}};
  const auto f = fuse_beliefs(g, bs);
  // Product {0.5, 1.5, 0, 0}, sum 2, A_c x sum = 1.
  EXPECT_DOUBLE_EQ(f[0], 0.5);
  EXPECT_DOUBLE_EQ(f[1], 1.5);
  EXPECT_DOUBLE_EQ(f[2], 0);
  EXPECT_NEAR(test::mass(f, g), 1.0, 1e-15);
  // Disjoint beliefs: an error, never NaN.
  EXPECT_THROW(fuse_beliefs(g, std::vector<std::vector<double>>{{1, 0, 0, 0}, {0, 1, 0, 0}}), NumericalError);
  const auto c = belief_fusion_counts(4, 2);
  EXPECT_EQ(c.N_C, 4 + 4 + 1 + 4);
}

}  // namespace
}  // namespace dtflop::rbe
