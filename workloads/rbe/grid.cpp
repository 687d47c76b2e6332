#include "workloads/rbe/grid.hpp"

#include <cmath>

#include <fmt/format.h>

#include "model/errors.hpp"

namespace dtflop::rbe {

bool inside(const Polygon& poly, Point p) {
  if (poly.size() < 3)
    throw InputError(fmt::format("a target-space polygon needs at least 3 vertices, got {}", poly.size()));
  bool in = false;
  // Even-odd rule: count the edges a ray from p towards +x crosses.
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Point a = poly[i], b = poly[j];
    if (!std::isfinite(a.x) || !std::isfinite(a.y))
      throw InputError(fmt::format("target-space polygon vertex {} is not finite", i));
    if ((a.y > p.y) != (b.y > p.y)) {
      const double x_cross = a.x + (p.y - a.y) * (b.x - a.x) / (b.y - a.y);
      if (p.x < x_cross) in = !in;
    }
  }
  return in;
}

Grid::Grid(double x_min, double x_max, double y_min, double y_max, std::int64_t nx, std::int64_t ny)
    : x_min_(x_min), x_max_(x_max), y_min_(y_min), y_max_(y_max), nx_(nx), ny_(ny) {
  if (!std::isfinite(x_min) || !std::isfinite(x_max) || !std::isfinite(y_min) || !std::isfinite(y_max))
    throw InputError("grid bounds must be finite numbers");
  if (!(x_max > x_min) || !(y_max > y_min))
    throw InputError(fmt::format("grid bounds [{}, {}] x [{}, {}] are empty; give x_max > x_min and "
                                 "y_max > y_min",
                                 x_min, x_max, y_min, y_max));
  if (nx < 1 || ny < 1)
    throw InputError(fmt::format("grid {}x{} must have at least one cell each way", nx, ny));
}

std::vector<std::uint8_t> Grid::mask(const Polygon& target_space) const {
  std::vector<std::uint8_t> m(static_cast<std::size_t>(cells()));
  for (std::int64_t iy = 0; iy < ny_; ++iy)
    for (std::int64_t ix = 0; ix < nx_; ++ix)
      m[static_cast<std::size_t>(index(ix, iy))] = inside(target_space, centre(ix, iy)) ? 1 : 0;
  return m;
}

}  // namespace dtflop::rbe
