#include "probes/cache_ladder.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

namespace dtflop::probes {

namespace {

std::string mib(std::int64_t bytes) { return fmt::format("{:.1f} MiB", static_cast<double>(bytes) / (1 << 20)); }

}  // namespace

CacheKnee find_cache_knee(std::span<const LadderPoint> ladder) {
  for (std::size_t i = 0; i < ladder.size(); ++i) {
    const auto& p = ladder[i];
    if (p.bytes <= 0 || !(p.bandwidth > 0) || !std::isfinite(p.bandwidth))
      throw std::invalid_argument(fmt::format("cache ladder point {}: {} bytes at {} B/s; both must be positive and finite",
                                              i, p.bytes, p.bandwidth));
    if (i > 0 && p.bytes <= ladder[i - 1].bytes)
      throw std::invalid_argument(fmt::format("cache ladder point {}: {} bytes after {}; sizes must ascend", i, p.bytes,
                                              ladder[i - 1].bytes));
  }
  CacheKnee k;
  const std::size_t n = ladder.size();
  if (n < 5) {
    k.why = fmt::format("a ladder of {} sizes is too short to show two plateaus (5 at least)", n);
    return k;
  }
  std::size_t top = 0;
  for (std::size_t i = 1; i < n; ++i)
    if (ladder[i].bandwidth > ladder[top].bandwidth) top = i;
  double tail[3] = {ladder[n - 3].bandwidth, ladder[n - 2].bandwidth, ladder[n - 1].bandwidth};
  std::sort(tail, tail + 3);
  k.cache_plateau = ladder[top].bandwidth;
  k.memory_plateau = tail[1];
  k.threshold = std::sqrt(k.cache_plateau * k.memory_plateau);
  if (k.cache_plateau < kMinPlateauRatio * k.memory_plateau) {
    k.why = fmt::format("the highest bandwidth ({:.3g} GB/s) is within {:.1f}x of the largest sizes' ({:.3g} GB/s): "
                        "no step from a cache to memory between {} and {}",
                        k.cache_plateau / 1e9, kMinPlateauRatio, k.memory_plateau / 1e9, mib(ladder.front().bytes),
                        mib(ladder.back().bytes));
    return k;
  }
  std::size_t knee = top;
  while (knee + 1 < n && ladder[knee + 1].bandwidth >= k.threshold) ++knee;
  if (knee + 3 >= n) {
    k.why = fmt::format("the bandwidth falls below {:.3g} GB/s only after {}, among the ladder's three largest sizes: "
                        "no memory plateau beyond it",
                        k.threshold / 1e9, mib(ladder[knee].bytes));
    return k;
  }
  for (std::size_t i = knee + 2; i < n; ++i)
    if (ladder[i].bandwidth >= k.threshold) {
      k.why = fmt::format("the bandwidth falls below {:.3g} GB/s after {} but climbs back above it at {}: no single knee",
                          k.threshold / 1e9, mib(ladder[knee].bytes), mib(ladder[i].bytes));
      return k;
    }
  const LadderPoint& a = ladder[knee];
  const LadderPoint& b = ladder[knee + 1];
  k.above = a.bytes;
  k.below = b.bytes;
  // a.bandwidth >= threshold > b.bandwidth, so f is in [0, 1).
  const double f = std::log(a.bandwidth / k.threshold) / std::log(a.bandwidth / b.bandwidth);
  const double bytes = static_cast<double>(a.bytes) * std::pow(static_cast<double>(b.bytes) / static_cast<double>(a.bytes), f);
  k.bytes = std::clamp(static_cast<std::int64_t>(std::llround(bytes)), a.bytes, b.bytes);
  return k;
}

std::vector<std::int64_t> ladder_sizes(std::int64_t first, std::int64_t last, int steps_per_octave) {
  if (first <= 0 || last < first || steps_per_octave < 1)
    throw std::invalid_argument(fmt::format("ladder_sizes({}, {}, {}): need 0 < first <= last and steps >= 1", first,
                                            last, steps_per_octave));
  constexpr std::int64_t kGrain = 64 << 10;
  std::vector<std::int64_t> out;
  const double step = std::exp2(1.0 / steps_per_octave);
  for (int k = 0;; ++k) {
    const double s = static_cast<double>(first) * std::exp2(static_cast<double>(k) / steps_per_octave);
    if (s > static_cast<double>(last)) break;
    const std::int64_t b = std::max(kGrain, static_cast<std::int64_t>(s) / kGrain * kGrain);
    if (out.empty() || b > out.back()) out.push_back(b);
  }
  const std::int64_t l = std::max(kGrain, last / kGrain * kGrain);
  if (static_cast<double>(l) > static_cast<double>(out.back()) * std::pow(step, 0.25)) out.push_back(l);
  return out;
}

}  // namespace dtflop::probes
