// What the estimator estimates: the summary of a belief on the grid (mean, covariance, the
// maximum a posteriori cell, entropy) and its output per step as CSV or JSON.
//
// The belief is a density on the grid (grid.hpp: sum x A_c = 1); the cell probabilities are
// p_i = b_i A_c. Mean and covariance are those of the cell centres weighted by p_i (the
// discrete distribution the grid holds); the entropy is that of the cell probabilities,
// H = -sum p_i ln p_i in nats (0 for one cell, ln n_g for a uniform belief).
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "workloads/rbe/grid.hpp"

namespace dtflop::rbe {

struct Estimate {
  std::int64_t step = 0;      // steps done when the belief was taken (0: the prior)
  double time = 0;            // physical time of the step, seconds (0 where there is none)
  double mean_x = 0, mean_y = 0;
  double cov_xx = 0, cov_xy = 0, cov_yy = 0;
  std::int64_t map_ix = 0, map_iy = 0;  // the cell of largest belief (the first one on ties)
  double map_x = 0, map_y = 0;          // its centre
  double entropy = 0;                   // nats
  double mass = 0;                      // sum p_i (1 for a normalized belief)
  int detected = -1;                    // the step's observation: 1 detected, 0 not, -1 none
};

// The estimate of `belief` (a density, n_x n_y values). Throws InputError when the sizes differ,
// a value is negative or not finite, or the belief holds no mass.
Estimate estimate(const Grid& grid, std::span<const double> belief);

// CSV with a header line; columns in the order of Estimate's fields.
std::string estimates_csv(std::span<const Estimate> rows);
nlohmann::json to_json(const Estimate& e);
nlohmann::json estimates_json(std::span<const Estimate> rows);
// Writes `rows` to `path` atomically, as JSON when the name ends in .json, else CSV.
void write_estimates(const std::filesystem::path& path, std::span<const Estimate> rows);

}  // namespace dtflop::rbe
