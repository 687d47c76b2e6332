#include "model/cost_counts.hpp"

#include <algorithm>

namespace dtflop {

std::string_view to_string(HostMemory m) { return m == HostMemory::pinned ? "pinned" : "pageable"; }
std::string_view to_string(Precision p) { return p == Precision::fp64 ? "fp64" : "fp32"; }

void add_copies(std::vector<CopySize>& sizes, std::int64_t bytes, std::int64_t count) {
  if (count == 0) return;
  auto it = std::find_if(sizes.begin(), sizes.end(), [bytes](const CopySize& s) { return s.bytes == bytes; });
  if (it != sizes.end()) it->count += count;
  else sizes.push_back({bytes, count});
}

CostCounts& CostCounts::operator+=(const CostCounts& o) {
  N_CG += o.N_CG;
  N_GC += o.N_GC;
  N_GG += o.N_GG;
  N_C += o.N_C;
  N_G += o.N_G;
  N_GR += o.N_GR;
  N_CC += o.N_CC;
  N_CW += o.N_CW;
  transfers_CG += o.transfers_CG;
  transfers_GC += o.transfers_GC;
  launches += o.launches;
  waves += o.waves;
  atomics += o.atomics;
  host_waits += o.host_waits;
  N_GS += o.N_GS;
  cpu_syncs += o.cpu_syncs;
  cpu_threads = std::max(cpu_threads, o.cpu_threads);
  cpu_footprint = std::max(cpu_footprint, o.cpu_footprint);  // the larger working set
  for (const CopySize& s : o.copies_GC) add_copies(copies_GC, s.bytes, s.count);
  return *this;
}

CostCounts CostCounts::scaled(std::int64_t steps) const {
  CostCounts c = *this;
  c.N_CG *= steps;
  c.N_GC *= steps;
  c.N_GG *= steps;
  c.N_C *= steps;
  c.N_G *= steps;
  c.N_GR *= steps;
  c.N_CC *= steps;
  c.N_CW *= steps;
  c.transfers_CG *= steps;
  c.transfers_GC *= steps;
  c.launches *= steps;
  c.waves *= steps;
  c.atomics *= steps;
  c.host_waits *= steps;
  c.N_GS *= steps;
  c.cpu_syncs *= steps;
  for (CopySize& s : c.copies_GC) s.count *= steps;
  return c;
}

}  // namespace dtflop
