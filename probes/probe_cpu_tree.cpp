// Host k-d tree work (L_tree): the cost of one step of building or searching a 2D k-d tree on
// one thread, the irregular host work (dependent loads and branches) that the DCT workload's
// matching does and that no FLOP rate or bandwidth prices. Measured as the matching does it: a
// nanoflann tree over n points (10 per leaf), then a search for the 2 nearest around each point,
// moved by under half the spacing; the time of a repetition over its steps, counted by the
// convention the workloads count them with (tree_build_steps, tree_search_steps in
// model/cost_counts.hpp), gives L_tree: the median over several placements of the thread
// (probes/placements.hpp), whose spread is the parameter's. The same in trees of kTreeSmall points
// (built and searched one after another, enough of them to time) gives L_tree_small: a step in a
// tree that stays in the first-level cache, where the matching of a frame of a few hundred dots
// runs; a tree between the two sizes is priced between them (tree_large_steps).
#include <chrono>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <fmt/format.h>
#include <nanoflann.hpp>

#include "model/cost_counts.hpp"
#include "model/stats.hpp"
#include "probes/measure.hpp"
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

// `trees` trees of n random points each, and a query beside each point (moved by under a pixel, a
// hundredth of the points' spacing).
struct TreeSet {
  std::int64_t n = 0, trees = 0;
  std::vector<std::vector<double>> pts, queries;
};
TreeSet tree_set(std::int64_t n, std::int64_t trees, std::uint64_t seed) {
  TreeSet t{n, trees, {}, {}};
  std::mt19937_64 rng(seed);
  // Points spread so that their spacing is ~90 px whatever n (a 24 MP still's dots are ~100 px apart).
  const double side = 90.0 * std::sqrt(static_cast<double>(n));
  std::uniform_real_distribution<double> u(0, side), jitter(-0.5, 0.5);
  for (std::int64_t k = 0; k < trees; ++k) {
    std::vector<double> p(2 * n), q(2 * n);
    for (auto& v : p) v = u(rng);
    for (std::size_t i = 0; i < p.size(); ++i) q[i] = p[i] + jitter(rng);
    t.pts.push_back(std::move(p));
    t.queries.push_back(std::move(q));
  }
  return t;
}

// One timed pass over a set: build each tree and search around each of its points; the seconds a
// step (tree_build_steps + n tree_search_steps a tree). `check`: every search must find a nearest
// point no farther than the one its query was moved from (the trees were built and searched; two
// random points may lie closer than the move, so not necessarily that one).
double pass_per_step(const TreeSet& t, bool check) {
  std::uint32_t idx[2];
  double d2[2];
  std::int64_t own = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (std::int64_t k = 0; k < t.trees; ++k) {
    Cloud cloud{&t.pts[k]};
    Tree tree(2, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(kKdTreeLeaf));
    const auto& q = t.queries[k];
    const auto& p = t.pts[k];
    for (std::int64_t i = 0; i < t.n; ++i) {
      const double at[2] = {q[2 * i], q[2 * i + 1]};
      const double dx = at[0] - p[2 * i], dy = at[1] - p[2 * i + 1];
      if (tree.knnSearch(at, 2, idx, d2) == 2 && d2[0] <= dx * dx + dy * dy + 1e-12) ++own;
    }
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (check && own != t.n * t.trees)
    throw ValidationError(fmt::format("{} of {} k-d tree searches found a point as near as the one they started "
                                      "from", own, t.n * t.trees));
  return s / static_cast<double>(t.trees * (tree_build_steps(t.n) + t.n * tree_search_steps(t.n, 2)));
}

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  const int reps = o.effort == Effort::full ? 11 : o.effort == Effort::quick ? 5 : 2;
  // Large: a tree over more points than a 24 MP still has dots (1600), a few levels deep and past the
  // first-level cache. Small: trees that stay in it, as many as make a pass of the large one's steps.
  const TreeSet large = tree_set(kTreeLarge, 1, 20261124);
  const TreeSet small = tree_set(kTreeSmall, 2 * kTreeLarge / kTreeSmall, 20261128);

  // One placement: a warm-up pass of each, then the median of `reps` timed passes of each.
  std::vector<double> small_steps;
  auto one_placement = [&] {
    std::vector<double> big, little;
    for (int k = -1; k < reps; ++k) {  // k = -1: warm-up, untimed, checked
      const double b = pass_per_step(large, k < 0), l = pass_per_step(small, k < 0);
      if (k >= 0) {
        big.push_back(b);
        little.push_back(l);
      }
    }
    small_steps.push_back(summarize(little).median);
    return summarize(big).median;
  };
  const Placed placed = on_placements(latency_placements(o.effort), one_placement);
  const std::string how = fmt::format("time / steps (model/cost_counts.hpp), the median over {} of the median of {} each",
                                      describe_placements(placed.cpus), reps);
  r.measurements.push_back(time_measurement(
      "tree", "one step of k-d tree work (build or search, one thread)", placed.values, Param::L_tree,
      fmt::format("nanoflann: a tree over {} random points and a 2-nearest search around each; {}", kTreeLarge, how)));
  r.measurements.push_back(time_measurement(
      "tree-small", "one step of k-d tree work in a small tree (one thread)", small_steps, Param::L_tree_small,
      fmt::format("nanoflann: {} trees of {} random points, each built and searched around each point; {}",
                  small.trees, kTreeSmall, how)));
  const Stats& st = r.measurements[0].stats;
  o.say(fmt::format("  k-d tree step: {:.1f} ns in a tree of {} points (placements {:.1f} .. {:.1f} ns), {:.1f} ns in "
                    "trees of {}",
                    r.measurements[0].value * 1e9, kTreeLarge, st.min * 1e9, st.max * 1e9,
                    r.measurements[1].value * 1e9, kTreeSmall));
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_cpu_tree) {
  registry.add({"cpu-tree", "host k-d tree work: one step of a build or a search (nanoflann, one thread)", false, 27,
                dtflop::probes::run});
}
