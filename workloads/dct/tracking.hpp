// Tracking (seed 6.2, eq. 6.3): match each reference dot to a dot of the deformed frame,
// through a grid of cells over the frame's dots (kernels/point_grid.hpp). Dots lost or appearing are reported, never mismatched
// silently: a match is accepted only if it is the nearest dot around the predicted position,
// inside the search radius, unambiguous (the second-nearest is clearly farther), and no other
// reference dot claims the same deformed dot.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "kernels/point_grid.hpp"
#include "model/cost_counts.hpp"  // tree_build_steps, tree_search_steps
#include "workloads/dct/specimen.hpp"

namespace dtflop::dct {

// A 2D k-d tree over a set of points (nanoflann), for k-nearest searches (the matching's second
// pass, the support domains, stereo). The points must outlive the index.
class PointIndex {
 public:
  explicit PointIndex(const std::vector<Vec2>& points);
  ~PointIndex();
  PointIndex(const PointIndex&) = delete;
  PointIndex& operator=(const PointIndex&) = delete;
  // The k nearest points (fewer if the set is smaller), nearest first: indices and squared
  // distances.
  void knn(Vec2 q, int k, std::vector<std::uint32_t>& idx, std::vector<double>& d2) const;
  // All points within `radius`, nearest first.
  void within(Vec2 q, double radius, std::vector<std::pair<std::uint32_t, double>>& out) const;
  std::size_t size() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Median distance from each point to its nearest neighbour (0 for fewer than 2 points).
double median_spacing(const std::vector<Vec2>& points);

struct MatchOptions {
  double search_radius = 0;   // px; 0 = 0.4 x the reference dots' median spacing
  double ambiguity = 1.5;     // the second-nearest must be >= this x the nearest's distance
  int refine_neighbours = 6;  // second pass: predict lost dots from this many matched neighbours
};

using LostReason = kernels::MatchLoss;  // none, nothing_near, ambiguous, claimed_by_other

struct Matches {
  std::vector<int> ref_to_def;          // per reference dot: deformed index, or -1
  std::vector<LostReason> lost_reason;  // per reference dot
  std::vector<int> appeared;            // deformed dots no reference dot matched
  int matched = 0;
  double search_radius = 0;             // what was used
  std::int64_t tree_steps = 0;          // k-d tree work done (match_work)
  std::int64_t match_steps = 0;         // grid work done (match_work)
  std::string summary() const;          // "1598 of 1600 matched, 2 lost (...), 1 appeared"
};

// The work of match_dots, counted before it runs. The matching bins the `deformed` dots into a
// grid and each reference dot asks it for its nearest two within the search radius, then the
// `retried` dots ask again: match_steps = deformed + reference + retried (one step per dot binned
// and per query answered: kernels/point_grid.hpp). The rest is k-d tree work, in tree_steps: for
// the `refined` dots lost in the first pass, a tree over the reference and a search for each
// one's 2 refine_neighbours + 1 nearest; without a search radius given, first a tree over the
// reference (2 or more dots), each asking for its 2 nearest, to find one.
// (tree_build_steps and tree_search_steps: model/cost_counts.hpp; PointIndex has 10 points per leaf.)
struct MatchWork {
  std::int64_t tree_steps = 0;
  std::int64_t match_steps = 0;
  bool operator==(const MatchWork&) const = default;
};
MatchWork match_work(std::int64_t reference, std::int64_t deformed, std::int64_t refined = 0, std::int64_t retried = 0,
                     int refine_neighbours = 6, bool radius_given = true);

// Matches frames' dots to a reference, keeping its grid and working buffers from one frame to the
// next: a frame's matching then allocates only its result (and, when a dot was lost, what the
// second pass needs). (Allocated afresh, the buffers of a
// few thousand dots went back to the system and faulted in again on every call, which tripled
// the matching's time from 3000 dots on the 2-vCPU VM.)
class Matcher {
 public:
  // `predicted` (optional, one per reference dot) is where each dot is expected in the
  // deformed frame, e.g. its position in the previous frame; empty = the reference position.
  Matches match(const std::vector<Vec2>& reference, const std::vector<Vec2>& deformed, const MatchOptions& o,
                const std::vector<Vec2>& predicted = {});

 private:
  kernels::PointGrid grid_;
  std::vector<int> owner_, which_;
  std::vector<double> owner_d_;
  std::vector<Vec2> where_;
};

// One matching with a Matcher of its own.
Matches match_dots(const std::vector<Vec2>& reference, const std::vector<Vec2>& deformed,
                   const MatchOptions& o, const std::vector<Vec2>& predicted = {});

}  // namespace dtflop::dct
