// Observation likelihoods (seed eq. 4.6) and fusion of several sensor platforms (4.13, 5.8-5.9).
// All are grid arrays (grid.hpp), float64.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "model/cost_counts.hpp"
#include "workloads/rbe/grid.hpp"

namespace dtflop::rbe {

// A positive observation: the sensor at `sensor` saw the target at `observed`. The likelihood is
// an isotropic Gaussian density around `observed` whose standard deviation grows with the
// sensor-target distance: sigma = sigma_min + sigma_per_distance * |observed - sensor|.
struct PositiveObservation {
  Point observed;
  Point sensor;
  double sigma_min = 0.05;
  double sigma_per_distance = 0.05;
};

// A negative observation: the sensor at `sensor` saw nothing. l(x) = 1 - P_d(x), with a
// Gaussian probability of detection P_d(x) = pd_max exp(-|x - sensor|^2 / (2 sigma^2))
// (seed Test 4: sigma 0.2 km). pd_max in [0, 1]; pd_max = 1 makes l zero under the sensor.
struct NegativeObservation {
  Point sensor;
  double pd_max = 0.9;
  double sigma = 0.2;
};

// Throws InputError for non-finite positions or non-positive spreads, pd_max outside [0, 1].
std::vector<double> likelihood(const Grid& grid, const PositiveObservation& o);
std::vector<double> likelihood(const Grid& grid, const NegativeObservation& o);

// Multiplies `mask` (grid.hpp) into `values` (cells outside the target space become 0).
// Throws InputError when the sizes differ.
void apply_mask(std::span<double> values, std::span<const std::uint8_t> mask);

// Observation fusion (4.13): the product of the platforms' likelihoods, cell by cell.
// Throws InputError when there are none or their sizes differ.
std::vector<double> fuse_observations(std::span<const std::vector<double>> likelihoods);
// Counts on the CPU (float64, one thread): (n_s - 1) n_g multiplications.
CostCounts observation_fusion_counts(std::int64_t cells, std::int64_t platforms);

// Belief fusion (5.8-5.9): the product of the platforms' beliefs, normalized so that it
// integrates to one over the grid (sum x A_c = 1). Throws NumericalError (backend.hpp) when the
// product is zero everywhere (the platforms' beliefs do not overlap), InputError on bad sizes.
std::vector<double> fuse_beliefs(const Grid& grid, std::span<const std::vector<double>> beliefs);
// Counts on the CPU (float64, one thread): (n_s - 1) n_g multiplications, n_g additions,
// 1 multiplication by A_c, n_g divisions.
CostCounts belief_fusion_counts(std::int64_t cells, std::int64_t platforms);

}  // namespace dtflop::rbe
