// Motion model of the grid-based RBE: the target's displacement over one time step turned
// into the prediction's convolution kernel (seed eqs. 4.9-4.10, 5.1, 5.23).
//
// Kernel convention used by every backend: entry a of a kernel of size I (zero-based) is the
// probability that the target moves by (a - c) cells, c = (I - 1) / 2 (integer division), so
// an odd kernel is centred and an even one reaches one cell further in +. The prediction is
// the convolution pred[i] = sum_a k[a] * p[i - (a - c)], with zero belief outside the grid.
#pragma once

#include <cstdint>
#include <vector>

#include "workloads/rbe/grid.hpp"

namespace dtflop::rbe {

inline std::int64_t kernel_centre(std::int64_t size) { return (size - 1) / 2; }

// The kernel of the prediction: separable (a column kernel along x of length I_x times a row
// kernel along y of length I_y, eq. 5.1) or a full I_x x I_y matrix (eq. 4.10).
class MotionKernel {
 public:
  MotionKernel() = default;
  // Throws InputError when a kernel is empty, holds a negative or non-finite value, or sums
  // to zero.
  static MotionKernel separable(std::vector<double> kx, std::vector<double> ky);
  // `values` row-major, [b * Ix + a] is displacement (a - c_x, b - c_y).
  static MotionKernel full(std::int64_t Ix, std::int64_t Iy, std::vector<double> values);

  std::int64_t Ix() const { return Ix_; }
  std::int64_t Iy() const { return Iy_; }
  bool is_separable() const { return full_.empty(); }
  const std::vector<double>& kx() const { return kx_; }    // separable only
  const std::vector<double>& ky() const { return ky_; }    // separable only
  const std::vector<double>& values() const { return full_; }  // full only
  // Entry (a, b) of the 2D kernel, whichever the representation.
  double at(std::int64_t a, std::int64_t b) const;
  // The I_x x I_y matrix (the outer product kx ky^T when separable).
  std::vector<double> dense() const;
  double sum() const;

 private:
  std::int64_t Ix_ = 0, Iy_ = 0;
  std::vector<double> kx_, ky_, full_;
};

// A Gaussian displacement per step, in the grid's units (not cells): mean (mean_x, mean_y),
// standard deviations sigma_x, sigma_y > 0 and correlation rho in (-1, 1).
struct GaussianMotion {
  double mean_x = 0;
  double mean_y = 0;
  double sigma_x = 1;
  double sigma_y = 1;
  double rho = 0;
  bool axis_aligned() const { return rho == 0; }
};

// Gaussian drift (eq. 5.23): over a time step dt the target moves by dt * v * (cos g, sin g)
// with speed v ~ N(speed_mean, speed_sigma) and heading g ~ N(heading_mean, heading_sigma)
// (radians, measured from +x). Seed Test 4: v ~ N(0.1 km/s, 0.02), g ~ N(0, 0.7).
struct DriftModel {
  double speed_mean = 0;
  double speed_sigma = 0;
  double heading_mean = 0;
  double heading_sigma = 0;
  double dt = 1;
};

// The Gaussian with the displacement's exact mean and covariance (v and g independent;
// E[cos g] = cos(mu) e^{-s^2/2}, E[cos^2 g] = (1 + cos(2 mu) e^{-2 s^2}) / 2, ...). Throws
// InputError when a parameter is negative or not finite, or the displacement has no spread.
GaussianMotion moments(const DriftModel& drift);

// The kernel of size I_x x I_y for `motion` on `grid`'s cells: each entry is the probability
// mass of the displacement over that cell offset, normalized to sum 1 over the kernel. Axis-
// aligned motion gives a separable kernel (1D cell integrals through erf), correlated motion a
// full one (each cell integrated exactly along x through the conditional normal's CDF and by
// composite Simpson along y). Throws InputError when a size is < 1 or larger than the grid,
// or the kernel would hold no probability mass.
MotionKernel make_kernel(const GaussianMotion& motion, const Grid& grid, std::int64_t Ix,
                         std::int64_t Iy);

// The probability mass of `motion` that a kernel of size I_x x I_y on `grid` holds.
double kernel_mass(const GaussianMotion& motion, const Grid& grid, std::int64_t Ix, std::int64_t Iy);

struct KernelSize {
  std::int64_t Ix = 1;
  std::int64_t Iy = 1;
};
// The smallest kernel (grown one cell at a time along the axis that gains more mass) that holds
// at least `fraction` of the motion's probability mass (default 99.7%, the 3-sigma mass of a
// Gaussian). Throws InputError when fraction is not in (0, 1) or no kernel within the grid
// holds that much.
KernelSize kernel_size_for_mass(const GaussianMotion& motion, const Grid& grid, double fraction = 0.997);

}  // namespace dtflop::rbe
