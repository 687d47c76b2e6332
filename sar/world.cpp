#include "sar/world.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace dtflop::sar {
namespace {

constexpr double kPi = 3.14159265358979323846;

double normal(std::mt19937_64& rng, double mean, double sigma) {
  return std::normal_distribution<double>(mean, sigma)(rng);
}

double wrap(double a) {
  while (a > kPi) a -= 2 * kPi;
  while (a < -kPi) a += 2 * kPi;
  return a;
}

}  // namespace

Raft::Raft(const Scenario& s, std::uint64_t seed) : s_(&s), rng_(seed) {
  p_ = {normal(rng_, s.prior_x, s.prior_sigma_x), normal(rng_, s.prior_y, s.prior_sigma_y)};
}

void Raft::advance(double dt) {
  const double v = normal(rng_, s_->target_speed_mean, s_->target_speed_sigma);
  const double g = normal(rng_, s_->target_heading_mean, s_->target_heading_sigma);
  p_.x += dt * v * std::cos(g);
  p_.y += dt * v * std::sin(g);
}

void fly(const Scenario& s, Helicopter& h, double turn, double dt) {
  h.x += dt * s.heli_speed * std::cos(h.heading);
  h.y += dt * s.heli_speed * std::sin(h.heading);
  h.heading = wrap(h.heading + dt * s.turn_coefficient * std::clamp(turn, -s.max_turn, s.max_turn));
}

double detection_probability(const Scenario& s, double d) {
  return s.detection_max * std::exp(-d * d / (2 * s.detection_spread * s.detection_spread));
}

Observation sense(const Scenario& s, const Helicopter& h, int platform, rbe::Point raft, std::mt19937_64& rng) {
  Observation o;
  o.sensor_x = h.x;
  o.sensor_y = h.y;
  o.platform = platform;
  const double d = std::hypot(raft.x - h.x, raft.y - h.y);
  const double u = std::uniform_real_distribution<double>(0, 1)(rng);
  if (u < detection_probability(s, d)) {
    const double sigma = s.noise_min + s.noise_per_km * d;
    o.detected = 1;
    o.observed_x = raft.x + normal(rng, 0, sigma);
    o.observed_y = raft.y + normal(rng, 0, sigma);
  }
  return o;
}

rbe::WindowedLikelihood likelihood_window(const Scenario& s, const rbe::Grid& grid, const Observation& o) {
  // P_d is below 1e-13 of its peak beyond 7.7 spreads: cells farther than that from the sensor
  // take the value of P_d = 0 (1 without a detection, 0 with one), the rest are computed.
  const double reach = 7.7 * s.detection_spread;
  const bool hit = o.detected != 0;
  rbe::WindowedLikelihood l;
  l.outside = hit ? 0.0 : 1.0;
  const double two_s2 = 2 * s.detection_spread * s.detection_spread;
  const double sigma = s.noise_min + s.noise_per_km * std::hypot(o.observed_x - o.sensor_x, o.observed_y - o.sensor_y);
  const double norm = 1 / (2 * kPi * sigma * sigma);
  auto first = [](double v, double lo, double d) { return static_cast<std::int64_t>(std::floor((v - lo) / d)); };
  const std::int64_t ix0 = std::max<std::int64_t>(0, first(o.sensor_x - reach, grid.x_min(), grid.dx()));
  const std::int64_t ix1 = std::min<std::int64_t>(grid.nx() - 1, first(o.sensor_x + reach, grid.x_min(), grid.dx()));
  const std::int64_t iy0 = std::max<std::int64_t>(0, first(o.sensor_y - reach, grid.y_min(), grid.dy()));
  const std::int64_t iy1 = std::min<std::int64_t>(grid.ny() - 1, first(o.sensor_y + reach, grid.y_min(), grid.dy()));
  if (ix1 < ix0 || iy1 < iy0) return l;  // the sensor's reach misses the grid
  l.window = {ix0, ix1, iy0, iy1};
  l.values.reserve(static_cast<std::size_t>(l.window.cells()));
  for (std::int64_t iy = iy0; iy <= iy1; ++iy)
    for (std::int64_t ix = ix0; ix <= ix1; ++ix) {
      const rbe::Point c = grid.centre(ix, iy);
      const double r2 = (c.x - o.sensor_x) * (c.x - o.sensor_x) + (c.y - o.sensor_y) * (c.y - o.sensor_y);
      const double pd = s.detection_max * std::exp(-r2 / two_s2);
      double v;
      if (hit) {
        const double e2 = (c.x - o.observed_x) * (c.x - o.observed_x) + (c.y - o.observed_y) * (c.y - o.observed_y);
        v = pd * norm * std::exp(-e2 / (2 * sigma * sigma));
      } else {
        v = 1 - pd;
      }
      l.values.push_back(v);
    }
  return l;
}

