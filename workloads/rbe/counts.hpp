// Cost counts of the grid-based RBE as the dissertation formulates it (seed ch. 4-5).
// The backends of workloads/rbe declare their own counts beside their code; these are the
// paper's pipelines, checked against eqs. 5.10-5.16 by tests/workloads.
#pragma once

#include <cstdint>

#include "model/cost_counts.hpp"

namespace dtflop::rbe {

struct Shape {
  std::int64_t nx = 0;  // grid cells along x
  std::int64_t ny = 0;  // grid cells along y
  std::int64_t Ix = 0;  // kernel size along x
  std::int64_t Iy = 0;  // kernel size along y
  std::int64_t cells() const { return nx * ny; }  // n_g
};

// Throws InputError when a size is < 1, absurdly large (> 2^31 cells or a side > 65536),
// or the kernel is larger than the grid.
void validate(const Shape& s);

// The seed's GPU pipeline (5.3.1): belief, column and row kernels, likelihood and the sum go
// to the device each step; q and the belief come back; the sum is taken on the CPU.
//   N_CG = 2 n_g + I_x + I_y + 1   (5.10)     N_GC = 2 n_g                 (5.13)
//   N_GG = 4 n_g + I_x + I_y + 1   (5.14)     N_C  = n_g                   (5.15)
//   N_G  = 2 n_g (I_x + I_y + 1)   (5.16)
// Transfers: 5 host->device (belief, 2 kernels, likelihood, sum), 2 device->host (q,
// belief). Launches: 3 (column pass, row pass + multiply, divide). P = 4 (float32).
CostCounts seed_gpu_counts(const Shape& s, HostMemory memory = HostMemory::pageable);

// The conventional sequential step on the CPU: full 2D convolution (4.10),
// 2 n_g I_x I_y FLOPs, then correction (multiply, sum, divide: 3 n_g FLOPs). P = 8 (float64,
// as the reference backend computes). One thread, nothing on the device.
CostCounts conventional_cpu_counts(const Shape& s);

}  // namespace dtflop::rbe
