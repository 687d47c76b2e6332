// The arithmetic of the DCT workload that every backend shares: the background-removed,
// intensity-weighted centroid of one dot (eq. 7.1), in kernels/dot_centroid.hpp, where the
// gpu-centroid probe runs it too, and the fields at one point (moving least squares, eqs.
// 7.2-7.6 with 6.5, and finite elements), in kernels/point_fields.hpp, where the cpu-mls probe
// runs them too. Written once, templated on the scalar type, and compiled for
// the host (float64 reference, float32 checks) and for the device (float32). The FLOP constants
// are what these functions do, counted by hand from the code; counts.cpp builds the backends'
// CostCounts from them.
#pragma once

#include <cmath>
#include <cstdint>

#include "kernels/dot_centroid.hpp"
#include "kernels/point_fields.hpp"  // also defines DTFLOP_HD

namespace dtflop::dct {

// ---- Centroids (eq. 7.1; kernels/dot_centroid.hpp: shared with the gpu-centroid probe) ---
using kernels::classify_pixel;
using kernels::kFlopsPerCentroid;
using kernels::kFlopsPerPlane;
using kernels::kFlopsPerRingPixel;
using kernels::kFlopsPerWeightedPixel;
using kernels::kIgnore;
using kernels::kRing;
using kernels::kRingWidth;
using kernels::kWeighted;
using kernels::PixelClass;
using kernels::RingSums;
using kernels::solve_plane;
using kernels::WeightSums;

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
