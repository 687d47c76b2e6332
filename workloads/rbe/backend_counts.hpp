// Exact cost counts of one step of each RBE backend (the code that does the work sits beside
// each function: cpu_seq.cpp, cpu_par.cpp, cuda_seed.cu, cuda_resident.cu). docs/rbe.md
// derives every formula; tests/workloads/rbe/test_rbe_backend_counts.cpp checks them against
// formulas written out by hand.
#pragma once

#include <cstddef>
#include <cstdint>

#include "model/cost_counts.hpp"
#include "workloads/rbe/backend.hpp"

namespace dtflop::rbe {

// S(I) = sum over kernel entries a of |a - c|: the taps that fall off one grid edge, summed
// over the outputs of a row (see cpu_seq_counts).
std::int64_t edge_taps(std::int64_t kernel_size);

// cpu-seq, float64, one thread. Separable: both passes run over zero-padded lines, every
// output taking every tap; the y-pass is an x-pass between two transposes (6 n_g values moved
// instead of 2). Full 2D: loops over the taps inside the grid only, with
//   valid taps along x, one row: I_x n_x - S(I_x), along y, one column: I_y n_y - S(I_y)
//   separable: N_C = 2 (n_y X I_x + n_x Y I_y) + 3 n_g + 1,  N_CC = 14 n_g + I_x + I_y
//   with the lines rounded up to whole groups of reference::kGroup outputs:
//   X = kGroup ceil(n_x / kGroup), Y = kGroup ceil(n_y / kGroup)
//   full:      N_C = 2 (I_x n_x - S(I_x)) (I_y n_y - S(I_y)) + 3 n_g + 1,  N_CC = 8 n_g + I_x I_y
//   (multiply by l: n_g, sum: n_g, A_c x sum: 1, divide: n_g)
// N_CW = 0. Separable: N_CD = 2 (n_y X I_x + n_x Y I_y), every tap of both passes: each group of
// kGroup outputs holds one float64 accumulator per output, so each tap's addition waits for the
// previous tap's (chained sliding window, priced K_CD). Full 2D: N_CD = 0, its taps are one
// chain per output, a shape no probe measures yet. N_CS = n_g: the correction's sum of q is one
// chain of dependent additions (priced at V_CS).
CostCounts cpu_seq_counts(const Shape& s, Convolution prediction);

// cpu-par, float32, `threads` threads, zero-padded buffers so every output takes every tap. The
// separable passes compute whole blocks of kCpuParXBlock outputs along a row (x-pass) and whole
// strips of kCpuParYStrip columns (y-pass), a row's last one partly outside the grid, so with
// the row widths rounded up to them, X = kCpuParXBlock ceil(n_x / kCpuParXBlock) and
// Y = kCpuParYStrip ceil(n_x / kCpuParYStrip):
//   separable: N_C = 2 n_y (I_x X + I_y Y) + 3 n_g + 2,  N_CC = 7 n_g + I_x + I_y
//   full:      N_C = 2 n_g I_x I_y + 3 n_g + 2,          N_CC = 7 n_g + I_x I_y
//   sliding-window FLOPs (one unaligned load per FMA): N_CW = 2 n_y I_x X (the x-pass),
//   2 n_g I_x I_y (full 2D); aligned-window FLOPs (each row segment loaded feeds two FMAs):
//   N_CA = 2 n_y I_y Y (the y-pass), 0 (full 2D)
//   cpu_syncs = 3 with two threads or more (the prediction's parallel region, the barrier between
//   its two loops, the correction's region), 0 on one thread
//   cpu_footprint (separable) = P (3 n_g + (n_y + I_y - 1) Y): q, l, the prediction and u, which
//   is stored strip by strip with I_y - 1 zero rows
// (the previous step's normalization 1 / (A_c S) is folded into this step's multiply by l).
inline constexpr int kCpuParXBlock = 64;
inline constexpr int kCpuParYStrip = 32;
CostCounts cpu_par_counts(const Shape& s, Convolution prediction, int threads);

// cuda-seed: eqs. 5.10-5.16 (seed_gpu_counts) plus the one multiplication A_c x sum on the CPU
// that the seed folds into its n_g summations: N_C = n_g + 1. Of N_G, the row kernel's taps
// read u one row further on each (a new cache line per warp, where the column kernel's taps
// re-read the lines of the taps before): N_GR = 2 n_g I_y; the column kernel's taps, N_GW = 2 n_g I_x
// (a load and its bounds test beside every FMA, priced K_GW times). The host's sum is one chain of
// dependent additions: N_CS = n_g. Its phases are timed by the host up to a synchronize, two laps
// of each (laps_CG = laps_GC = laps_G = 2), and each lap's round trip is in its component.
CostCounts cuda_seed_counts(const Shape& s, HostMemory memory);

// How cuda-resident covers the grid for a shape and a layout.
struct ResidentPlan {
  Layout::Passes passes = Layout::Passes::fused;  // resolved: fused or split
  int threads = 0;                 // per block, all kernels
  int tile_w = 0, tile_h = 0;      // outputs per block of the (fused or y-pass) kernel
  std::int64_t blocks_x = 0, blocks_y = 0;
  std::size_t smem_bytes = 0;      // dynamic shared memory of that kernel
  // split only: the x-pass kernel
  int xtile_w = 0, xtile_h = 0;
  std::int64_t xblocks_x = 0, xblocks_y = 0;
  std::size_t xsmem_bytes = 0;
  // split only: the passes' chunks of taps (resident_geometry.hpp); 0 taps: the whole kernel in
  // one chunk, as when it fits
  int x_chunk = 0, x_chunks = 1;
  int y_chunk = 0, y_chunks = 1;
  std::int64_t blocks() const { return blocks_x * blocks_y; }
  std::int64_t xblocks() const { return xblocks_x * xblocks_y; }
};
// Largest dynamic shared memory a block may use on sm_90 (227 KiB).
inline constexpr std::size_t kMaxSharedBytes = 232448;
// Throws InputError, saying which rule the layout breaks, for an invalid layout: block_x a
// multiple of 8 in [8, 1024]; block_x x block_y a multiple of 32, at most 1024;
// cells_per_thread one of 1, 2, 4, 8, 16; an explicitly fused tile's shared memory within
// `max_shared`. A split pass whose tile for the whole kernel would not fit `max_shared` walks
// the kernel in chunks of taps (resident_geometry.hpp, pass_chunk), so split (and automatic)
// layouts run any kernel the grid holds.
ResidentPlan resident_plan(const Shape& s, const Layout& layout, std::size_t max_shared = kMaxSharedBytes);

// cuda-resident, float32, one steady-state step inside a run (see cuda_resident.cu), on a GPU
// of S = `sms` multiprocessors; a kernel of B blocks runs in q(B) = ceil(B / S) waves:
//   fused: launches 1, waves = q(B), N_GG = 3 n_g + I_x + I_y + 2 + 2 B, gpu_footprint P (3 n_g + I_x + I_y),
//          N_G = q(B) S [2 I_x W (H + I_y - 1) + (2 I_y + 3) W H + 2]
//   split: launches 2, waves = q(B_x) + q(B), N_GG = 5 n_g + I_x + I_y + 2 + 2 B, gpu_footprint P (4 n_g + I_x + I_y),
//          N_G = q(B_x) S 2 I_x W_x H_x + q(B) S [(2 I_y + 3) W H + 2]
// with B blocks of W x H outputs (B_x blocks of W_x x H_x in the x-pass; fused and x-pass tiles
// of a row start (-h_x) mod 4 cells left of multiples of their width, resident_geometry.hpp, so
// B = ceil((n_x + shift) / W) ceil(n_y / H) there). Halo values re-read
// by neighbouring blocks come from L2 and are not counted in N_GG; every tile computes all of
// its outputs (those outside the grid are zeros and not stored), so N_G counts them.
// Wave quantization: a kernel lasts as long as its busiest multiprocessor, which runs q(B)
// rounds of blocks, so N_G counts q(B) S blocks, as if every multiprocessor ran q(B) (>= B
// blocks; equal when B is a multiple of S), and each round adds a fixed cost (waves x L_wave,
// docs/model.md). Tile fills: a block copies its input tile (halo included) and the kernel
// coefficients from device memory into shared memory before it computes; a multiprocessor runs
// occ blocks at once (resident::blocks_per_sm, from the kernel's register bound, its shared
// memory and the 1 KiB reserved per block), so the busiest one fills ceil(q(B) / occ) rounds:
//   fused: N_GS = ceil(q(B) / occ) S [(H + I_y - 1) (W + kx) + kx + ky]
//   split: N_GS = ceil(q(B_x) / occ_x) S c_x [H_x (128 + kx) + kx] + ceil(q(B) / occ_y) S c_y [u_rows W + ky]
// with kx = 8 ceil(I_x / 8), ky = the y coefficients padded (resident_geometry.hpp), u_rows =
// H + R ceil(I_y / R), c_x = c_y = 1; a pass chunked over the kernel's taps (its whole-kernel
// tile too large for shared memory: ResidentPlan::x_chunk, y_chunk) fills c chunks, each with
// kx (or ky) = the chunk's C taps and 128 + C columns (or u_rows = H + C rows). Atomics: every block of the correcting kernel (fused, or the split y-pass)
// adds its share of S_k to the one sum in device memory: atomics = B. N_GR = 0: every tap reads
// the block's shared-memory tile. Throws InputError when sms < 1.
CostCounts cuda_resident_counts(const Shape& s, const Layout& layout, int sms);
// A run of `steps` steps in chunks of `chunk` steps (one CUDA graph each with `graph`, else
// launched by the host one kernel at a time): adds per chunk one memset of the chunk's sums, two
// 8-byte device copies (the last sum carried in and out), one device->host copy of the sums and
// one host wait (the graph's launch, or the last launch, and the synchronize that waits for it).
// With `graph`, every kernel is a graph's (graph_launches = launches).
CostCounts cuda_resident_run_counts(const Shape& s, const Layout& layout, int sms, std::int64_t steps,
                                    std::int64_t chunk, bool graph);

}  // namespace dtflop::rbe
