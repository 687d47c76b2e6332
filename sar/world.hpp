// The world of the search-and-rescue scenario: the drifting raft (5.23), the helicopters (5.24),
// the sensor (Gaussian probability of detection, noise growing with distance, negative
// observations when nothing is seen) and the search-and-track control.
#pragma once

#include <cstdint>
#include <random>
#include <span>
#include <vector>

#include "sar/scenario.hpp"
#include "workloads/rbe/backend.hpp"
#include "workloads/rbe/estimate.hpp"
#include "workloads/rbe/grid.hpp"

namespace dtflop::sar {

// The raft, drifting by (5.23) with its own random draws; starts at a draw from the prior.
class Raft {
 public:
  Raft(const Scenario& s, std::uint64_t seed);
  void advance(double dt);
  rbe::Point position() const { return p_; }

 private:
  const Scenario* s_;
  std::mt19937_64 rng_;
  rbe::Point p_;
};

// One step of a helicopter (5.24): x += dt v cos(theta), y += dt v sin(theta),
// theta += dt alpha turn; `turn` is the control's command, |turn| <= max_turn.
void fly(const Scenario& s, Helicopter& h, double turn, double dt);

// P_d at distance d: detection_max exp(-d^2 / (2 spread^2)).
double detection_probability(const Scenario& s, double d);

// What a helicopter reports each step. Plain doubles: the message of observation fusion.
struct Observation {
  double sensor_x = 0, sensor_y = 0;
  double detected = 0;             // 1 or 0
  double observed_x = 0, observed_y = 0;
  double platform = 0;             // index of the helicopter
};
inline constexpr std::int64_t kObservationBytes = static_cast<std::int64_t>(sizeof(Observation));

// Draws the observation of the raft at `raft` from helicopter `h`.
Observation sense(const Scenario& s, const Helicopter& h, int platform, rbe::Point raft, std::mt19937_64& rng);

// The likelihood of an observation on `grid`: for a detection P_d(x) N(z; x, sigma^2 I) with
// sigma = noise_min + noise_per_km |z - sensor|; for none, 1 - P_d(x) (a negative observation).
// Values are > 0 wherever detection_max < 1 (no detection). Cells beyond 7.7 spreads of the
// sensor, where P_d < 1e-13 of its peak, take P_d = 0.
std::vector<double> likelihood(const Scenario& s, const rbe::Grid& grid, const Observation& o);
// The same likelihood as a window (the cells within 7.7 spreads of the sensor, clipped to the grid)
// and the value beyond it: what a backend whose belief lives on a device needs to be sent.
rbe::WindowedLikelihood likelihood_window(const Scenario& s, const rbe::Grid& grid, const Observation& o);

// The search-and-track control: the turn command, among `control_turns` commands evenly spread
// over [-max_turn, max_turn], whose path held for `control_lookahead` steps of `step_time`
// collects the most expected detection sum_j sum_i p_i P_d(|c_i - pos_j|) under the current
// belief (cell probabilities p_i, the cells within 4 spreads of pos_j along each axis); ties go to
// the smaller turn. Where no path comes within reach of the belief (expected detection below
// 1e-6), it turns toward the belief's mean instead. The same for every fusion rule.
//
// In three parts, so that the belief's sums are taken where it lives (rbe::Backend::summarize):
// the look-ahead positions pos_j (turn-major: control_lookahead points per turn command), the
// footprint of P_d they are weighed with, and the choice from the sums at those points.
std::vector<rbe::Point> lookahead_points(const Scenario& s, const Helicopter& h);
rbe::Footprint detection_footprint(const Scenario& s);
double choose_turn(const Scenario& s, const Helicopter& h, std::span<const double> footprints, rbe::Point mean);
// All three on a float64 belief on the host (rbe::footprint_sums, rbe::estimate's mean).
double choose_turn(const Scenario& s, const rbe::Grid& grid, const Helicopter& h, std::span<const double> belief);

// The prior belief: N(prior mean, diag(prior sigma^2)) sampled at the cell centres.
std::vector<double> prior_belief(const Scenario& s, const rbe::Grid& grid);

}  // namespace dtflop::sar
