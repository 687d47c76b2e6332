// The cooperative search-and-rescue scenario (seed 5.4.4, Table 5.5): the sea area and its
// grid, the drifting life raft (5.23) and its prior, the helicopters (5.24) and their sensor,
// the search-and-track control, the fusion rule and the radio link. Read from a YAML file
// (sar/scenarios/*.yaml; docs/sar.md lists every field) and validated field by field: a wrong
// field is one line naming the field, the value and what is expected.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "workloads/rbe/grid.hpp"
#include "workloads/rbe/motion.hpp"

namespace dtflop::sar {

// How the platforms share what they know (seed 4.13, 5.8-5.9, and a pool that does not count
// shared information twice).
enum class Rule {
  none,         // no sharing: each helicopter estimates alone
  observation,  // observation fusion every step (4.13): every platform's observation to every other
  belief,       // belief fusion every `interval` steps (5.8-5.9): the normalized product of the beliefs
  loglinear,    // log-linear (Chernoff) pool every `interval` steps: prod b_i^(1/n), normalized
};
std::string to_string(Rule r);
// Throws InputError naming the known rules.
Rule parse_rule(const std::string& text);

struct Helicopter {
  double x = 0, y = 0, heading = 0;  // km, km, rad from +x
};

struct Scenario {
  std::string name = "sar";
  // Sea area (km) and its grid.
  double x_min = -3, x_max = 11, y_min = -4, y_max = 4;
  std::int64_t nx = 140, ny = 80;
  // Physical time of one estimation step (s) and the length of a run.
  double step_time = 1.0;
  std::int64_t steps = 200;
  // Target (5.23): speed N(mean, sigma) km/s, heading N(mean, sigma) rad; prior N(mean, diag(sigma^2)) km.
  double target_speed_mean = 0.1, target_speed_sigma = 0.02;
  double target_heading_mean = 0.0, target_heading_sigma = 0.7;
  double prior_x = -1, prior_y = 1, prior_sigma_x = 0.3, prior_sigma_y = 0.2;
  double kernel_mass = 0.997;  // the motion kernel holds this much of a step's displacement
  // Helicopters (5.24): speed km/s, turn coefficient alpha, largest turn command (rad/s).
  double heli_speed = 0.12, turn_coefficient = 0.8, max_turn = 1.0;
  std::vector<Helicopter> helicopters;
  // Sensor: Gaussian probability of detection pd_max exp(-d^2 / (2 spread^2)); a detection
  // reports the raft's position with Gaussian noise sigma = noise_min + noise_per_km x distance.
  double detection_max = 0.95, detection_spread = 0.2;
  double noise_min = 0.02, noise_per_km = 0.05;
  // Control: candidate turn commands, look-ahead steps.
  std::int64_t control_turns = 9, control_lookahead = 10;
  // Fusion.
  Rule rule = Rule::belief;
  std::int64_t interval = 5;
  // Link (802.11n peak, seed Table 5.5): bandwidth Mbit/s, latency per message ms, and whether
  // it is modelled at all; `sleep` also holds each message back for its delay in wall time.
  bool link_enabled = true;
  double bandwidth_mbps = 70, latency_ms = 2;
  bool link_sleep = false;
  std::string backend = "cpu-par";
  std::uint64_t seed = 1;

  rbe::Grid grid() const { return rbe::Grid(x_min, x_max, y_min, y_max, nx, ny); }
  // The raft's displacement over `dt` seconds (5.23) as the RBE's drift model.
  rbe::DriftModel drift(double dt) const {
    return {target_speed_mean, target_speed_sigma, target_heading_mean, target_heading_sigma, dt};
  }
};

// Throws InputError naming the field, its value and what is expected.
void validate(const Scenario& s);
// Reads and validates a YAML scenario; fields left out keep their defaults. Throws InputError
// (one line: the file, the field, the value, what is expected) for a file that cannot be read,
// is larger than 1 MiB, is not YAML, or holds an unknown field or a bad value.
Scenario load_scenario(const std::string& path);
// Parses YAML text (for tests and fuzzing); `what` names it in messages.
Scenario parse_scenario(const std::string& text, const std::string& what);
// A digest of what every platform of a team must agree on (grid, motion, sensor, fusion, steps,
// helicopters, seed): two processes with different digests are not one team.
std::uint64_t team_digest(const Scenario& s);

}  // namespace dtflop::sar
