// cuda-bands: one grid split into horizontal bands over several GPUs (or several partitions of
// one GPU), each band stepped by cuda-resident's fused kernel, the halo rows exchanged with the
// neighbours every step and the correction's sum combined by an all-reduce (cuda_bands.cu,
// docs/rbe.md "cuda-bands"). Here: the partition, the launches of a band and the exact counts,
// pure functions of the sizes (no device), checked by tests/workloads/rbe/test_rbe_bands.cpp
// against formulas written out by hand.
#pragma once

#include <cstdint>
#include <vector>

#include "model/cost_counts.hpp"
#include "workloads/rbe/backend.hpp"
#include "workloads/rbe/backend_counts.hpp"

namespace dtflop::rbe {

// At most this many partitions (bands) of one grid.
inline constexpr int kMaxPartitions = 64;
// Steps per segment of a cuda-bands run: the sums of a segment come back in one copy.
inline constexpr std::int64_t kBandSegment = 1000;

// One band: rows [first, first + rows) of the grid.
struct Band {
  std::int64_t first = 0;
  std::int64_t rows = 0;
};

// The grid's n_y rows in G bands, the first n_y mod G one row taller than the others
// (floor(n_y / G) + 1, then floor(n_y / G)). An output row y reads rows y - h_b .. y + h_a of
// the prediction's input (h_b = I_y - 1 - c rows before it, h_a = c after it, c the kernel's
// centre, motion.hpp): a band holds its own rows with h_b halo rows above and h_a below, which
// its neighbours send every step (zeros at the grid's edges). Every band must be at least
// max(h_b, h_a) rows tall, so that a halo comes from the next band alone.
struct BandPlan {
  std::vector<Band> bands;
  std::int64_t halo_before = 0;  // h_b
  std::int64_t halo_after = 0;   // h_a
  std::int64_t ld = 0;           // row pitch of the band buffers (floats): n_x rounded up to 4
  std::int64_t partitions() const { return static_cast<std::int64_t>(bands.size()); }
  // Rows of band b's buffer: h_b + rows + h_a.
  std::int64_t buffer_rows(std::size_t b) const { return halo_before + bands[b].rows + halo_after; }
};
// Throws InputError, saying what to do, for partitions outside [1, kMaxPartitions], more
// partitions than rows, or a band lower than the kernel's half-width.
BandPlan band_plan(const Shape& s, int partitions);

// Band-local output rows [begin, end) of one kernel launch.
struct RowRange {
  std::int64_t begin = 0;
  std::int64_t end = 0;
  std::int64_t rows() const { return end - begin; }
  bool operator==(const RowRange&) const = default;
};
// The launches of band b in one step. `edges`: the max(h_b, h_a) rows next to each neighbour,
// which hold the rows that read its halo and the rows sent to it, computed first once the halo
// has arrived; `inner`: the rest (the side towards a grid edge included), computed while the
// next step's halos travel. When a band is too low to have inner rows, `inner` is empty and
// `edges` is one launch of all its rows.
struct BandLaunches {
  std::vector<RowRange> inner;
  std::vector<RowRange> edges;
};
BandLaunches band_launches(const BandPlan& plan, std::size_t band);

// The halo messages band b sends each step: up to band b - 1 (its first h_a rows, when b > 0
// and h_a > 0) and down to band b + 1 (its last h_b rows, when b < G - 1 and h_b > 0); whole
// pitched rows, ld floats each.
struct HaloSends {
  std::int64_t messages = 0;
  std::int64_t values = 0;
};
HaloSends halo_sends(const BandPlan& plan, std::size_t band);

// How the partitions are placed: `gpus` GPUs; one partition per GPU (messages over the link,
// NCCL) or every partition on one GPU (PeerPath::device: copies inside its memory).
struct BandPlacement {
  int partitions = 1;
  int gpus = 1;
  PeerPath path = PeerPath::link;
};
// From the options: gpus 0 = every GPU this process sees (1 where it sees none: counts for
// a machine not at hand), partitions 0 = one per GPU. Throws InputError unless partitions ==
// gpus or gpus == 1 (other placements are not built), or for values out of range.
BandPlacement band_placement(const BackendOptions& options);
// The same from explicit values, without looking at this machine (0 is not allowed).
BandPlacement band_placement(int partitions, int gpus);

// The counts of one launch of cuda-resident's fused kernel over `rows` output rows of a grid
// n_x wide (cuda_resident_counts' fused formulas with B = ceil((n_x + shift) / W) ceil(rows / H)
// blocks and rows x n_x cells): launches 1, waves q(B), atomics B,
//   N_G = q(B) S [2 I_x W (H + I_y - 1) + (2 I_y + 3) W H + 2],
//   N_GG = 3 rows n_x + I_x + I_y + 2 + 2 B,  N_GS = ceil(q(B) / occ) S [(H + I_y - 1)(W + kx) + kx + ky].
CostCounts fused_rows_counts(const Shape& s, const Layout& layout, int sms, std::int64_t rows);

// One steady-state step of cuda-bands, counted on its busiest device: each count is the
// largest over the devices (the step waits for the slowest). A device's counts:
//   its bands' launches (fused_rows_counts of each range of band_launches());
//   link: peer_messages, N_peer = halo_sends() of its band; collectives = 1 (G > 1),
//         collective_bytes = 8 (the sum, one float64);
//   G > 1: each band's scale kernel (the lagged normalization, cuda_bands.cu): launches 1,
//         N_GG 12 (six float64 values);
//   device (every band on one GPU): the launches of all bands; every band's halo_sends() (a
//         device-to-device copy each); collectives = G reduction kernels (G > 1), each reading
//         the G partial sums and writing the total: collective_bytes = 8 G (G + 1).
// G = 1 is cuda-resident's step without a graph: no messages, no all-reduce.
// Throws InputError when the layout needs the split passes (cuda-bands runs the fused kernel).
CostCounts cuda_bands_counts(const Shape& s, const Layout& layout, int sms, const BandPlacement& placement);
// A run of `steps` steps in segments of `segment` steps: per segment and band, the segment's
// partial sums zeroed (2 n values) and two 8-byte device copies (the last total carried in and
// out, 4 values each, read + write); band 0 copies the segment's totals (G > 1: evidences) to
// the host (one copy of 2 n values, pinned) and the host waits once for the segment. G > 1, per
// segment of m steps and band: a third copy (E_1 = T_0, 4 values) and m + 1 scale kernels moving
// 6m - 1 float64 values (4 for m = 1) where the steps count m kernels and 6m.
CostCounts cuda_bands_run_counts(const Shape& s, const Layout& layout, int sms, const BandPlacement& placement,
                                 std::int64_t steps, std::int64_t segment = kBandSegment);

}  // namespace dtflop::rbe
