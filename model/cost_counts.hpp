// CostCounts: what one run of a computation moves and computes, in the terms of the DTFLOP
// model (seed eqs. 3.3-3.9) plus the counts the extended model needs.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace dtflop {

enum class HostMemory { pageable, pinned };
enum class Precision { fp32, fp64 };
// Where the messages between the partitions of one grid travel (peer_messages, N_peer and the
// collectives): between GPUs (NCCL over NVLink or PCIe: L_peer, B_peer, L_allreduce,
// B_allreduce), or inside one device, partitions that share a GPU (device-to-device copies and a
// reduction kernel: L_launch, B_GG_copy, B_GG; docs/model.md 2.9).
enum class PeerPath { link, device };

std::string_view to_string(HostMemory m);
std::string_view to_string(Precision p);
std::string_view to_string(PeerPath p);

// `count` copies of `bytes` bytes each.
struct CopySize {
  std::int64_t bytes = 0;
  std::int64_t count = 0;
  bool operator==(const CopySize&) const = default;
};

struct CostCounts {
  int P = 4;                    // bytes per value
  Precision precision = Precision::fp32;  // which FLOP rates apply
  std::int64_t N_CG = 0;        // values host -> device
  std::int64_t N_GC = 0;        // values device -> host
  std::int64_t N_GG = 0;        // values moved through device memory (reads + writes)
  std::int64_t N_C = 0;         // FLOPs on the CPU
  std::int64_t N_G = 0;         // FLOPs on the GPU
  std::int64_t N_GR = 0;        // of N_G, the FLOPs of windows across rows: every tap reads its
                                // operand from device memory in another row than the previous
                                // tap's (a new cache line for each warp at every tap), where a
                                // window along a row re-reads the lines of the taps before it.
                                // Priced K_GR times a FLOP at V_G (latency+); 0 = none
  std::int64_t N_GW = 0;        // of N_G, the FLOPs of windows along a row read from device memory:
                                // a load (and its bounds test) per FMA, the warp's line re-read by
                                // the next tap. Priced K_GW times a FLOP at V_G (latency+, where the
                                // profile has K_GW); 0 = none
  std::int64_t N_CC = 0;        // values moved through host memory by CPU work (extended model)
  std::int64_t N_CC_pixel = 0;  // of N_CC, those of the passes priced as pixel steps (a frame's histogram,
                                // threshold, labelling and windows): where the profile prices the steps by
                                // kind, figures timed on such passes over memory, dt_CC leaves them out
  std::int64_t N_CW = 0;        // of N_C, the FLOPs of vectorized sliding-window loops, bound by
                                // their loads: a correlation along contiguous memory whose every
                                // vector FMA loads its operand one value on from the previous
                                // tap's (one unaligned load per FMA). Priced K_CW times a FLOP at
                                // the CPU rate (memory and extended variants). Loops bound by the
                                // FMA units or by chains of dependent additions are not counted
                                // here; 0 = none
  std::int64_t N_CD = 0;        // of N_C, the FLOPs of chained sliding-window loops: a correlation
                                // along contiguous memory with few outputs in flight (a group of
                                // 8 float64 accumulators, compiled for the baseline instruction
                                // set), so every tap's addition waits for the previous tap's.
                                // Priced K_CD times a FLOP at the CPU rate (memory and extended
                                // variants); 0 = none. A FLOP is in N_CW or N_CD, never both
  std::int64_t N_CA = 0;        // of N_C, the FLOPs of aligned vector windows: a correlation across
                                // rows whose every aligned row segment loaded feeds two FMAs (two
                                // output rows at once). Priced K_CA times a FLOP at the CPU rate
                                // (memory and extended variants); 0 = none
  std::int64_t N_CS = 0;        // of N_C, the FLOPs of one serial chain: a plain sum whose every
                                // addition waits for the one before (no other chain beside it).
                                // Priced at V_CS, the rate of such a chain (latency, memory and
                                // extended variants); 0 = none. Not also in N_CW or N_CD
  std::int64_t N_CM = 0;        // of N_C, the FLOPs of moving-least-squares fields on the CPU: per
                                // support dot of a point its Givens rotations, square roots and
                                // divisions, each waiting for the one before; per point the solves.
                                // Priced at V_CM (V_CM_all for cpu_threads > 1), the rate of that
                                // code (latency, memory and extended variants); 0 = none. Not also
                                // in N_CW, N_CD, N_CA or N_CS
  std::int64_t N_GM = 0;        // FLOPs of one GPU thread's moving-least-squares field: the mean point's
                                // support dots' rotations, square roots and divisions, each waiting
                                // for the one before, and its solves. The points' threads run side by
                                // side, so one point's chain, not the sum (which N_G holds), is the
                                // time: priced at V_GM (latency+, where the profile has it); 0 = none
  std::int64_t gpu_pixel_steps = 0;  // window pixels the device classifies per dot (each one's
                                // neighbourhood read in both passes of a dot's block): work that
                                // its blocks' branches and barriers bound, not the bytes in N_GG.
                                // Priced at L_GP (latency+, where the profile has it: the gpu-centroid
                                // probe or a fit gives it); 0 = none
  std::int64_t gpu_frame_pixels = 0;  // pixels the device's whole-frame passes visit, a thread a pixel
                                // each pass (a threshold, a labelling's unions, a histogram): light
                                // threads whose issue, not the bytes they move, bounds them. Priced
                                // at L_GF (latency+, where the profile has it: the gpu-frame-pass
                                // probe or a fit gives it); 0 = none
  std::int64_t N_GG_frame = 0;  // of N_GG, the values those passes move: where gpu_frame_pixels are
                                // priced, dt_GG leaves them out (L_GF is timed on such passes,
                                // their traffic included)
  std::int64_t N_GS = 0;        // values kernels copy from device memory into shared-memory tiles
                                // (halos included), counted per round of blocks on the busiest
                                // multiprocessor times the multiprocessors, like N_G (latency+)
  std::int64_t transfers_CG = 0;  // number of host->device copies
  std::int64_t transfers_GC = 0;  // number of device->host copies
  std::int64_t launches = 0;      // kernel launches
  std::int64_t graph_launches = 0;  // of launches, the kernels launched as nodes of a CUDA graph: the
                                    // device starts them one after another without the host (L_graph
                                    // each, latency+; the others L_launch)
  std::int64_t waves = 0;         // rounds of thread blocks the busiest multiprocessor runs,
                                  // summed over the kernels, as the backend counts them (e.g.
                                  // ceil(B / S) for B blocks on S multiprocessors, one at a time)
  std::int64_t atomics = 0;       // atomic updates of one device address that every block of a
                                  // kernel updates (a reduction's total): they serialize where the
                                  // address lives, one after another (latency+)
  std::int64_t host_waits = 0;    // times the host submits work to the device and waits for it
                                  // to finish (a graph launch and a synchronize), outside the
                                  // measured components: priced in the total only
  std::int64_t laps_CG = 0;       // host-timed laps of host->device copies: the host submits them
  std::int64_t laps_GC = 0;       // (device->host copies, kernels) and waits for them, and the
  std::int64_t laps_G = 0;        // measured component holds the wait (cuda-seed's phases):
                                  // each a submit-and-wake round trip the copies' and kernels'
                                  // device-side figures leave out (latency+, L_wait each)
  std::int64_t tree_steps = 0;    // steps of the CPU's k-d tree work (a point placed at one level of a build,
                                  // a level descended or a leaf point examined by a search): irregular
                                  // host work that no FLOP rate prices (latency+, L_tree each)
  std::int64_t match_steps = 0;   // steps of the CPU's grid matching (kernels/point_grid.hpp): one per point
                                  // binned into the grid and one per query answered from it (latency+,
                                  // L_match each)
  std::int64_t record_steps = 0;  // steps of the host's pass over a GPU labelling's component records
                                  // (kernels/component_records.hpp): a record tallied, placed by one
                                  // radix pass of its key, handed on (latency+, L_record each)
  std::int64_t pixel_steps = 0;   // steps of the CPU's scalar pixel work, one per pixel a scalar loop
                                  // visits (a histogram's count, a label decided, a window pixel
                                  // classified) and per label a neighbourhood scan reads: branchy
                                  // work on data in the caches that no FLOP rate or bandwidth prices
                                  // (latency+, L_pixel each)
  std::int64_t label_steps = 0;   // of pixel_steps, those of a labelling (a pixel thresholded and
                                  // given its 8-connected component, with the components' statistics)
  std::int64_t hist_steps = 0;    // of pixel_steps, a pixel counted into a histogram. Where the profile
                                  // has L_label, L_hist and L_scan (latency+): label_steps at L_label,
                                  // hist_steps at L_hist, the rest at L_scan; else all at L_pixel
  std::int64_t pixel_passes = 0;  // frames whose pixel steps run as passes over the frame: on several
                                  // threads each costs a fixed L_pass_all beside its steps (threads woken,
                                  // stripes merged), where the profile has it
  std::int64_t cpu_syncs = 0;     // times the CPU threads start together or wait for each other
                                  // (a parallel region's fork and join, a barrier)
  std::int64_t net_messages = 0;  // messages one process sends to others (MPI; L_net each)
  std::int64_t net_bytes = 0;     // payload bytes of those messages (over B_net)
  std::int64_t peer_messages = 0;  // halo messages the busiest device sends to the partitions of the
                                   // grid on other devices (or, on one device, copies between them)
  std::int64_t N_peer = 0;         // values (P bytes each) in those messages
  std::int64_t collectives = 0;    // all-reduces across the partitions (on one device: reduction
                                   // kernels, one per partition)
  std::int64_t collective_bytes = 0;  // bytes each all-reduce contributes per device (on one
                                      // device: the reduction kernels' reads and writes)
  HostMemory host_memory = HostMemory::pageable;
  PeerPath peer_path = PeerPath::link;  // where peer_messages, N_peer and the collectives travel
  int cpu_threads = 1;          // threads doing the CPU work
  std::vector<CopySize> copies_GC;  // the device->host copies by size (empty: not counted); their
                                   // bytes add up to P N_GC and their number to transfers_GC. A
                                   // pageable copy's staging cost depends on its size (latency+)
  std::int64_t gpu_footprint = 0;  // bytes of device memory the kernels of one step touch (their
                                   // working set; 0 = not counted): how much of N_GG the GPU's L2
                                   // cache serves (B_L2) rather than device memory (B_GG)
  std::int64_t cpu_footprint = 0;  // bytes of host memory the CPU work touches in one step (its
                                   // working set; 0 = not counted): how much of N_CC the
                                   // last-level cache serves (memory and extended variants)

