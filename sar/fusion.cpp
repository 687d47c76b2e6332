#include "sar/fusion.hpp"

#include <cmath>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "sar/world.hpp"
#include "workloads/rbe/backend.hpp"

namespace dtflop::sar {

std::vector<double> loglinear_pool(const rbe::Grid& grid, std::span<const std::vector<double>> beliefs) {
  if (beliefs.empty()) throw InputError("log-linear pool: needs at least one belief");
  for (std::size_t p = 0; p < beliefs.size(); ++p)
    if (static_cast<std::int64_t>(beliefs[p].size()) != grid.cells())
      throw InputError(fmt::format("log-linear pool: belief {} has {} cells, the grid {}", p, beliefs[p].size(),
                                   grid.cells()));
  const double w = 1.0 / double(beliefs.size());
  const std::size_t n = beliefs[0].size();
  std::vector<double> logs(n, 0.0);
  std::vector<char> zero(n, 0);
  for (const auto& b : beliefs)
    for (std::size_t i = 0; i < n; ++i) {
      if (!(b[i] > 0)) zero[i] = 1;
      else logs[i] += w * std::log(b[i]);
    }
  // Shift by the largest log so that exp() neither underflows everywhere nor overflows.
  double top = -INFINITY;
  for (std::size_t i = 0; i < n; ++i)
    if (!zero[i]) top = std::max(top, logs[i]);
  if (!std::isfinite(top))
    throw rbe::NumericalError(0, fmt::format("log-linear pool: the {} beliefs do not overlap (every cell is zero in "
                                             "some belief); fuse more often",
                                             beliefs.size()));
  std::vector<double> out(n, 0.0);
  double sum = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (!zero[i]) sum += out[i] = std::exp(logs[i] - top);
  const double z = sum * grid.cell_area();
  for (double& v : out) v /= z;
  return out;
}

std::vector<float> to_wire(std::span<const double> belief) {
  std::vector<float> w(belief.size());
  for (std::size_t i = 0; i < belief.size(); ++i) w[i] = static_cast<float>(belief[i]);
  return w;
}

std::vector<double> from_wire(std::span<const float> wire) {
  std::vector<double> b(wire.size());
  for (std::size_t i = 0; i < wire.size(); ++i) b[i] = wire[i];
  return b;
}

bool fuses_beliefs(const Scenario& s, std::int64_t step) {
  return (s.rule == Rule::belief || s.rule == Rule::loglinear) && step % s.interval == 0;
}

Traffic traffic(const Scenario& s, std::int64_t team, std::int64_t step) {
  Traffic t;
  if (team < 2) return t;
  if (s.rule == Rule::observation) {
    t.messages = team - 1;
    t.bytes = (team - 1) * kObservationBytes;
  } else if (fuses_beliefs(s, step)) {
    t.messages = team - 1;
    t.bytes = (team - 1) * s.nx * s.ny * std::int64_t{4};
  }
  return t;
}

MeanTraffic mean_traffic(const Scenario& s, std::int64_t team) {
  MeanTraffic m;
  if (team < 2) return m;
  if (s.rule == Rule::observation) {
    m.messages = double(team - 1);
    m.bytes = double((team - 1) * kObservationBytes);
  } else if (s.rule == Rule::belief || s.rule == Rule::loglinear) {
    m.messages = double(team - 1) / double(s.interval);
    m.bytes = double((team - 1) * s.nx * s.ny * 4) / double(s.interval);
  }
  return m;
}

double link_delay(const Scenario& s, const Traffic& t) {
  if (!s.link_enabled) return 0;
  return double(t.messages) * s.latency_ms * 1e-3 + 8.0 * double(t.bytes) / (s.bandwidth_mbps * 1e6);
}

}  // namespace dtflop::sar
