#include "workloads/rbe/motion.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <fmt/format.h>

#include "model/errors.hpp"

namespace dtflop::rbe {
namespace {

void check_kernel_values(const std::vector<double>& v, const char* what) {
  if (v.empty()) throw InputError(fmt::format("the {} kernel is empty; give at least one value", what));
  double sum = 0;
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (!std::isfinite(v[i]) || v[i] < 0)
      throw InputError(fmt::format("{} kernel value {} is {}; kernel values must be finite and >= 0",
                                   what, i, v[i]));
    sum += v[i];
  }
  if (!(sum > 0)) throw InputError(fmt::format("the {} kernel sums to zero; it must hold some probability", what));
}

double normal_cdf(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

void check_motion(const GaussianMotion& m) {
  if (!std::isfinite(m.mean_x) || !std::isfinite(m.mean_y))
    throw InputError("the motion's mean displacement must be finite");
  if (!(m.sigma_x > 0) || !(m.sigma_y > 0) || !std::isfinite(m.sigma_x) || !std::isfinite(m.sigma_y))
    throw InputError(fmt::format("the motion's standard deviations ({}, {}) must be finite and > 0",
                                 m.sigma_x, m.sigma_y));
  if (!(std::abs(m.rho) < 1))
    throw InputError(fmt::format("the motion's correlation {} must lie in (-1, 1)", m.rho));
}

// Probability that the displacement lies in [x0, x1] x [y0, y1] (grid units). Separable when
// rho = 0; otherwise exact along x given y (conditional normal) and composite Simpson along y.
double rect_mass(const GaussianMotion& m, double x0, double x1, double y0, double y1) {
  if (m.rho == 0)
    return (normal_cdf((x1 - m.mean_x) / m.sigma_x) - normal_cdf((x0 - m.mean_x) / m.sigma_x)) *
           (normal_cdf((y1 - m.mean_y) / m.sigma_y) - normal_cdf((y0 - m.mean_y) / m.sigma_y));
  // Integrate over y only where the density is not negligible (8 sigma).
  const double lo = std::max(y0, m.mean_y - 8 * m.sigma_y);
  const double hi = std::min(y1, m.mean_y + 8 * m.sigma_y);
  if (!(hi > lo)) return 0;
  const double s_cond = m.sigma_x * std::sqrt(1 - m.rho * m.rho);
  auto f = [&](double y) {
    const double zy = (y - m.mean_y) / m.sigma_y;
    const double py = std::exp(-0.5 * zy * zy) / (m.sigma_y * std::sqrt(2 * M_PI));
    const double mx = m.mean_x + m.rho * m.sigma_x * zy;
    return py * (normal_cdf((x1 - mx) / s_cond) - normal_cdf((x0 - mx) / s_cond));
  };
  constexpr int n = 64;  // even
  const double h = (hi - lo) / n;
  double s = f(lo) + f(hi);
  for (int i = 1; i < n; ++i) s += (i % 2 ? 4 : 2) * f(lo + i * h);
  return s * h / 3;
}

// Displacement interval of kernel entry a (grid units) along an axis of cell size d.
double entry_lo(std::int64_t a, std::int64_t size, double d) {
  return (double(a - kernel_centre(size)) - 0.5) * d;
}

}  // namespace

MotionKernel MotionKernel::separable(std::vector<double> kx, std::vector<double> ky) {
  check_kernel_values(kx, "column (x)");
  check_kernel_values(ky, "row (y)");
  MotionKernel k;
  k.Ix_ = static_cast<std::int64_t>(kx.size());
  k.Iy_ = static_cast<std::int64_t>(ky.size());
  k.kx_ = std::move(kx);
  k.ky_ = std::move(ky);
  return k;
}

MotionKernel MotionKernel::full(std::int64_t Ix, std::int64_t Iy, std::vector<double> values) {
  if (Ix < 1 || Iy < 1) throw InputError(fmt::format("kernel {}x{} must be at least 1x1", Ix, Iy));
  if (static_cast<std::int64_t>(values.size()) != Ix * Iy)
    throw InputError(fmt::format("a {}x{} kernel needs {} values, got {}", Ix, Iy, Ix * Iy, values.size()));
  check_kernel_values(values, "2D");
  MotionKernel k;
  k.Ix_ = Ix;
  k.Iy_ = Iy;
  k.full_ = std::move(values);
  return k;
}

double MotionKernel::at(std::int64_t a, std::int64_t b) const {
  if (is_separable()) return kx_[static_cast<std::size_t>(a)] * ky_[static_cast<std::size_t>(b)];
  return full_[static_cast<std::size_t>(b * Ix_ + a)];
}

std::vector<double> MotionKernel::dense() const {
  std::vector<double> d(static_cast<std::size_t>(Ix_ * Iy_));
  for (std::int64_t b = 0; b < Iy_; ++b)
    for (std::int64_t a = 0; a < Ix_; ++a) d[static_cast<std::size_t>(b * Ix_ + a)] = at(a, b);
  return d;
}

double MotionKernel::sum() const {
  if (is_separable())
    return std::accumulate(kx_.begin(), kx_.end(), 0.0) * std::accumulate(ky_.begin(), ky_.end(), 0.0);
  return std::accumulate(full_.begin(), full_.end(), 0.0);
}

GaussianMotion moments(const DriftModel& d) {
  for (double v : {d.speed_mean, d.speed_sigma, d.heading_mean, d.heading_sigma, d.dt})
    if (!std::isfinite(v)) throw InputError("drift model parameters must be finite numbers");
  if (d.speed_sigma < 0 || d.heading_sigma < 0)
    throw InputError("drift model standard deviations must be >= 0");
  if (!(d.dt > 0)) throw InputError(fmt::format("drift time step {} must be > 0", d.dt));
  const double mu = d.heading_mean, s2 = d.heading_sigma * d.heading_sigma;
  const double e1 = std::exp(-s2 / 2), e2 = std::exp(-2 * s2);
  const double Ec = std::cos(mu) * e1, Es = std::sin(mu) * e1;          // E[cos g], E[sin g]
  const double Ecc = 0.5 * (1 + std::cos(2 * mu) * e2);                 // E[cos^2 g]
  const double Ess = 0.5 * (1 - std::cos(2 * mu) * e2);                 // E[sin^2 g]
  const double Ecs = 0.5 * std::sin(2 * mu) * e2;                       // E[sin g cos g]
  const double Ev2 = d.speed_mean * d.speed_mean + d.speed_sigma * d.speed_sigma;
  const double m2 = d.speed_mean * d.speed_mean;
  const double dt2 = d.dt * d.dt;
  GaussianMotion g;
  g.mean_x = d.dt * d.speed_mean * Ec;
  g.mean_y = d.dt * d.speed_mean * Es;
  const double vx = dt2 * (Ev2 * Ecc - m2 * Ec * Ec);
  const double vy = dt2 * (Ev2 * Ess - m2 * Es * Es);
  const double cxy = dt2 * (Ev2 * Ecs - m2 * Ec * Es);
  if (!(vx > 0) || !(vy > 0))
    throw InputError("the drift has no spread along an axis (speed and heading noise are zero); "
                     "give speed_sigma or heading_sigma > 0");
  g.sigma_x = std::sqrt(vx);
  g.sigma_y = std::sqrt(vy);
  g.rho = cxy / (g.sigma_x * g.sigma_y);
  if (std::abs(g.rho) < 1e-12) g.rho = 0;  // axis-aligned up to rounding: separable
  return g;
}

MotionKernel make_kernel(const GaussianMotion& m, const Grid& grid, std::int64_t Ix, std::int64_t Iy) {
  check_motion(m);
  if (Ix < 1 || Iy < 1) throw InputError(fmt::format("kernel {}x{} must be at least 1x1", Ix, Iy));
  if (Ix > grid.nx() || Iy > grid.ny())
    throw InputError(fmt::format("kernel {}x{} is larger than the grid {}x{}", Ix, Iy, grid.nx(), grid.ny()));
  const double dx = grid.dx(), dy = grid.dy();
  if (m.axis_aligned()) {
    auto axis = [](std::int64_t size, double d, double mean, double sigma) {
      std::vector<double> k(static_cast<std::size_t>(size));
      for (std::int64_t a = 0; a < size; ++a) {
        const double lo = entry_lo(a, size, d);
        k[static_cast<std::size_t>(a)] = normal_cdf((lo + d - mean) / sigma) - normal_cdf((lo - mean) / sigma);
      }
      return k;
    };
    auto kx = axis(Ix, dx, m.mean_x, m.sigma_x);
    auto ky = axis(Iy, dy, m.mean_y, m.sigma_y);
    const double sx = std::accumulate(kx.begin(), kx.end(), 0.0);
    const double sy = std::accumulate(ky.begin(), ky.end(), 0.0);
    if (!(sx > 0) || !(sy > 0))
      throw InputError(fmt::format("a {}x{} kernel holds none of the motion's probability (mean "
                                   "displacement ({}, {}) is outside it); use a larger kernel",
                                   Ix, Iy, m.mean_x, m.mean_y));
    for (auto& v : kx) v /= sx;
    for (auto& v : ky) v /= sy;
    return MotionKernel::separable(std::move(kx), std::move(ky));
  }
  std::vector<double> v(static_cast<std::size_t>(Ix * Iy));
  double total = 0;
  for (std::int64_t b = 0; b < Iy; ++b)
    for (std::int64_t a = 0; a < Ix; ++a) {
      const double x0 = entry_lo(a, Ix, dx), y0 = entry_lo(b, Iy, dy);
      const double p = rect_mass(m, x0, x0 + dx, y0, y0 + dy);
      v[static_cast<std::size_t>(b * Ix + a)] = p;
      total += p;
    }
  if (!(total > 0))
    throw InputError(fmt::format("a {}x{} kernel holds none of the motion's probability; use a larger kernel",
                                 Ix, Iy));
  for (auto& x : v) x /= total;
  return MotionKernel::full(Ix, Iy, std::move(v));
}

double kernel_mass(const GaussianMotion& m, const Grid& grid, std::int64_t Ix, std::int64_t Iy) {
  check_motion(m);
  const double dx = grid.dx(), dy = grid.dy();
  const double x0 = entry_lo(0, Ix, dx), y0 = entry_lo(0, Iy, dy);
  return rect_mass(m, x0, x0 + double(Ix) * dx, y0, y0 + double(Iy) * dy);
}

KernelSize kernel_size_for_mass(const GaussianMotion& m, const Grid& grid, double fraction) {
  check_motion(m);
  if (!(fraction > 0 && fraction < 1))
    throw InputError(fmt::format("probability-mass fraction {} must lie in (0, 1), e.g. 0.997", fraction));
  KernelSize k;
  double mass = kernel_mass(m, grid, k.Ix, k.Iy);
  while (mass < fraction) {
    const bool can_x = k.Ix < grid.nx(), can_y = k.Iy < grid.ny();
    if (!can_x && !can_y)
      throw InputError(fmt::format("no kernel within the {}x{} grid holds {:.4g} of the motion's "
                                   "probability (the whole grid holds {:.4g}); use a larger grid or a "
                                   "smaller fraction",
                                   grid.nx(), grid.ny(), fraction, mass));
    const double mx = can_x ? kernel_mass(m, grid, k.Ix + 1, k.Iy) : -1;
    const double my = can_y ? kernel_mass(m, grid, k.Ix, k.Iy + 1) : -1;
    if (mx >= my) {
      ++k.Ix;
      mass = mx;
    } else {
      ++k.Iy;
      mass = my;
    }
  }
  return k;
}

}  // namespace dtflop::rbe
