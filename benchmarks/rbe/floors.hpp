// The physical floor of one RBE step: the fewest bytes it must move through device (or host)
// memory and the fewest FLOPs it must do, over the measured ceilings (docs/PERFORMANCE.md).
#pragma once

#include <algorithm>
#include <cstdint>

#include "workloads/rbe/counts.hpp"

namespace dtflop::rbe::bench {

// Ceilings measured on the lent H200 (docs/design.md, reference figures): device-to-device copy
// 4.19 TB/s (read + write counted), FP32 FMA 55 TFLOP/s.
inline constexpr double kH200Bandwidth = 4.2e12;
inline constexpr double kH200Flops = 55e12;

struct Floor {
  double bytes = 0;   // read the belief and the likelihood, write the belief: 3 n_g x 4 B
  double flops = 0;   // 2 n_g (I_x + I_y) prediction (5.5) + 3 n_g correction
  double seconds(double bandwidth, double rate) const { return std::max(bytes / bandwidth, flops / rate); }
};

inline Floor floor_of(const Shape& s) {
  const double ng = double(s.cells());
  return {3 * ng * 4, 2 * ng * double(s.Ix + s.Iy) + 3 * ng};
}

}  // namespace dtflop::rbe::bench
