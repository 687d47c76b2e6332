// The cache a process really gets: read bandwidth over a ladder of working-set sizes, and the
// size where it falls from the cache's plateau to the memory's (the "knee"). The system's
// figure (sysfs) says how large the last-level cache is; on a shared host (a VM whose L3 is
// shared with every other tenant) a process gets only part of it, and the model prices a
// working set by what it gets (docs/probe.md, cpu-memory; docs/model.md 2.4).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace dtflop::probes {

struct LadderPoint {
  std::int64_t bytes = 0;  // working set (> 0), ascending along a ladder
  double bandwidth = 0;    // bytes read per second over it (> 0)
};

struct CacheKnee {
  // The effective last-level cache: where the bandwidth crosses `threshold` on its way down
  // from the cache plateau, interpolated linearly in log size and log bandwidth between the
  // last ladder point at or above the threshold (`above`) and the next one (`below`). Empty when
  // the ladder shows no knee (`why` says why).
  std::optional<std::int64_t> bytes;
  std::int64_t above = 0;       // the largest ladder size still at or above the threshold
  std::int64_t below = 0;       // the next ladder size, the first below it
  double cache_plateau = 0;     // highest bandwidth of the ladder [B/s]
  double memory_plateau = 0;    // median bandwidth of its three largest sizes [B/s]
  double threshold = 0;         // sqrt(cache_plateau x memory_plateau) [B/s]
  std::string why;              // for an empty `bytes`: what the ladder lacked
};

// Plateaus no more than this far apart are one plateau: the ladder shows no cache.
inline constexpr double kMinPlateauRatio = 1.3;

// The knee rule (pure; tests/probes/test_cache_ladder.cpp): the cache plateau is the highest
// bandwidth of the ladder, the memory plateau the median of its three largest sizes'; with
// them at least kMinPlateauRatio apart, the threshold is their geometric mean; counting up from
// the cache plateau's point, `above` is the last point at or above it, and the knee is where
// the line from `above` to the next point crosses it (log size, log bandwidth), so that the
// estimate moves smoothly with the data rather than by a ladder step when one point sits at the
// threshold. No knee when the ladder has fewer than 5 points, the plateaus are closer than
// kMinPlateauRatio, the fall comes within the three largest sizes (no memory plateau beyond
// it), or a larger size climbs back above the threshold (no single knee). Throws
// std::invalid_argument when the points are not ascending in size or hold a non-positive or
// non-finite value.
CacheKnee find_cache_knee(std::span<const LadderPoint> ladder);

// The ladder's sizes: first x 2^(k / steps_per_octave) for k = 0, 1, ... while <= last, each
// rounded down to a multiple of 64 KiB (at least 64 KiB), then `last` itself unless the last
// step came within a quarter step of it. Throws std::invalid_argument unless
// 0 < first <= last and steps_per_octave >= 1.
std::vector<std::int64_t> ladder_sizes(std::int64_t first, std::int64_t last, int steps_per_octave);

}  // namespace dtflop::probes
