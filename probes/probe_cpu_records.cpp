// The host's pass over a GPU labelling's component records (L_record): the DCT workload's cuda
// backend reads back one record per labelled component and, on one thread, tallies each, orders
// them by their roots (a radix sort, a byte a pass) and hands the kept ones on as dots
// (kernels/component_records.hpp, the one source the workload runs). Measured as the backend does
// it: 4096 records of a 2048 x 2048 region (roots scattered over it, as the device leaves them in
// the order its blocks finished; 3 radix passes), nine in ten kept, each kept record copied into a
// dot, the records evicted from the CPU's caches before each pass (a device copy just wrote them).
// The time of a repetition over its record steps gives L_record: the median over several
// placements of the thread (probes/placements.hpp), whose spread is the parameter's.
#include <algorithm>
#include <cstdint>
#include <random>
#include <unordered_set>
#include <vector>

#include <fmt/format.h>

#include "kernels/component_records.hpp"
#include "probes/placements.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes {
namespace {

struct Dot {  // what the workload makes of a kept record: a centroid, its weight and area
  double x = 0, y = 0, weight = 0;
  int area = 0;
};

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  constexpr int kRecords = 4096;
  constexpr std::int64_t kSide = 2048, kRegion = kSide * kSide;
  const int reps = o.effort == Effort::full ? 31 : o.effort == Effort::quick ? 11 : 3;
  std::mt19937_64 rng(20261129);
  // Distinct roots scattered over the region; x, y, weight and area as a centroid kernel leaves them.
  std::vector<int> root(kRecords), status(kRecords), area(kRecords), pixels(3 * kRecords);
  std::vector<double> x(kRecords), y(kRecords), weight(kRecords);
  std::uniform_int_distribution<std::int64_t> anywhere(0, kRegion - 1);
  std::uniform_int_distribution<int> dot_area(20, 400), tenth(0, 9);
  std::unordered_set<std::int64_t> seen;
  for (int k = 0; k < kRecords; ++k) {
    std::int64_t at = anywhere(rng);
    while (!seen.insert(at).second) at = anywhere(rng);
    root[k] = static_cast<int>(at);
    x[k] = static_cast<double>(at % kSide) + 0.5;
    y[k] = static_cast<double>(at / kSide) + 0.5;
    area[k] = dot_area(rng);
    weight[k] = 255.0 * area[k];
    status[k] = tenth(rng) == 0 ? 1 + tenth(rng) % 4 : 0;  // one in ten rejected, for one of four reasons
    pixels[3 * k] = 2 * area[k];
    pixels[3 * k + 1] = area[k] / 2;
    pixels[3 * k + 2] = area[k];
  }
  std::vector<int> want;  // the kept records in the order of their roots, as the pass must hand them on
  for (int k = 0; k < kRecords; ++k)
    if (status[k] == 0) want.push_back(k);
  std::sort(want.begin(), want.end(), [&](int a, int b) { return root[a] < root[b]; });
  const kernels::RecordColumns cols{status.data(), area.data(), root.data(), pixels.data(), kRecords};
  const std::int64_t steps = kernels::record_steps(kRecords, kRegion);

  // The records arrive by a device copy, so they are in none of the CPU's caches when the pass starts:
  // each pass starts with them evicted (untimed), where the architecture allows it.
  bool evicted = true;
  auto evict = [&] {
    evicted = evict_from_caches(root.data(), root.size() * sizeof(int)) &&
              evict_from_caches(status.data(), status.size() * sizeof(int)) &&
              evict_from_caches(area.data(), area.size() * sizeof(int)) &&
              evict_from_caches(pixels.data(), pixels.size() * sizeof(int)) &&
              evict_from_caches(x.data(), x.size() * sizeof(double)) &&
              evict_from_caches(y.data(), y.size() * sizeof(double)) &&
              evict_from_caches(weight.data(), weight.size() * sizeof(double));
  };
  // One placement: a warm-up pass (which checks the order), then the median of `reps` timed passes,
  // a step each. The buffers are kept from pass to pass, as the backend keeps its own.
  auto one_placement = [&] {
    std::vector<int> order, scratch;
    std::vector<Dot> dots;
    std::vector<int> comp_of_dot;
    kernels::RecordTally tally;
    return median_seconds_per_step(reps, steps, [&](bool warm_up) {
      dots.clear();
      comp_of_dot.clear();
      kernels::order_records(cols, kRegion, tally, order, scratch, [&](int k) {
        dots.push_back({x[k], y[k], weight[k], area[k]});
        comp_of_dot.push_back(k);
      });
      if (warm_up && comp_of_dot != want)
        throw ValidationError(fmt::format("the pass handed on {} dots, not the {} kept records in the order of their roots",
                                          comp_of_dot.size(), want.size()));
    }, evict);
  };
  const Placed at = on_placements(latency_placements(o.effort), one_placement);
  r.measurements.push_back(step_measurement(
      o, at, reps, "record", "one step of the host's pass over component records (one thread)", Param::L_record,
      fmt::format("kernels/component_records.hpp: {} records of a {}x{} region tallied, ordered by their roots in {} "
                  "radix passes and the kept ones ({}) handed on as dots, {} steps, the records {} before each pass",
                  kRecords, kSide, kSide, kernels::radix_passes(kRegion), want.size(), steps,
                  evicted ? "evicted from the CPU's caches" : "in the caches (this architecture cannot evict them)"),
      "component record step"));
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_cpu_records) {
  registry.add({"cpu-records", "the host's pass over a GPU labelling's component records: one step (one thread)", false,
                27, dtflop::probes::run});
}
