// cuda-resident's fused kernel over a range of rows of a grid, for the backends that step one
// grid in parts (cuda-bands, cuda_bands.cu): the same kernel, tiles and arithmetic as
// cuda-resident's steps, launched over band-local output rows [begin, end) of a band's buffers
// (its own rows with the halo rows around them). Defined in cuda_resident.cu, beside the kernel.
#pragma once

#include <cuda_runtime_api.h>

#include <cstdint>
#include <memory>
#include <span>

#include "workloads/rbe/backend_counts.hpp"

namespace dtflop::rbe::detail {

class FusedSweep {
 public:
  // On the current device. `shape`: the whole grid (n_x, the kernel I_x x I_y); `rows`: the rows
  // of the buffers q0, q1 and l (each `rows` rows of resident::row_pitch(n_x) floats, the padding
  // columns zero); kx, ky: the kernel's two passes (motion.hpp, not flipped). Throws InputError
  // when the layout needs the split passes or is invalid on this device.
  FusedSweep(const Shape& shape, const Layout& layout, std::int64_t rows, const float* q0, const float* q1,
             const float* l, std::span<const double> kx, std::span<const double> ky, double cell_area);
  ~FusedSweep();
  FusedSweep(const FusedSweep&) = delete;
  FusedSweep& operator=(const FusedSweep&) = delete;
  // Enqueues on `stream` (of the device it was made on) the kernel writing rows [begin, end) of
  // q[1 - prev] from q[prev] (rows begin - h_b .. end - 1 + h_a), scaled by 1 / (A_c *sum_in)
  // and multiplied by l, adding the sum of the rows written to *sum_out (float64, atomically).
  void launch(int prev, std::int64_t begin, std::int64_t end, const double* sum_in, double* sum_out,
              cudaStream_t stream) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dtflop::rbe::detail
