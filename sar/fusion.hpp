// Fusion rules of the team and the radio link they travel over.
//
// - observation fusion (seed 4.13): every step each platform sends its observation (a few
//   numbers, kObservationBytes) to every other; each multiplies all the platforms' likelihoods.
// - belief fusion (5.8-5.9): every `interval` steps each platform sends its whole belief (float32
//   on the wire, 4 n_g bytes) to every other; each takes the normalized product. Once beliefs
//   have been fused they share the prior and every earlier exchange, and the product counts that
//   shared information again at every fusion (over-confidence).
// - log-linear (Chernoff) pool: the same exchange, fused as prod_i b_i^(1/n), normalized: a
//   belief shared by all is left as it is, so nothing is counted twice (Julier-Uhlmann-style
//   covariance intersection for densities); the price is that independent information is
//   under-weighted.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "sar/scenario.hpp"
#include "workloads/rbe/grid.hpp"

namespace dtflop::sar {

// prod_i b_i^(1/n), normalized to sum x A_c = 1. Cells where some belief is 0 are 0. Throws
// rbe::NumericalError when the pool is zero everywhere (the beliefs do not overlap), InputError
// on bad sizes.
std::vector<double> loglinear_pool(const rbe::Grid& grid, std::span<const std::vector<double>> beliefs);

// The belief as it travels: float32, n_g values.
std::vector<float> to_wire(std::span<const double> belief);
std::vector<double> from_wire(std::span<const float> wire);

// What one platform sends in one step of a team of `team` platforms.
struct Traffic {
  std::int64_t messages = 0;  // point-to-point messages sent
  std::int64_t bytes = 0;     // payload bytes sent, all messages together
};
// Step `step` (1-based): observation fusion sends (team - 1) observations every step; belief and
// log-linear fusion send (team - 1) beliefs on steps that are a multiple of the interval; none
// sends nothing.
Traffic traffic(const Scenario& s, std::int64_t team, std::int64_t step);
// Mean traffic per step over a long run (what the model's network term counts).
struct MeanTraffic {
  double messages = 0, bytes = 0;
};
MeanTraffic mean_traffic(const Scenario& s, std::int64_t team);
// Whether `step` (1-based) fuses beliefs.
bool fuses_beliefs(const Scenario& s, std::int64_t step);

// The link model: each message costs latency + 8 bytes / bandwidth; a platform sends its
// messages one after another over its radio. 0 when the link is off.
double link_delay(const Scenario& s, const Traffic& t);

}  // namespace dtflop::sar
