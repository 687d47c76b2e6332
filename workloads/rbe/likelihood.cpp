#include "workloads/rbe/likelihood.hpp"

#include <cmath>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "workloads/rbe/backend.hpp"

namespace dtflop::rbe {
namespace {

void check_point(Point p, const char* what) {
  if (!std::isfinite(p.x) || !std::isfinite(p.y))
    throw InputError(fmt::format("the {} position ({}, {}) must be finite", what, p.x, p.y));
}

void check_same_sizes(std::span<const std::vector<double>> arrays, const char* what) {
  if (arrays.empty()) throw InputError(fmt::format("{} fusion needs at least one platform", what));
  for (std::size_t i = 1; i < arrays.size(); ++i)
    if (arrays[i].size() != arrays[0].size())
      throw InputError(fmt::format("{} fusion: platform {} has {} cells, platform 0 has {}", what, i,
                                   arrays[i].size(), arrays[0].size()));
}

}  // namespace

std::vector<double> likelihood(const Grid& grid, const PositiveObservation& o) {
  check_point(o.observed, "observed");
  check_point(o.sensor, "sensor");
  if (!(o.sigma_min > 0) || !(o.sigma_per_distance >= 0) || !std::isfinite(o.sigma_min) ||
      !std::isfinite(o.sigma_per_distance))
    throw InputError(fmt::format("observation spread sigma_min {} must be > 0 and sigma_per_distance {} "
                                 ">= 0 (both finite)",
                                 o.sigma_min, o.sigma_per_distance));
  const double dist = std::hypot(o.observed.x - o.sensor.x, o.observed.y - o.sensor.y);
  const double sigma = o.sigma_min + o.sigma_per_distance * dist;
  const double norm = 1 / (2 * M_PI * sigma * sigma);
  std::vector<double> l(static_cast<std::size_t>(grid.cells()));
  for (std::int64_t iy = 0; iy < grid.ny(); ++iy)
    for (std::int64_t ix = 0; ix < grid.nx(); ++ix) {
      const Point c = grid.centre(ix, iy);
      const double r2 = (c.x - o.observed.x) * (c.x - o.observed.x) + (c.y - o.observed.y) * (c.y - o.observed.y);
      l[static_cast<std::size_t>(grid.index(ix, iy))] = norm * std::exp(-r2 / (2 * sigma * sigma));
    }
  return l;
}

std::vector<double> likelihood(const Grid& grid, const NegativeObservation& o) {
  check_point(o.sensor, "sensor");
  if (!(o.pd_max >= 0 && o.pd_max <= 1))
    throw InputError(fmt::format("probability of detection pd_max {} must lie in [0, 1]", o.pd_max));
  if (!(o.sigma > 0) || !std::isfinite(o.sigma))
    throw InputError(fmt::format("detection spread sigma {} must be finite and > 0", o.sigma));
  std::vector<double> l(static_cast<std::size_t>(grid.cells()));
  for (std::int64_t iy = 0; iy < grid.ny(); ++iy)
    for (std::int64_t ix = 0; ix < grid.nx(); ++ix) {
      const Point c = grid.centre(ix, iy);
      const double r2 = (c.x - o.sensor.x) * (c.x - o.sensor.x) + (c.y - o.sensor.y) * (c.y - o.sensor.y);
      l[static_cast<std::size_t>(grid.index(ix, iy))] = 1 - o.pd_max * std::exp(-r2 / (2 * o.sigma * o.sigma));
    }
  return l;
}

void apply_mask(std::span<double> values, std::span<const std::uint8_t> mask) {
  if (mask.size() != values.size())
    throw InputError(fmt::format("the mask has {} cells, the grid array {}", mask.size(), values.size()));
  for (std::size_t i = 0; i < values.size(); ++i)
    if (!mask[i]) values[i] = 0;
}

std::vector<double> fuse_observations(std::span<const std::vector<double>> likelihoods) {
  check_same_sizes(likelihoods, "observation");
  std::vector<double> out = likelihoods[0];
  for (std::size_t p = 1; p < likelihoods.size(); ++p)
    for (std::size_t i = 0; i < out.size(); ++i) out[i] *= likelihoods[p][i];
  return out;
}

CostCounts observation_fusion_counts(std::int64_t cells, std::int64_t platforms) {
  CostCounts c;
  c.P = 8;
  c.precision = Precision::fp64;
  c.N_C = (platforms - 1) * cells;
  c.N_CC = platforms * cells + cells;  // read every likelihood, write the product
  return c;
}

std::vector<double> fuse_beliefs(const Grid& grid, std::span<const std::vector<double>> beliefs) {
  check_same_sizes(beliefs, "belief");
  if (static_cast<std::int64_t>(beliefs[0].size()) != grid.cells())
    throw InputError(fmt::format("belief fusion: beliefs have {} cells, the grid {}", beliefs[0].size(),
                                 grid.cells()));
  std::vector<double> out = beliefs[0];
  for (std::size_t p = 1; p < beliefs.size(); ++p)
    for (std::size_t i = 0; i < out.size(); ++i) out[i] *= beliefs[p][i];
  double sum = 0;
  for (double v : out) sum += v;
  const double z = sum * grid.cell_area();
  if (!(z > 0) || !std::isfinite(z))
    throw NumericalError(0, fmt::format("belief fusion: the product of the {} platforms' beliefs is {} "
                                        "everywhere (their beliefs do not overlap); fuse fewer platforms "
                                        "or fuse more often",
                                        beliefs.size(), std::isfinite(z) ? "zero" : "not finite"));
  for (double& v : out) v /= z;
  return out;
}

CostCounts belief_fusion_counts(std::int64_t cells, std::int64_t platforms) {
  CostCounts c;
  c.P = 8;
  c.precision = Precision::fp64;
  c.N_C = (platforms - 1) * cells + cells + 1 + cells;
  c.N_CC = platforms * cells + cells + cells + 2 * cells;  // product r+w, sum read, divide r+w
  return c;
}

}  // namespace dtflop::rbe