  CostCounts& operator+=(const CostCounts& o);
  // Counts of `steps` repetitions.
  CostCounts scaled(std::int64_t steps) const;
  bool operator==(const CostCounts&) const = default;
};

// The counting convention of tree_steps, shared by the workloads that count them and the probe
// that measures L_tree: a 2D k-d tree with kKdTreeLeaf points per leaf has depth(n) =
// 1 + ceil(log2(n / kKdTreeLeaf)) levels (at least one); a build over n points is n x depth(n)
// steps (each point placed at each level), a search for the k nearest depth(n) + kKdTreeLeaf + k
// (the levels descended, a leaf examined, the k kept).
inline constexpr std::int64_t kKdTreeLeaf = 10;
std::int64_t tree_build_steps(std::int64_t n);
std::int64_t tree_search_steps(std::int64_t n, std::int64_t k);

// ceil(a / b) for a >= 0, b > 0: whole blocks, waves or chunks that a count fills.
constexpr std::int64_t ceil_div(std::int64_t a, std::int64_t b) { return (a + b - 1) / b; }

// Adds `count` copies of `bytes` bytes to `sizes` (merged with those of the same size).
void add_copies(std::vector<CopySize>& sizes, std::int64_t bytes, std::int64_t count);

// One integer count of CostCounts. The table of them (count_fields()) is what adds, scales,
// reads, writes, checks and prints counts: a new count is a member above plus a row there
// (docs/model.md, section 5).
struct CountField {
  // How the counts of two computations, or of several steps, combine.
  enum class Accumulate {
    sum,  // added, and multiplied by the steps (what one run moves or does)
    max,  // the larger, whatever the steps (a figure of one step, e.g. a working set)
  };
  std::string_view name;                // JSON key and printed name
  std::int64_t CostCounts::*member;
  std::string_view unit;                // what one of it is: "values", "FLOPs", "copies", ...
  std::string_view meaning;
  Accumulate accumulate = Accumulate::sum;
  // The count it is a part of (N_CW of N_C), or none: then 0 <= it <= that count.
  std::int64_t CostCounts::*part_of = nullptr;
};
const std::vector<CountField>& count_fields();
const CountField& count_field(std::int64_t CostCounts::*member);

// Throws InputError when a count that is a part of another (CountField::part_of) is negative
// or larger than it, or when copies_GC does not add up to P N_GC bytes in transfers_GC copies.
void check_consistent(const CostCounts& counts);

}  // namespace dtflop
