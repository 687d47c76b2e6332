// Helpers for the RBE tests: random problems (fresh seed each run, printed on failure), errors.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "workloads/rbe/backend.hpp"
#include "workloads/rbe/likelihood.hpp"

namespace dtflop::rbe::test {

// A fresh seed per test run; tests SCOPED_TRACE it so a failure can be reproduced.
inline std::uint64_t fresh_seed() {
  std::random_device rd;
  return (std::uint64_t(rd()) << 32) ^ rd();
}

struct RandomProblem {
  std::int64_t nx = 37, ny = 29, Ix = 5, Iy = 3;
  bool separable = true;
  bool mask = false;       // a random triangle as the target space
  double area = 0.25;      // cell area A_c (grid spacing 0.5 x 0.5)
};

// Random positive kernels (not Gaussian: every tap matters), a random prior with some zero
// cells, a random likelihood in [0.05, 1].
inline Problem random_problem(const RandomProblem& r, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u01(0, 1);
  Problem p;
  const double d = std::sqrt(r.area);
  p.grid = Grid(-1, -1 + d * double(r.nx), 2, 2 + d * double(r.ny), r.nx, r.ny);
  auto vec = [&](std::int64_t n, double lo) {
    std::vector<double> v(static_cast<std::size_t>(n));
    for (auto& x : v) x = lo + u01(rng);
    return v;
  };
  if (r.separable) p.kernel = MotionKernel::separable(vec(r.Ix, 0.01), vec(r.Iy, 0.01));
  else p.kernel = MotionKernel::full(r.Ix, r.Iy, vec(r.Ix * r.Iy, 0.01));
  p.prior = vec(r.nx * r.ny, 0);
  for (auto& x : p.prior)
    if (u01(rng) < 0.1) x = 0;
  p.prior[p.prior.size() / 2] = 1;  // never all zeros, not even on a 1 x 1 grid
  p.likelihood = vec(r.nx * r.ny, 0.05);
  if (r.mask) {
    const double w = d * double(r.nx), h = d * double(r.ny);
    const Polygon tri = {{-1 + 0.05 * w, 2 + 0.1 * h}, {-1 + 0.95 * w, 2 + 0.3 * h}, {-1 + 0.4 * w, 2 + 0.97 * h}};
    p.mask = p.grid.mask(tri);
  }
  return p;
}

// sum |a - b| / sum |b|.
inline double relative_l1(const std::vector<double>& a, const std::vector<double>& b) {
  double num = 0, den = 0;
  for (std::size_t i = 0; i < b.size(); ++i) {
    num += std::abs(a[i] - b[i]);
    den += std::abs(b[i]);
  }
  return num / den;
}

inline std::size_t count_nan(const std::vector<double>& v) {
  std::size_t n = 0;
  for (double x : v) n += std::isnan(x) ? 1 : 0;
  return n;
}

// sum x A_c: 1 for a normalized belief.
inline double mass(const std::vector<double>& belief, const Grid& g) {
  double s = 0;
  for (double x : belief) s += x;
  return s * g.cell_area();
}

inline std::string describe(const RandomProblem& r, std::uint64_t seed) {
  return fmt::format("grid {}x{}, kernel {}x{} ({}), mask {}, seed {}", r.nx, r.ny, r.Ix, r.Iy,
                     r.separable ? "separable" : "full", r.mask, seed);
}

// A belief peaked at the origin of a 48 x 48 grid on [-2, 2]^2, watched by a sensor that
// (almost surely, P_d up to 0.999) sees nothing there: long runs of this negative
// observation must neither underflow nor produce NaN.
inline Problem negative_observation_problem() {
  const Grid g(-2, 2, -2, 2, 48, 48);
  Problem p;
  p.grid = g;
  p.kernel = make_kernel({0, 0, 0.05, 0.05, 0}, g, 5, 5);
  p.prior.resize(std::size_t(g.cells()));
  for (std::int64_t j = 0; j < 48; ++j)
    for (std::int64_t i = 0; i < 48; ++i) {
      const Point c = g.centre(i, j);
      p.prior[std::size_t(g.index(i, j))] = std::exp(-(c.x * c.x + c.y * c.y) / (2 * 0.1));
    }
  p.likelihood = likelihood(g, NegativeObservation{{0, 0}, 0.999, 0.5});
  return p;
}

}  // namespace dtflop::rbe::test
