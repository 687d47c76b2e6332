// The frames the gpu-centroid probe gives the DCT cuda backend's centroid block: dots of one
// radius on a jittered grid (centres 3 radii + 1 px apart: the workload's closest, so that
// neighbours' windows overlap as they do on a dense specimen), bright on a flat background,
// anti-aliased (16 x 16 samples a pixel the edge crosses), labelled where a pixel's centre lies within the radius,
// each dot's window its labels' bounding box grown by the margin and the ring. And the float64
// centroid of every dot by the same arithmetic on the host (kernels/dot_centroid.hpp), which the
// device's must match (the tests check the host's against the centres the frame was drawn with).
#pragma once

#include <cstdint>
#include <vector>

#include "probes/gpu.hpp"

namespace dtflop::probes::centroid {

inline constexpr int kMargin = 2;  // the DCT workload's default margin (px of a dot's edge)

struct Specimen {
  gpu::CentroidFrame frame;
  double radius = 0;
  std::vector<double> centres;  // x, y a dot: where it was drawn
  std::vector<double> host;     // x, y a dot: the float64 centroid (eq. 7.1) on the host
  std::int64_t window_pixels = 0;  // summed over the dots: the counts' gpu_pixel_steps
};

// `dots` dots of `radius` px (3..40; 1..20000 dots) from `seed`. Throws std::invalid_argument
// outside those ranges.
Specimen make_specimen(double radius, int dots, std::uint64_t seed);

// Throws ValidationError (probes/probe.hpp) where a centroid of `got` (x, y a dot) differs from
// the host's float64 one by more than `tol` px, or is not a number.
void check(const Specimen& s, const std::vector<double>& got, double tol, const char* who);

}  // namespace dtflop::probes::centroid
