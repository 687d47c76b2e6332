// The RBE step written for clarity (cpu-seq's algorithms), templated on the scalar so that a
// test can run it with an operation-counting type and prove cpu_seq_counts() exact.
// Grid arrays are row-major, x fastest (grid.hpp); kernels follow motion.hpp's convention.
#pragma once

#include <cstdint>

#include "workloads/rbe/motion.hpp"

namespace dtflop::rbe::reference {

// Convolution along x with kernel k of size I (5.3): u[i] = sum_a k[a] p[i - (a - c)], taps
// outside the grid skipped (zero belief there).
template <class T>
void pass_x(std::int64_t nx, std::int64_t ny, const T* k, std::int64_t I, const T* p, T* u) {
  const std::int64_t c = kernel_centre(I);
  for (std::int64_t iy = 0; iy < ny; ++iy)
    for (std::int64_t ix = 0; ix < nx; ++ix) {
      T acc = T(0);
      for (std::int64_t a = 0; a < I; ++a) {
        const std::int64_t j = ix - (a - c);
        if (j >= 0 && j < nx) acc = acc + k[a] * p[iy * nx + j];
      }
      u[iy * nx + ix] = acc;
    }
}

// Convolution along y (5.4).
template <class T>
void pass_y(std::int64_t nx, std::int64_t ny, const T* k, std::int64_t I, const T* u, T* out) {
  const std::int64_t c = kernel_centre(I);
  for (std::int64_t iy = 0; iy < ny; ++iy)
    for (std::int64_t ix = 0; ix < nx; ++ix) {
      T acc = T(0);
      for (std::int64_t b = 0; b < I; ++b) {
        const std::int64_t j = iy - (b - c);
        if (j >= 0 && j < ny) acc = acc + k[b] * u[j * nx + ix];
      }
      out[iy * nx + ix] = acc;
    }
}

// The conventional 2D convolution (4.10) with a full Ix x Iy kernel (row-major, [b Ix + a]).
template <class T>
void convolve_full(std::int64_t nx, std::int64_t ny, const T* k, std::int64_t Ix, std::int64_t Iy,
                   const T* p, T* out) {
  const std::int64_t cx = kernel_centre(Ix), cy = kernel_centre(Iy);
  for (std::int64_t iy = 0; iy < ny; ++iy)
    for (std::int64_t ix = 0; ix < nx; ++ix) {
      T acc = T(0);
      for (std::int64_t b = 0; b < Iy; ++b) {
        const std::int64_t jy = iy - (b - cy);
        if (jy < 0 || jy >= ny) continue;
        for (std::int64_t a = 0; a < Ix; ++a) {
          const std::int64_t jx = ix - (a - cx);
          if (jx >= 0 && jx < nx) acc = acc + k[b * Ix + a] * p[jy * nx + jx];
        }
      }
      out[iy * nx + ix] = acc;
    }
}

// Correction step 1 (4.12): q = l x prediction.
template <class T>
void multiply(std::int64_t n, const T* l, const T* pred, T* q) {
  for (std::int64_t i = 0; i < n; ++i) q[i] = l[i] * pred[i];
}

// Correction step 2: the sum of q.
template <class T>
T sum(std::int64_t n, const T* q) {
  T s = T(0);
  for (std::int64_t i = 0; i < n; ++i) s = s + q[i];
  return s;
}

// Correction step 3 (4.11): p = q / (A_c x sum). The caller checks that the sum is positive.
template <class T>
void normalize(std::int64_t n, const T* q, T cell_area, T s, T* p) {
  const T z = cell_area * s;
  for (std::int64_t i = 0; i < n; ++i) p[i] = q[i] / z;
}

}  // namespace dtflop::rbe::reference
