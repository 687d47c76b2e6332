// The host's grid matching (L_match): the cost of one step of the DCT workload's matching on one
// thread, a point binned into a grid of cells or a query answered from it with the matching's
// checks (kernels/point_grid.hpp: PointGrid and match_pass, the one source the workload runs).
// Measured as the matching does it: the dots of a 64 x 64 pattern (a pitch of 20 px, each dot
// moved by up to 3 px, in raster order as an analysis finds them) binned for a search radius of
// 0.4 pitches, each point's owner cleared, then each dot of the pattern moved again by up to 2 px
// proposes its nearest within the radius (unambiguous, unclaimed). The time of a repetition over
// its steps (one per dot binned, one per query) gives L_match: the median over several placements
// of the thread (probes/placements.hpp), whose spread is the parameter's.
#include <cstdint>
#include <random>
#include <vector>

#include <fmt/format.h>

#include "kernels/point_grid.hpp"
#include "probes/placements.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes {
namespace {

struct Point {
  double x = 0, y = 0;
};

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  // About the dots of a 24 MP still (1600) and more, as cpu-tree.
  constexpr int kSide = 64;
  constexpr double kPitch = 20;
  const std::int64_t n = kSide * kSide;
  const int reps = o.effort == Effort::full ? 31 : o.effort == Effort::quick ? 11 : 3;
  std::mt19937_64 rng(20261129);
  std::uniform_real_distribution<double> placed(-3, 3), moved(-2, 2);
  std::vector<Point> dots, queries;
  dots.reserve(static_cast<std::size_t>(n));
  queries.reserve(static_cast<std::size_t>(n));
  for (int y = 0; y < kSide; ++y)
    for (int x = 0; x < kSide; ++x) {
      const Point d{kPitch * (x + 1) + placed(rng), kPitch * (y + 1) + placed(rng)};
      dots.push_back(d);
      queries.push_back({d.x + moved(rng), d.y + moved(rng)});
    }
  // Neighbours are at least 20 - 2 x 3 = 14 px apart; a query is within sqrt(8) < 3 px of its own
  // dot and so more than 11 px from any other: it finds its own dot alone within 8 px.
  const double radius = 0.4 * kPitch;
  const std::int64_t steps = 2 * n;

  // One placement: a warm-up pass, then the median of `reps` timed passes, a step each. Each pass
  // builds the grid afresh, as the matching does every frame.
  auto one_placement = [&] {
    // Kept between one placement's passes, as the workload's Matcher keeps its own.
    kernels::PointGrid grid;
    std::vector<int> which(static_cast<std::size_t>(n)), match, owner;
    std::vector<kernels::MatchLoss> loss;
    std::vector<double> owner_d;
    for (std::size_t i = 0; i < which.size(); ++i) which[i] = static_cast<int>(i);
    return median_seconds_per_step(reps, steps, [&](bool warm_up) {
      grid.build(dots.data(), dots.size(), radius);
      match.assign(dots.size(), -1);
      loss.assign(dots.size(), kernels::MatchLoss::nothing_near);
      owner.assign(dots.size(), -1);
      owner_d.assign(dots.size(), 0);
      kernels::match_pass(grid, which.data(), queries.data(), queries.size(), 1.5, match.data(), loss.data(),
                          owner.data(), owner_d.data());
      if (warm_up) {
        // Every query must find its own dot, unambiguous: the grid was built and searched.
        std::int64_t own = 0;
        for (std::size_t i = 0; i < dots.size(); ++i)
          own += match[i] == static_cast<int>(i) && loss[i] == kernels::MatchLoss::none;
        if (own != n)
          throw ValidationError(fmt::format("{} of {} grid matches found the dot they started from", own, n));
      }
    });
  };
  const Placed at = on_placements(latency_placements(o.effort), one_placement);
  r.measurements.push_back(step_measurement(
      o, at, reps, "match", "one step of the grid matching (a dot binned or a query answered, one thread)",
      Param::L_match,
      fmt::format("kernels/point_grid.hpp: {} dots of a {}x{} pattern binned and each matched (nearest within {} px, "
                  "unambiguous, unclaimed), {} steps", n, kSide, kSide, radius, steps),
      "grid matching step"));
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_cpu_match) {
  registry.add({"cpu-match", "the host's grid matching: one step, a dot binned or a query answered (one thread)", false,
                27, dtflop::probes::run});
}
