// Device kernels of the DCT cuda backend and their launchers (cuda_kernels.cu). Only plain
// data crosses this interface, so the host class (cuda_backend.cpp) is compiled by the C++
// compiler. Every launcher checks the launch and throws std::runtime_error on failure.
#pragma once

#include "cuda/check.hpp"

#include <cuda_runtime.h>

#include "workloads/dct/kernels.hpp"

namespace dtflop::dct::gpu {

struct Roi {
  int x, y, w, h;
};
struct CompStats {
  int* area;
  int* minx;
  int* miny;
  int* maxx;
  int* maxy;
  int* root;
};
struct DotParams {
  int min_area, max_area;
  float max_aspect, min_fill;
  int margin, reject_border, dark;
};
struct DotOut {
  double* x;
  double* y;
  float* weight;
  int* status;  // 0 kept, 1 area, 2 shape, 3 border, 4 no contrast
  int* pixels;  // window, ring, weighted pixels per component (3 ints)
};


// 256-bin histogram (8-bit scale) of a w x h image and Otsu's threshold in native levels.
// The most threads a block of each layout's kernels can run on the current device (their
// registers decide it: a kernel compiled for more registers a thread fits fewer threads a block),
// the smallest over the kernels each block size is used for.
struct BlockLimits {
  int pixels = 1024;  // histogram, threshold and labelling, component statistics
  int points = 1024;  // MLS and FE fields
  int dots = 1024;    // centroids
};
BlockLimits block_limits();
void launch_otsu(const void* img, bool wide, int w, int h, unsigned int* hist, int* T, int block, cudaStream_t s);
// Threshold + union-find labelling; afterwards *count holds the number of components.
// T_dev (or T_fixed when null): dark dots are v <= T, light dots v > T.
void launch_labels(const void* img, bool wide, int w, int h, const int* T_dev, int T_fixed, bool dark, int* L,
                   int* count, int block, cudaStream_t s);
// Area, bounding box and root (first pixel) of each of n components.
void launch_stats(const int* L, int w, int h, CompStats cs, int n, int block, cudaStream_t s);
// Filters and centroids (eq. 7.1), one block of `block` threads per component.
void launch_centroids(const void* img, bool wide, const int* L, int w, int h, Roi roi, CompStats cs, DotParams p,
                      DotOut out, int n, int block, cudaStream_t s);
void launch_displacement(int n, const double2* ref, const double* cx, const double* cy, const int* match, float2* U,
                         unsigned char* valid, cudaStream_t s);
void launch_mls(int n, const double2* pts, const float* rho, const unsigned char* geometry, const int* offsets,
                const int* dots, const double2* ref, const float2* U, const unsigned char* valid, int weight,
                int min_dots, float min_pivot, FieldValue<float>* out, int block, cudaStream_t s);
// FE: per point its triangle `tri` (3) and shape functions `N` (3); the recovery's triangles
// `support` with coefficients `coef` (CSR by `offsets`); per triangle its dots `tri_dots` and
// gradient coefficients `tri_gx`, `tri_gy` (3 each). kernels.hpp, FePoint. One warp a point, so
// `block` / 32 points a block.
void launch_fe(int n, const int* tri, const float* N, const int* offsets, const int* support, const float* coef,
               const int* tri_dots, const float* tri_gx, const float* tri_gy, const unsigned char* geometry,
               const float2* U, const unsigned char* valid, FieldValue<float>* out, int block, cudaStream_t s);

}  // namespace dtflop::dct::gpu
