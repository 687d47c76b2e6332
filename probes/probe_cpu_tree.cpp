// Host k-d tree work (L_tree): the cost of one step of building or searching a 2D k-d tree on
// one thread, the irregular host work (dependent loads and branches) that the DCT workload's
// matching does and that no FLOP rate or bandwidth prices. Measured as the matching does it: a
// nanoflann tree over n points (10 per leaf), then a search for the 2 nearest around each point,
// moved by under half the spacing; the time of a repetition over its steps, counted by the
// convention the workloads count them with (tree_build_steps, tree_search_steps in
// model/cost_counts.hpp), gives L_tree: the median over several placements of the thread
// (probes/placements.hpp), whose spread is the parameter's.
#include <cstdint>
#include <random>
#include <vector>

#include <fmt/format.h>
#include <nanoflann.hpp>

#include "model/cost_counts.hpp"
#include "probes/placements.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes {
namespace {

struct Cloud {
  const std::vector<double>* xy = nullptr;  // x0, y0, x1, y1, ...
  std::size_t kdtree_get_point_count() const { return xy->size() / 2; }
  double kdtree_get_pt(std::size_t i, std::size_t dim) const { return (*xy)[2 * i + dim]; }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const { return false; }
};
using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Cloud>, Cloud, 2, std::uint32_t>;

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  // About the dots of a 24 MP still (1600) and more, so the tree is a few levels deep.
  const std::int64_t n = 4096;
  const int reps = o.effort == Effort::full ? 11 : o.effort == Effort::quick ? 5 : 2;
  std::mt19937_64 rng(20261124);
  std::uniform_real_distribution<double> u(0, 6000);
  std::vector<double> pts(2 * n), queries(2 * n);
  for (auto& v : pts) v = u(rng);
  // The spacing of n random points in 6000 x 6000 is ~90 px: a shift of under 1 px keeps every
  // point its own nearest, which the check below relies on.
  std::uniform_real_distribution<double> jitter(-0.5, 0.5);
  for (std::size_t i = 0; i < pts.size(); ++i) queries[i] = pts[i] + jitter(rng);
  const std::int64_t steps = tree_build_steps(n) + n * tree_search_steps(n, 2);

  // One placement: a warm-up pass, then the median of `reps` timed passes, a step each.
  auto one_placement = [&] {
    return median_seconds_per_step(reps, steps, [&](bool warm_up) {
      std::uint32_t idx[2];
      double d2[2];
      Cloud cloud{&pts};
      Tree tree(2, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(kKdTreeLeaf));
      std::int64_t own = 0;
      for (std::int64_t i = 0; i < n; ++i) {
        const double q[2] = {queries[2 * i], queries[2 * i + 1]};
        if (tree.knnSearch(q, 2, idx, d2) == 2 && idx[0] == static_cast<std::uint32_t>(i)) ++own;
      }
      // Every search must find the point it was moved from: the tree was built and searched.
      if (own != n && warm_up)
        throw ValidationError(fmt::format("{} of {} k-d tree searches found the point they started from", own, n));
    });
  };
  const Placed placed = on_placements(latency_placements(o.effort), one_placement);
  r.measurements.push_back(step_measurement(
      o, placed, reps, "tree", "one step of k-d tree work (build or search, one thread)", Param::L_tree,
      fmt::format("nanoflann: a tree over {} random points and a 2-nearest search around each, {} steps "
                  "(model/cost_counts.hpp)", n, steps),
      "k-d tree step"));
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_cpu_tree) {
  registry.add({"cpu-tree", "host k-d tree work: one step of a build or a search (nanoflann, one thread)", false, 27,
                dtflop::probes::run});
}
