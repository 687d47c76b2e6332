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

// ---- What a search control reads: expected detection under a Gaussian footprint -------------

// A sensor footprint: weight peak exp(-d^2 / (2 spread^2)) at distance d from a point, over the
// cells of the square of half-side `reach` around it (the cells i_x = floor((x - reach - x_min) /
// dx) .. floor((x + reach - x_min) / dx), the same along y, clipped to the grid). Valid when
// every field is finite and > 0 (peak may be any finite value >= 0).
struct Footprint {
  double peak = 1;
  double spread = 1;
  double reach = 4;
};

// The cells a footprint at `at` covers (ix1 < ix0 or iy1 < iy0: none).
struct Window {
  std::int64_t ix0 = 0, ix1 = -1, iy0 = 0, iy1 = -1;
  std::int64_t cells() const { return ix1 < ix0 || iy1 < iy0 ? 0 : (ix1 - ix0 + 1) * (iy1 - iy0 + 1); }
};
Window footprint_window(const Grid& grid, const Footprint& f, Point at);
// Throws InputError naming the field when `f` is not valid, or a point is not finite.
void check_footprint(const Footprint& f, std::span<const Point> at);

// The float64 reference: for each point, sum_i p_i peak exp(-d_i^2 / (2 spread^2)) over the cells
// i of its window (p_i = b_i A_c, d_i the distance from the cell's centre). Throws InputError as
// estimate() and check_footprint() do.
std::vector<double> footprint_sums(const Grid& grid, std::span<const double> belief, const Footprint& f,
                                   std::span<const Point> at);

// What the estimate and a control read of a belief, as a backend computes it where the belief
// lives (Backend::summarize): a few numbers instead of the grid.
struct Summary {
  Estimate estimate;
  std::vector<double> footprints;  // one per point asked for
};

// CSV with a header line; columns in the order of Estimate's fields.
std::string estimates_csv(std::span<const Estimate> rows);
nlohmann::json to_json(const Estimate& e);
nlohmann::json estimates_json(std::span<const Estimate> rows);
// Writes `rows` to `path` atomically, as JSON when the name ends in .json, else CSV.
void write_estimates(const std::filesystem::path& path, std::span<const Estimate> rows);

}  // namespace dtflop::rbe
