#include "workloads/rbe/estimate.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "model/json_io.hpp"

namespace dtflop::rbe {

Estimate estimate(const Grid& grid, std::span<const double> belief) {
  if (static_cast<std::int64_t>(belief.size()) != grid.cells())
    throw InputError(fmt::format("estimate: the belief has {} values, the grid {} cells; give a belief of this grid",
                                 belief.size(), grid.cells()));
  const double ac = grid.cell_area();
  Estimate e;
  double best = -1;
  // Two passes: the mean first, then the centred second moments (no cancellation).
  double m = 0, sx = 0, sy = 0;
  for (std::int64_t iy = 0; iy < grid.ny(); ++iy)
    for (std::int64_t ix = 0; ix < grid.nx(); ++ix) {
      const double b = belief[static_cast<std::size_t>(grid.index(ix, iy))];
      if (!(b >= 0) || !std::isfinite(b))
        throw InputError(fmt::format("estimate: belief cell ({}, {}) is {}; a belief is finite and non-negative",
                                     ix, iy, b));
      const double p = b * ac;
      const Point c = grid.centre(ix, iy);
      m += p;
      sx += p * c.x;
      sy += p * c.y;
      if (b > best) {
        best = b;
        e.map_ix = ix;
        e.map_iy = iy;
      }
    }
  if (!(m > 0)) throw InputError("estimate: the belief holds no mass; give a belief with a positive cell");
  e.mass = m;
  e.mean_x = sx / m;
  e.mean_y = sy / m;
  double cxx = 0, cxy = 0, cyy = 0, h = 0;
  for (std::int64_t iy = 0; iy < grid.ny(); ++iy)
    for (std::int64_t ix = 0; ix < grid.nx(); ++ix) {
      const double p = belief[static_cast<std::size_t>(grid.index(ix, iy))] * ac / m;
      if (p <= 0) continue;
      const Point c = grid.centre(ix, iy);
      const double dx = c.x - e.mean_x, dy = c.y - e.mean_y;
      cxx += p * dx * dx;
      cxy += p * dx * dy;
      cyy += p * dy * dy;
      h -= p * std::log(p);
    }
  e.cov_xx = cxx;
  e.cov_xy = cxy;
  e.cov_yy = cyy;
  e.entropy = h;
  const Point mc = grid.centre(e.map_ix, e.map_iy);
  e.map_x = mc.x;
  e.map_y = mc.y;
  return e;
}

Window footprint_window(const Grid& grid, const Footprint& f, Point at) {
  auto first = [](double v, double lo, double d) { return static_cast<std::int64_t>(std::floor((v - lo) / d)); };
  Window w;
  w.ix0 = std::max<std::int64_t>(0, first(at.x - f.reach, grid.x_min(), grid.dx()));
  w.ix1 = std::min<std::int64_t>(grid.nx() - 1, first(at.x + f.reach, grid.x_min(), grid.dx()));
  w.iy0 = std::max<std::int64_t>(0, first(at.y - f.reach, grid.y_min(), grid.dy()));
  w.iy1 = std::min<std::int64_t>(grid.ny() - 1, first(at.y + f.reach, grid.y_min(), grid.dy()));
  return w;
}

void check_footprint(const Footprint& f, std::span<const Point> at) {
  if (!(std::isfinite(f.peak) && f.peak >= 0))
    throw InputError(fmt::format("footprint peak {} is invalid; give a finite value >= 0", f.peak));
  if (!(std::isfinite(f.spread) && f.spread > 0))
    throw InputError(fmt::format("footprint spread {} is invalid; give a finite value > 0", f.spread));
  if (!(std::isfinite(f.reach) && f.reach > 0))
    throw InputError(fmt::format("footprint reach {} is invalid; give a finite value > 0", f.reach));
  for (std::size_t j = 0; j < at.size(); ++j)
    if (!std::isfinite(at[j].x) || !std::isfinite(at[j].y) || std::abs(at[j].x) > 1e15 || std::abs(at[j].y) > 1e15)
      throw InputError(fmt::format("footprint point {} is ({}, {}); give finite coordinates within 1e15", j, at[j].x,
                                   at[j].y));
}

std::vector<double> footprint_sums(const Grid& grid, std::span<const double> belief, const Footprint& f,
                                   std::span<const Point> at) {
  if (static_cast<std::int64_t>(belief.size()) != grid.cells())
    throw InputError(fmt::format("footprints: the belief has {} values, the grid {} cells; give a belief of this grid",
                                 belief.size(), grid.cells()));
  check_footprint(f, at);
  const double ac = grid.cell_area();
  std::vector<double> out(at.size(), 0.0);
  for (std::size_t j = 0; j < at.size(); ++j) {
    const Window w = footprint_window(grid, f, at[j]);
    double e = 0;
    for (std::int64_t iy = w.iy0; iy <= w.iy1; ++iy)
      for (std::int64_t ix = w.ix0; ix <= w.ix1; ++ix) {
        const Point c = grid.centre(ix, iy);
        const double d = std::hypot(c.x - at[j].x, c.y - at[j].y);
        e += belief[static_cast<std::size_t>(grid.index(ix, iy))] * ac *
             (f.peak * std::exp(-d * d / (2 * f.spread * f.spread)));
      }
    out[j] = e;
  }
  return out;
}

std::string estimates_csv(std::span<const Estimate> rows) {
  std::string out = "step,time,mean_x,mean_y,cov_xx,cov_xy,cov_yy,map_ix,map_iy,map_x,map_y,entropy,mass,detected\n";
  for (const Estimate& e : rows)
    out += fmt::format("{},{:.9g},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{},{},{:.17g},{:.17g},{:.17g},{:.17g},{}\n",
                       e.step, e.time, e.mean_x, e.mean_y, e.cov_xx, e.cov_xy, e.cov_yy, e.map_ix, e.map_iy, e.map_x,
                       e.map_y, e.entropy, e.mass, e.detected);
  return out;
}

nlohmann::json to_json(const Estimate& e) {
  return {{"step", e.step},       {"time", e.time},         {"mean", {e.mean_x, e.mean_y}},
          {"covariance", {{e.cov_xx, e.cov_xy}, {e.cov_xy, e.cov_yy}}},
          {"map_cell", {e.map_ix, e.map_iy}}, {"map", {e.map_x, e.map_y}}, {"entropy", e.entropy},
          {"mass", e.mass},       {"detected", e.detected}};
}

nlohmann::json estimates_json(std::span<const Estimate> rows) {
  nlohmann::json a = nlohmann::json::array();
  for (const Estimate& e : rows) a.push_back(to_json(e));
  return {{"entropy_unit", "nats"}, {"length_unit", "grid units"}, {"estimates", a}};
}

void write_estimates(const std::filesystem::path& path, std::span<const Estimate> rows) {
  const bool json = path.extension() == ".json";
  write_file_atomically(path, json ? estimates_json(rows).dump(1) + "\n" : estimates_csv(rows));
}

}  // namespace dtflop::rbe
