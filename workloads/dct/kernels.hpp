// The arithmetic of the DCT workload that every backend shares: the background-removed,
// intensity-weighted centroid of one dot (eq. 7.1), here, and the fields at one point (moving
// least squares, eqs. 7.2-7.6 with 6.5, and finite elements), in kernels/point_fields.hpp, where
// the cpu-mls probe runs them too. Written once, templated on the scalar type, and compiled for
// the host (float64 reference, float32 checks) and for the device (float32). The FLOP constants
// are what these functions do, counted by hand from the code; counts.cpp builds the backends'
// CostCounts from them.
#pragma once

#include <cmath>
#include <cstdint>

#include "kernels/point_fields.hpp"  // also defines DTFLOP_HD

namespace dtflop::dct {

// ---- Centroids (eq. 7.1) ---------------------------------------------------------------
// A dot's window is its labelled bounding box grown by `margin` + kRingWidth pixels. Each
// window pixel is one of:
enum PixelClass : int { kIgnore = 0, kRing = 1, kWeighted = 2 };
constexpr int kRingWidth = 2;

// Class of pixel (x, y) for component `id`: labelled `id` -> weighted; background within
// Chebyshev distance `margin` of `id` and of no other component -> weighted (it holds the
// dot's partly covered edge); background near no component -> ring (background estimate);
// anything else -> ignored. `label(x, y)` returns -1 for background or outside the image.
template <class LabelAt>
DTFLOP_HD int classify_pixel(const LabelAt& label, int x, int y, int id, int margin) {
  const int l = label(x, y);
  if (l == id) return kWeighted;
  if (l != -1) return kIgnore;
  bool self = false, other = false;
  for (int dy = -margin; dy <= margin; ++dy)
    for (int dx = -margin; dx <= margin; ++dx) {
      const int n = label(x + dx, y + dy);
      self |= n == id;
      other |= (n != -1 && n != id);
    }
  if (other) return kIgnore;
  return self ? kWeighted : kRing;
}

// Sums over ring pixels for the background plane I = a + b x + c y (local coordinates).
template <class T>
struct RingSums {
  T n = 0, x = 0, y = 0, xx = 0, xy = 0, yy = 0, i = 0, xi = 0, yi = 0;
  DTFLOP_HD void add(T lx, T ly, T v) {  // 5 multiplies + 9 adds = 14 FLOPs
    n += T(1); x += lx; y += ly; xx += lx * lx; xy += lx * ly; yy += ly * ly;
    i += v; xi += lx * v; yi += ly * v;
  }
  DTFLOP_HD void merge(const RingSums& o) {
    n += o.n; x += o.x; y += o.y; xx += o.xx; xy += o.xy; yy += o.yy; i += o.i; xi += o.xi; yi += o.yi;
  }
};
constexpr std::int64_t kFlopsPerRingPixel = 14;

// Solves the 3x3 normal equations for the plane (Cramer's rule). Returns false when the ring
// cannot fix a plane (fewer than 3 pixels or all on a line); then the plane is its mean.
template <class T>
DTFLOP_HD bool solve_plane(const RingSums<T>& s, T& a, T& b, T& c) {
  // Six cofactors (3 FLOPs each) = 18; det: 3 mul + 2 add = 5; the degeneracy scale and test
  // (3); numerators 3 x 5 = 15 and 3 divides. Total 44 FLOPs.
  const T c00 = s.xx * s.yy - s.xy * s.xy;
  const T c01 = s.xy * s.y - s.x * s.yy;
  const T c02 = s.x * s.xy - s.xx * s.y;
  const T c11 = s.n * s.yy - s.y * s.y;
  const T c12 = s.x * s.y - s.n * s.xy;
  const T c22 = s.n * s.xx - s.x * s.x;
  const T det = s.n * c00 + s.x * c01 + s.y * c02;
  const T scale = s.n * s.xx * s.yy;
  if (s.n < T(3) || !(det > T(1e-6) * scale)) {
    a = s.n > T(0) ? s.i / s.n : T(0);
    b = c = T(0);
    return s.n > T(0);
  }
  a = (c00 * s.i + c01 * s.xi + c02 * s.yi) / det;
  b = (c01 * s.i + c11 * s.xi + c12 * s.yi) / det;
  c = (c02 * s.i + c12 * s.xi + c22 * s.yi) / det;
  return true;
}
constexpr std::int64_t kFlopsPerPlane = 44;

template <class T>
struct WeightSums {
  T w = 0, wx = 0, wy = 0;
  // bg = a + b x + c y (4), w = +-(I - bg) (1), max (1), 2 multiplies + 3 adds (5): 11 FLOPs.
  DTFLOP_HD void add(T lx, T ly, T v, T a, T b, T c, bool dark) {
    const T bg = a + b * lx + c * ly;
    T d = dark ? bg - v : v - bg;
    d = d > T(0) ? d : T(0);
    w += d; wx += d * lx; wy += d * ly;
  }
  DTFLOP_HD void merge(const WeightSums& o) { w += o.w; wx += o.wx; wy += o.wy; }
};
constexpr std::int64_t kFlopsPerWeightedPixel = 11;
// Centroid from the sums: 2 divides + 2 adds (window centre).
constexpr std::int64_t kFlopsPerCentroid = 4;

// ---- Fields at a point (kernels/point_fields.hpp: shared with the cpu-mls probe) ----------
using kernels::FePoint;
using kernels::FieldValue;
using kernels::flops_per_support_dot;
using kernels::flops_weight;
using kernels::kFlopsPerFeEntry;
using kernels::kFlopsPerFePoint;
using kernels::kFlopsPerFeWarpCombine;
using kernels::kFlopsPerPoint;
using kernels::kFlopsPerSupportDot;
using kernels::kFlopsStrain;
using kernels::kGaussAlpha;
using kernels::MlsPoint;
using kernels::PointStatus;
using kernels::rsqrt_of;
using kernels::strain_from_gradient;
using kernels::Weight;
using kernels::weight_fn;
}  // namespace dtflop::dct
