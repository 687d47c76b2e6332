// Exact cost counts of belief fusion on each RBE backend (Backend::fuse and wire_belief; the code
// sits in cpu_seq.cpp, cpu_par.cpp, cuda_fusion.cu with cuda_seed.cu and cuda_resident.cu).
// tests/sar/test_sar_fusion.cpp checks them against formulas written out by hand; docs/sar.md
// derives them.
//
// Notation: n = n_g cells, m platforms (the own belief and k = m - 1 others, each n float32
// values as they arrive over the link), L = kLogExpFlops FLOPs for one log or exp. The own belief
// enters as its wire values (backend.hpp), in rank order with the others.
//   product   per cell c = k multiplications and one addition to the sum
//   loglinear per cell c = m logs, k additions, one multiplication by w = 1/m, one exp, one
//             addition (log 0 = -inf and exp(-inf) = 0: every cell costs the same)
// cpu-seq (float64, P = 8, one thread): the reference; normalizes by division:
//   fuse:  N_C = n c [+1 for w] + 1 + n    (A_c x sum; the division)
//          N_CC = 4 n + ceil(k n / 2): own read, fused written, read and written again by the
//          normalization (8-byte values), the others' float32 values (4 bytes: half a value)
//   wire:  N_C = 0 (a conversion), N_CC = n + ceil(n / 2)
// cpu-par (float32, P = 4, T threads, one parallel region with a reduction); the own belief is
// q x scale (n multiplications, as its wire), the normalization folded into the next step like
// its steps' (scale = 1 / (A_c sum): 2 FLOPs):
//   fuse:  N_C = n c + n [+1 for w] + 2,  N_CC = (m + 1) n,  cpu_syncs = 1 (0 on one thread)
//   wire:  N_C = n,                       N_CC = 2 n,        cpu_syncs = 1 (0 on one thread)
// CUDA (cuda-seed, cuda-resident; float32, P = 4): one kernel of B = ceil(n / (kFusionThreads x
// kFusionCells)) blocks of T = kFusionThreads threads, each kFusionCells cells, block-reduced,
// one atomic add per block into a float64 sum (zeroed first) that comes back to the host (8
// bytes) to be checked:
//   fuse kernel: N_G = n c (the block reduction counted as one addition per value summed, as
//                in the RBE steps: docs/rbe.md), N_GG = (m + 1) n + 2 + 2 B (own and others
//                read, fused written; the sum zeroed and each block's atomic read-modify-write
//                of it), launches 1, waves ceil(B / S), atomics B; N_CG = k n in k copies (the
//                others), N_GC = 2 in one copy (the sum), host_waits 1 [N_C = 1 for w]
//   cuda-resident: the belief stays on the device: its q / (A_c S) made on the fly (N_G + n + 2
//                B T: each thread makes the scale; N_GG + 2 B: S read by each block), the fused
//                grid becomes the belief and the sum its pending normalization (one 8-byte device
//                copy: N_GG + 4), nothing else comes back.
//                wire: a kernel writes q / (A_c S) packed (N_G = n + 2 B T, N_GG = 2 n + 2 B,
//                launches 1, waves ceil(B / S)), one copy of n values back, host_waits 1.
//   cuda-seed: the belief lives on the host (its steps copy it each way): the own belief goes up
//                too (m copies, N_CG = m n), the host makes the scale 1 / (A_c S) (N_C + 2), a
//                second kernel scales the fused grid into the belief (N_G + n, N_GG + 2 n,
//                launches + 1, waves + ceil(B / S)) and it comes back (N_GC + n, one more copy
//                and host wait). wire: the host copies its float32 belief (N_CC = 2 n).
#pragma once

#include <cstdint>

#include "model/cost_counts.hpp"
#include "workloads/rbe/backend.hpp"

namespace dtflop::rbe {

// FLOPs counted for one log or exp (float32 or float64): a polynomial of degree ~ 10 and its
// range reduction.
inline constexpr std::int64_t kLogExpFlops = 13;
// The CUDA fusion kernels' layout: threads per block, cells per thread.
inline constexpr std::int64_t kFusionThreads = 256;
inline constexpr std::int64_t kFusionCells = 8;

// FLOPs of one cell of the fusion of m platforms (see above).
std::int64_t fusion_flops_per_cell(FusionRule rule, std::int64_t platforms);
// Blocks of a CUDA fusion kernel over n cells.
std::int64_t fusion_blocks(std::int64_t cells);

// Throw InputError for platforms < 2, cells < 1, threads < 1 or sms < 1.
CostCounts cpu_seq_fusion_counts(std::int64_t cells, FusionRule rule, std::int64_t platforms);
CostCounts cpu_seq_wire_counts(std::int64_t cells);
CostCounts cpu_par_fusion_counts(std::int64_t cells, FusionRule rule, std::int64_t platforms, int threads);
CostCounts cpu_par_wire_counts(std::int64_t cells, int threads);
CostCounts cuda_resident_fusion_counts(std::int64_t cells, FusionRule rule, std::int64_t platforms, int sms);
CostCounts cuda_resident_wire_counts(std::int64_t cells, int sms);
CostCounts cuda_seed_fusion_counts(std::int64_t cells, FusionRule rule, std::int64_t platforms, int sms);
CostCounts cuda_seed_wire_counts(std::int64_t cells);

}  // namespace dtflop::rbe
