#include "workloads/rbe/summary_counts.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "workloads/rbe/fusion_counts.hpp"

namespace dtflop::rbe {

WindowCells window_cells(const Grid& grid, const Footprint& f, std::span<const Point> at) {
  check_footprint(f, at);
  WindowCells w;
  for (const Point& p : at) {
    const std::int64_t c = footprint_window(grid, f, p).cells();
    w.total += c;
    w.largest = std::max(w.largest, c);
  }
  return w;
}

CostCounts host_summary_counts(const Grid& grid, const Footprint& f, std::span<const Point> at, BeliefCopy copy) {
  const WindowCells w = window_cells(grid, f, at);
  const std::int64_t n = grid.cells();
  CostCounts c;
  c.P = 8;
  c.precision = Precision::fp64;
  c.cpu_threads = 1;
  c.N_CC = copy == BeliefCopy::in_place ? 0 : n + ceil_div(n, 2);
  if (copy == BeliefCopy::float32_scaled) c.N_C += n;
  c.N_C += n * kHostEstimateFlops + kHostEstimateFinish;
  c.N_CC += 2 * n;
  c.N_C += w.total * kHostFootprintFlops;
  c.N_CC += w.total;
  return c;
}

CostCounts cuda_resident_summary_counts(const Grid& grid, const Footprint& f, std::span<const Point> at, int sms) {
  if (sms < 1) throw InputError(fmt::format("a GPU of {} multiprocessors cannot run the summary; give at least 1", sms));
  const WindowCells w = window_cells(grid, f, at);
  const std::int64_t n = grid.cells(), P = static_cast<std::int64_t>(at.size());
  const std::int64_t B = fusion_blocks(n);
  CostCounts c;
  c.P = 4;
  c.precision = Precision::fp64;
  c.N_GG = 2 * (9 + P);
  c.N_G = n * kDeviceEstimateFlops;
  c.N_GG += n + 16 * B + 4;
  c.atomics = 8 * B;
  c.launches = 1;
  c.waves = ceil_div(B, sms);
  if (P > 0) {
    const std::int64_t Bf = std::max<std::int64_t>(1, ceil_div(w.largest, kFusionThreads * kFusionCells));
    c.N_CG = 8 * P;
    c.transfers_CG = 1;
    c.N_G += w.total * kDeviceFootprintFlops;
    c.N_GG += w.total + 2 * Bf * P;
    c.atomics += Bf * P;
    c.launches += 1;
    c.waves += ceil_div(Bf * P, sms);
  }
  c.N_GC = 2 * (9 + P);
  c.transfers_GC = 1;
  c.copies_GC = {{8 * (9 + P), 1}};
  c.host_waits = 1;
  c.N_C = kDeviceSummaryFinish + 1 + P;
  c.host_memory = HostMemory::pageable;
  return c;
}

}  // namespace dtflop::rbe
