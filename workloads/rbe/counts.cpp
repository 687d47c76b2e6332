#include "workloads/rbe/counts.hpp"

#include <fmt/format.h>

#include "model/errors.hpp"

namespace dtflop::rbe {

void validate(const Shape& s) {
  constexpr std::int64_t kMaxSide = 65536;
  constexpr std::int64_t kMaxCells = std::int64_t{1} << 31;
  if (s.nx < 1 || s.ny < 1)
    throw InputError(fmt::format("grid {}x{} must have at least one cell each way", s.nx, s.ny));
  if (s.Ix < 1 || s.Iy < 1)
    throw InputError(fmt::format("kernel {}x{} must be at least 1x1", s.Ix, s.Iy));
  if (s.nx > kMaxSide || s.ny > kMaxSide || s.cells() > kMaxCells)
    throw InputError(fmt::format("grid {}x{} is larger than dtflop supports ({} per side, {} cells)",
                                 s.nx, s.ny, kMaxSide, kMaxCells));
  if (s.Ix > s.nx || s.Iy > s.ny)
    throw InputError(fmt::format("kernel {}x{} is larger than the grid {}x{}; use a kernel no "
                                 "larger than the grid",
                                 s.Ix, s.Iy, s.nx, s.ny));
}

CostCounts seed_gpu_counts(const Shape& s, HostMemory memory) {
  validate(s);
  const std::int64_t ng = s.cells();
  CostCounts c;
  c.P = 4;
  c.precision = Precision::fp32;
  c.N_CG = 2 * ng + s.Ix + s.Iy + 1;
  c.N_GC = 2 * ng;
  c.N_GG = 4 * ng + s.Ix + s.Iy + 1;
  c.N_C = ng;
  c.N_G = 2 * ng * (s.Ix + s.Iy + 1);
  c.transfers_CG = 5;
  c.transfers_GC = 2;
  c.copies_GC = {{ng * c.P, 2}};  // the prediction and the unnormalized belief, one grid each
  c.launches = 3;
  c.host_memory = memory;
  c.cpu_threads = 1;
  return c;
}

CostCounts conventional_cpu_counts(const Shape& s) {
  validate(s);
  const std::int64_t ng = s.cells();
  CostCounts c;
  c.P = 8;
  c.precision = Precision::fp64;
  c.N_C = 2 * ng * s.Ix * s.Iy + 3 * ng;
  // Host memory traffic in values: prediction reads the belief and writes the prediction
  // (the kernel stays in cache), correction reads prediction and likelihood and writes q,
  // normalization reads q and writes the belief.
  c.N_CC = 2 * ng + 3 * ng + 2 * ng;
  c.cpu_threads = 1;
  return c;
}

}  // namespace dtflop::rbe
