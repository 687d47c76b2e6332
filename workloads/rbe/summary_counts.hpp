// Exact cost counts of Backend::summarize: the estimate (estimate.hpp: mean, covariance, MAP,
// entropy, mass) and the footprint sums a search control reads, computed where the belief lives.
// The code sits in estimate.cpp (the host's float64 reference, which the CPU backends and
// cuda-seed run on their belief()) and cuda_summary.cu (cuda-resident). tests/workloads/rbe/
// test_rbe_summary.cpp checks them against formulas written out by hand; docs/rbe.md derives them.
//
// Notation: n = n_g cells; P points; W_j the cells of point j's window (footprint_window), W =
// sum_j W_j; L = kLogExpFlops. Every cell is counted as holding belief (a zero cell skips the log
// of the entropy and the second pass's terms on the host, so these are the counts of a belief
// with no zero cell: an upper bound otherwise).
// Host (cpu-seq, cpu-par, cuda-seed; float64, P = 8, one thread):
//   the belief: cpu-seq reads its float64 belief where it is; cuda-seed first converts its
//              float32 host belief (N_CC = n + ceil(n / 2)); cpu-par also scales it (N_C = n).
//   estimate:  N_C = n kHostEstimateFlops + kHostEstimateFinish, N_CC = 2 n (two passes: the
//              mean, then the centred moments and p ln p)
//   footprints: N_C = W kHostFootprintFlops, N_CC = W
// cuda-resident (the belief stays on the device; float64 arithmetic on float32 values: precision
// fp64, P = 4, so a double is 2 values): one buffer of 9 + P doubles is zeroed (N_GG = 2 (9 + P));
//   estimate kernel: B = fusion_blocks(n) blocks of kFusionThreads threads; each cell's raw
//              moments about the grid's centre and w ln w, accumulated in float64:
//              N_G = n kDeviceEstimateFlops; N_GG = n (the belief read) + 16 B (each block's 7
//              atomic additions and one atomic maximum, 2 values each) + 4 (one thread copies the
//              pending normalization beside them); atomics 8 B; launches 1; waves ceil(B / S)
//   footprint kernel (only when P > 0): the point table goes up (8 values a point in one copy:
//              N_CG = 8 P, transfers_CG 1); Bf = ceil(max_j W_j / (kFusionThreads kFusionCells))
//              blocks per point: N_G = W kDeviceFootprintFlops, N_GG = W + 2 Bf P, atomics Bf P,
//              launches 1, waves ceil(Bf P / S)
//   back: one copy of 9 + P doubles (N_GC = 2 (9 + P), copies_GC {8 (9 + P) bytes, 1}), host
//              waits 1; the host finishes (N_C = kDeviceSummaryFinish + 1 + P: the estimate from
//              the sums, then the footprints' scale peak / S and P multiplications).
#pragma once

#include <cstdint>
#include <span>

#include "model/cost_counts.hpp"
#include "workloads/rbe/estimate.hpp"
#include "workloads/rbe/grid.hpp"

namespace dtflop::rbe {

// FLOPs are the operations the code writes (a cell's centre (i + 0.5) d + min is 3), a log or exp
// counted as kLogExpFlops.
// The host's estimate (estimate.cpp), per cell: first pass p = b A_c, the centre, m += p and two
// products with their sums (12); second pass p = b A_c / m, the centre, the offsets, the three
// covariance products with their sums, p ln p and its sum (21 + a log).
inline constexpr std::int64_t kHostEstimateFlops = 33 + 13;
// ... once the sums are taken: two means, the MAP cell's centre.
inline constexpr std::int64_t kHostEstimateFinish = 8;
// A footprint on the host (footprint_sums), per cell: the centre (6), the distance (two
// differences and hypot: 6), the exponent -d d / (2 s s) (4), exp, peak x, b x A_c x, the sum (3).
inline constexpr std::int64_t kHostFootprintFlops = 19 + 13;
// cuda-resident's moments kernel, per cell: the centre about the grid's centre (6), w x and w y
// (2), three second-moment products (3), six sums (6), w ln w and its sum (2 + a log).
inline constexpr std::int64_t kDeviceEstimateFlops = 19 + 13;
// Its footprint kernel, per cell: the offsets from the point (8), the squared distance (3), the
// exponent's product (1), exp, the product with the cell's value and the sum (2).
inline constexpr std::int64_t kDeviceFootprintFlops = 14 + 13;
// The host's FLOPs from cuda-resident's sums to the estimate: two means and their offsets (4),
// three covariances (9), the entropy (a log, a division, a subtraction), the mass (1), the MAP
// cell's centre (6).
inline constexpr std::int64_t kDeviceSummaryFinish = 22 + 13;

// How a host backend's belief() makes its float64 copy.
enum class BeliefCopy {
  in_place,        // cpu-seq: none, its float64 belief is read where it is
  float32,         // cuda-seed: a conversion
  float32_scaled,  // cpu-par: a conversion and a multiplication by the pending scale
};

// The total and the largest of the windows of `at` (footprint_window).
struct WindowCells {
  std::int64_t total = 0;
  std::int64_t largest = 0;
};
WindowCells window_cells(const Grid& grid, const Footprint& f, std::span<const Point> at);

// Throw InputError for a bad footprint or point (check_footprint), or sms < 1.
CostCounts host_summary_counts(const Grid& grid, const Footprint& f, std::span<const Point> at, BeliefCopy copy);
CostCounts cuda_resident_summary_counts(const Grid& grid, const Footprint& f, std::span<const Point> at, int sms);

}  // namespace dtflop::rbe
