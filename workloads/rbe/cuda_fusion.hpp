// Belief fusion on the device, shared by cuda-seed and cuda-resident (Backend::fuse and
// wire_belief; exact counts in fusion_counts.hpp). Internal to workloads/rbe.
#pragma once

#include <cuda_runtime_api.h>

#include <cstdint>
#include <span>

#include "workloads/rbe/backend.hpp"
#include "workloads/rbe/cuda_memory.hpp"

namespace dtflop::rbe::detail {

class DeviceFusion {
 public:
  // Copies `others` (n_g packed float32 values each) to the device, one copy each, and fuses
  // them by `rule` with the own belief `own` (nx x ny, rows `ld` apart; scaled by 1 / (area x
  // *own_denominator) on the fly when that device value is given, as the wire would carry it),
  // which stands at `position` among them, into `out` (same layout as own; its padding is not
  // written) in one kernel on `stream`. Returns the sum of out (one 8-byte copy back, the host
  // waits for it); the device keeps it in sum().
  double fuse(FusionRule rule, const float* own, const double* own_denominator, double area, std::size_t position,
              float* out, std::int64_t nx, std::int64_t ny, std::int64_t ld,
              std::span<const std::span<const float>> others, cudaStream_t stream);
  const double* sum() const { return sum_.get(); }

 private:
  DeviceArray<float> others_;
  DeviceArray<double> sum_;
};

// out (packed, nx x ny) = in (rows ld apart) x s, with s = 1 / (area x *denominator) when
// `denominator` (a device value) is given, else `scale`. Enqueued on `stream`.
void launch_fusion_scale(const float* in, std::int64_t nx, std::int64_t ny, std::int64_t ld,
                         const double* denominator, double area, float scale, float* out, cudaStream_t stream);

}  // namespace dtflop::rbe::detail