std::vector<double> likelihood(const Scenario& s, const rbe::Grid& grid, const Observation& o) {
  return rbe::expand(likelihood_window(s, grid, o), grid);
}

namespace {

std::int64_t turn_count(const Scenario& s) { return std::max<std::int64_t>(s.control_turns, 0); }
double turn_command(const Scenario& s, std::int64_t k) {
  const std::int64_t n = s.control_turns;
  return n == 1 ? 0.0 : -s.max_turn + 2 * s.max_turn * double(k) / double(n - 1);
}

}  // namespace

std::vector<rbe::Point> lookahead_points(const Scenario& s, const Helicopter& h) {
  std::vector<rbe::Point> at;
  at.reserve(std::size_t(turn_count(s) * std::max<std::int64_t>(s.control_lookahead, 0)));
  for (std::int64_t k = 0; k < turn_count(s); ++k) {
    Helicopter p = h;
    for (std::int64_t j = 0; j < s.control_lookahead; ++j) {
      fly(s, p, turn_command(s, k), s.step_time);
      at.push_back({p.x, p.y});
    }
  }
  return at;
}

rbe::Footprint detection_footprint(const Scenario& s) {
  return {s.detection_max, s.detection_spread, 4 * s.detection_spread};
}

double choose_turn(const Scenario& s, const Helicopter& h, std::span<const double> footprints, rbe::Point mean) {
  const std::int64_t n = turn_count(s), L = std::max<std::int64_t>(s.control_lookahead, 0);
  if (static_cast<std::int64_t>(footprints.size()) != n * L)
    throw std::invalid_argument("choose_turn: one footprint sum per look-ahead point is needed");
  double best = -1, best_turn = 0;
  for (std::int64_t k = 0; k < n; ++k) {
    const double turn = turn_command(s, k);
    double score = 0;
    for (std::int64_t j = 0; j < L; ++j) score += footprints[std::size_t(k * L + j)];
    if (score > best + 1e-12 || (std::abs(score - best) <= 1e-12 && std::abs(turn) < std::abs(best_turn))) {
      best = score;
      best_turn = turn;
    }
  }
  if (best >= 1e-6) return best_turn;
  // Out of reach: turn toward the belief's mean.
  if (!std::isfinite(mean.x) || !std::isfinite(mean.y)) return 0;
  const double want = wrap(std::atan2(mean.y - h.y, mean.x - h.x) - h.heading);
  return std::clamp(want / (s.step_time * s.turn_coefficient), -s.max_turn, s.max_turn);
}

double choose_turn(const Scenario& s, const rbe::Grid& grid, const Helicopter& h, std::span<const double> belief) {
  const std::vector<rbe::Point> at = lookahead_points(s, h);
  const std::vector<double> sums = rbe::footprint_sums(grid, belief, detection_footprint(s), at);
  const rbe::Estimate e = rbe::estimate(grid, belief);
  return choose_turn(s, h, sums, {e.mean_x, e.mean_y});
}

std::vector<double> prior_belief(const Scenario& s, const rbe::Grid& grid) {
  std::vector<double> b(static_cast<std::size_t>(grid.cells()));
  for (std::int64_t iy = 0; iy < grid.ny(); ++iy)
    for (std::int64_t ix = 0; ix < grid.nx(); ++ix) {
      const rbe::Point c = grid.centre(ix, iy);
      const double dx = (c.x - s.prior_x) / s.prior_sigma_x, dy = (c.y - s.prior_y) / s.prior_sigma_y;
      b[static_cast<std::size_t>(grid.index(ix, iy))] = std::exp(-0.5 * (dx * dx + dy * dy));
    }
  return b;
}

}  // namespace dtflop::sar
