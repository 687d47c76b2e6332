// The grid of the grid-based RBE (seed 4.2.1): a rectangular space split into n_x x n_y cells,
// cell centres (eq. 4.7), the cell area A_c and an optional target-space mask (the cells whose
// centre lies inside an arbitrary polygon).
//
// Storage convention used by every backend: a grid array holds n_x * n_y values, row-major with
// x the fast (contiguous) index: value (i_x, i_y) lives at [i_y * n_x + i_x], i_x in [0, n_x),
// i_y in [0, n_y) (zero-based; the seed's formulas are one-based).
#pragma once

#include <cstdint>
#include <vector>

namespace dtflop::rbe {

struct Point {
  double x = 0;
  double y = 0;
};

// A simple polygon (vertices in order, either orientation, not closed: the last vertex joins
// the first). Used to describe an arbitrary target space.
using Polygon = std::vector<Point>;

// True when `p` lies strictly inside `poly` (even-odd rule). Throws InputError when the
// polygon has fewer than 3 vertices or a non-finite coordinate.
bool inside(const Polygon& poly, Point p);

class Grid {
 public:
  Grid() = default;
  // Throws InputError when the bounds are empty or not finite, or a count is < 1.
  Grid(double x_min, double x_max, double y_min, double y_max, std::int64_t nx, std::int64_t ny);
  // Unit cells: [0, nx] x [0, ny], A_c = 1.
  static Grid unit(std::int64_t nx, std::int64_t ny) { return Grid(0, double(nx), 0, double(ny), nx, ny); }

  std::int64_t nx() const { return nx_; }
  std::int64_t ny() const { return ny_; }
  std::int64_t cells() const { return nx_ * ny_; }  // n_x n_y (n_g when there is no mask)
  double x_min() const { return x_min_; }
  double x_max() const { return x_max_; }
  double y_min() const { return y_min_; }
  double y_max() const { return y_max_; }
  double dx() const { return (x_max_ - x_min_) / double(nx_); }
  double dy() const { return (y_max_ - y_min_) / double(ny_); }
  double cell_area() const { return dx() * dy(); }  // A_c
  // Cell centre (eq. 4.7), zero-based indices.
  Point centre(std::int64_t ix, std::int64_t iy) const {
    return {(double(ix) + 0.5) * dx() + x_min_, (double(iy) + 0.5) * dy() + y_min_};
  }
  std::int64_t index(std::int64_t ix, std::int64_t iy) const { return iy * nx_ + ix; }

  // 1 for cells whose centre lies inside `target_space`, 0 otherwise (seed 4.2.1). Every
  // backend applies a mask by multiplying it into the likelihood and the prior, so cells
  // outside the target space never hold belief after a correction.
  std::vector<std::uint8_t> mask(const Polygon& target_space) const;

 private:
  double x_min_ = 0, x_max_ = 1, y_min_ = 0, y_max_ = 1;
  std::int64_t nx_ = 1, ny_ = 1;
};

}  // namespace dtflop::rbe
