#include "workloads/rbe/fusion_counts.hpp"

#include <fmt/format.h>

#include "model/errors.hpp"

namespace dtflop::rbe {
namespace {

void check(std::int64_t cells, std::int64_t platforms) {
  if (cells < 1) throw InputError(fmt::format("belief fusion over {} cells: a grid needs at least one cell", cells));
  if (platforms < 2)
    throw InputError(fmt::format("belief fusion of {} platform(s): fusion needs at least 2 platforms", platforms));
}
void check_sms(int sms) {
  if (sms < 1) throw InputError(fmt::format("a GPU of {} multiprocessors cannot run the fusion; give at least 1", sms));
}
// The host's share of the log-linear pool: w = 1 / m.
std::int64_t weight_flops(FusionRule rule) { return rule == FusionRule::loglinear ? 1 : 0; }

// The CUDA fusion kernel and the sum it brings back (fusion_counts.hpp).
CostCounts cuda_fuse_kernel(std::int64_t n, FusionRule rule, std::int64_t m, int sms) {
  check(n, m);
  check_sms(sms);
  const std::int64_t B = fusion_blocks(n), k = m - 1;
  CostCounts c;
  c.P = 4;
  c.precision = Precision::fp32;
  c.N_G = n * fusion_flops_per_cell(rule, m);
  c.N_GG = (m + 1) * n + 2 + 2 * B;
  c.launches = 1;
  c.waves = ceil_div(B, sms);
  c.atomics = B;
  c.N_CG = k * n;
  c.transfers_CG = k;
  c.N_GC = 2;
  c.transfers_GC = 1;
  c.copies_GC = {{8, 1}};
  c.host_waits = 1;
  c.N_C = weight_flops(rule);
  c.host_memory = HostMemory::pageable;
  return c;
}

}  // namespace

std::int64_t fusion_flops_per_cell(FusionRule rule, std::int64_t m) {
  const std::int64_t k = m - 1;
  if (rule == FusionRule::product) return k + 1;
  return m * kLogExpFlops + k + 1 + kLogExpFlops + 1;
}

std::int64_t fusion_blocks(std::int64_t cells) { return ceil_div(cells, kFusionThreads * kFusionCells); }

CostCounts cpu_seq_fusion_counts(std::int64_t n, FusionRule rule, std::int64_t m) {
  check(n, m);
  CostCounts c;
  c.P = 8;
  c.precision = Precision::fp64;
  c.N_C = n * fusion_flops_per_cell(rule, m) + weight_flops(rule) + 1 + n;
  c.N_CC = 4 * n + ceil_div((m - 1) * n, 2);
  c.cpu_threads = 1;
  return c;
}

CostCounts cpu_seq_wire_counts(std::int64_t n) {
  check(n, 2);
  CostCounts c;
  c.P = 8;
  c.precision = Precision::fp64;
  c.N_CC = n + ceil_div(n, 2);
  c.cpu_threads = 1;
  return c;
}

CostCounts cpu_par_fusion_counts(std::int64_t n, FusionRule rule, std::int64_t m, int threads) {
  check(n, m);
  if (threads < 1) throw InputError(fmt::format("cpu-par fusion on {} threads: give at least 1", threads));
  CostCounts c;
  c.P = 4;
  c.precision = Precision::fp32;
  c.N_C = n * fusion_flops_per_cell(rule, m) + n + weight_flops(rule) + 2;
  c.N_CC = (m + 1) * n;
  c.cpu_syncs = threads > 1 ? 1 : 0;
  c.cpu_threads = threads;
  c.cpu_footprint = 4 * (m + 1) * n;
  return c;
}

CostCounts cpu_par_wire_counts(std::int64_t n, int threads) {
  check(n, 2);
  if (threads < 1) throw InputError(fmt::format("cpu-par fusion on {} threads: give at least 1", threads));
  CostCounts c;
  c.P = 4;
  c.precision = Precision::fp32;
  c.N_C = n;
  c.N_CC = 2 * n;
  c.cpu_syncs = threads > 1 ? 1 : 0;
  c.cpu_threads = threads;
  c.cpu_footprint = 4 * 2 * n;
  return c;
}

CostCounts cuda_resident_fusion_counts(std::int64_t n, FusionRule rule, std::int64_t m, int sms) {
  CostCounts c = cuda_fuse_kernel(n, rule, m, sms);
  c.N_G += n + 2 * fusion_blocks(n) * kFusionThreads;  // the own q / (A_c S), as the wire carries it
  c.N_GG += 2 * fusion_blocks(n) + 4;  // S read by each block; the sum becomes the belief's pending
                                       // normalization: an 8-byte device copy
  return c;
}

CostCounts cuda_resident_wire_counts(std::int64_t n, int sms) {
  check(n, 2);
  check_sms(sms);
  const std::int64_t B = fusion_blocks(n);
  CostCounts c;
  c.P = 4;
  c.precision = Precision::fp32;
  c.N_G = n + 2 * B * kFusionThreads;
  c.N_GG = 2 * n + 2 * B;
  c.launches = 1;
  c.waves = ceil_div(B, sms);
  c.N_GC = n;
  c.transfers_GC = 1;
  c.copies_GC = {{4 * n, 1}};
  c.host_waits = 1;
  c.host_memory = HostMemory::pageable;
  return c;
}

CostCounts cuda_seed_fusion_counts(std::int64_t n, FusionRule rule, std::int64_t m, int sms) {
  CostCounts c = cuda_fuse_kernel(n, rule, m, sms);
  const std::int64_t B = fusion_blocks(n);
  c.N_CG += n;  // the own belief goes up too
  c.transfers_CG += 1;
  c.N_C += 2;   // scale = 1 / (A_c S)
  c.N_G += n;   // the scaling kernel
  c.N_GG += 2 * n;
  c.launches += 1;
  c.waves += ceil_div(B, sms);
  c.N_GC += n;  // the fused belief comes back
  c.transfers_GC += 1;
  add_copies(c.copies_GC, 4 * n, 1);
  c.host_waits += 1;
  return c;
}

CostCounts cuda_seed_wire_counts(std::int64_t n) {
  check(n, 2);
  CostCounts c;
  c.P = 4;
  c.precision = Precision::fp32;
  c.N_CC = 2 * n;
  c.cpu_threads = 1;
  return c;
}

}  // namespace dtflop::rbe
