// The RBE step written for clarity (cpu-seq's algorithms), templated on the scalar so that a
// test can run it with an operation-counting type and prove cpu_seq_counts() exact.
// Grid arrays are row-major, x fastest (grid.hpp); kernels follow motion.hpp's convention.
#pragma once

#include <cstdint>
#include <vector>

#include "kernels/host_loops.hpp"
#include "workloads/rbe/motion.hpp"

namespace dtflop::rbe::reference {

// The taps a of a kernel of size I (centre c) that reach inside a line of n cells from output
// i: j = i - (a - c) in [0, n). Loops run over exactly these, so that the work done is the
// FLOPs counted (no iterations spent testing taps that fall outside the grid).
inline std::int64_t first_tap(std::int64_t i, std::int64_t c, std::int64_t n) {
  return i + c - (n - 1) > 0 ? i + c - (n - 1) : 0;
}
inline std::int64_t end_tap(std::int64_t i, std::int64_t c, std::int64_t I) { return i + c + 1 < I ? i + c + 1 : I; }

// Convolution along x with kernel k of size I (5.3): u[i] = sum_a k[a] p[i - (a - c)], zero
// belief outside the grid. Each row is copied into a zero-padded line so that every output
// takes all I taps (a tap outside the grid adds k[a] x 0 = +0 and leaves the sum exactly as if
// it had been skipped), and each output sums its taps in order, one dependent addition after
// another. Outputs are taken kGroup at a time so that kGroup such chains run side by side: one
// chain at a time, the time per tap would depend on the kernel size (the processor overlaps
// consecutive outputs' chains only when an output has few taps), and on how many outputs sit
// near an edge; this way it is the same for every tap, and the FLOPs predict the time. The last
// group of a row is computed whole too (its outputs past the row are dropped), so a row costs
// kGroup ceil(n_x / kGroup) outputs' taps. The loop over a line is kernels::correlate_chained,
// which the cpu-window probe times for K_CD.
inline constexpr std::int64_t kGroup = kernels::kChainGroup;
template <class T>
void pass_x(std::int64_t nx, std::int64_t ny, const T* k, std::int64_t I, const T* p, T* u) {
  const std::int64_t left = I - 1 - kernel_centre(I);  // padding before the row
  // line[left + j] = p[row + j]; output ix reads line[ix + I - 1 - a] for a = 0 .. I - 1.
  const std::int64_t groups = (nx + kGroup - 1) / kGroup;
  std::vector<T> line(static_cast<std::size_t>(groups * kGroup + I - 1), T(0));
  for (std::int64_t iy = 0; iy < ny; ++iy) {
    for (std::int64_t j = 0; j < nx; ++j) line[static_cast<std::size_t>(left + j)] = p[iy * nx + j];
    kernels::correlate_chained(line.data() + (I - 1), nx, k, I, u + iy * nx);
  }
}

// out[x ny + y] = in[y nx + x]: the transpose of an nx-wide, ny-tall array, in 32 x 32 tiles
// so that both the reads and the writes use whole cache lines.
template <class T>
void transpose(std::int64_t nx, std::int64_t ny, const T* in, T* out) {
  constexpr std::int64_t kTile = 32;
  for (std::int64_t y0 = 0; y0 < ny; y0 += kTile)
    for (std::int64_t x0 = 0; x0 < nx; x0 += kTile)
      for (std::int64_t y = y0; y < y0 + kTile && y < ny; ++y)
        for (std::int64_t x = x0; x < x0 + kTile && x < nx; ++x) out[x * ny + y] = in[y * nx + x];
}

// Convolution along y (5.4): the x-pass of the transposed array, transposed back. A column
// read in place touches a new cache line, and for wide grids a new page, at every tap; through
// the transpose both passes read contiguous memory and cost the same per tap, whatever the grid
// width. Each output sums the same taps in the same order as the direct form
// out[y nx + x] = sum_b k[b] u[(y - (b - c)) nx + x]. `work` holds 2 nx ny values.
template <class T>
void pass_y(std::int64_t nx, std::int64_t ny, const T* k, std::int64_t I, const T* u, T* out, T* work) {
  T* ut = work;
  T* vt = work + nx * ny;
  transpose(nx, ny, u, ut);
  pass_x(ny, nx, k, I, ut, vt);
  transpose(ny, nx, vt, out);
}

// The conventional 2D convolution (4.10) with a full Ix x Iy kernel (row-major, [b Ix + a]).
template <class T>
void convolve_full(std::int64_t nx, std::int64_t ny, const T* k, std::int64_t Ix, std::int64_t Iy,
                   const T* p, T* out) {
  const std::int64_t cx = kernel_centre(Ix), cy = kernel_centre(Iy);
  for (std::int64_t iy = 0; iy < ny; ++iy)
    for (std::int64_t ix = 0; ix < nx; ++ix) {
      T acc = T(0);
      const std::int64_t a0 = first_tap(ix, cx, nx), a1 = end_tap(ix, cx, Ix);
      for (std::int64_t b = first_tap(iy, cy, ny), b1 = end_tap(iy, cy, Iy); b < b1; ++b) {
        const std::int64_t row = (iy - (b - cy)) * nx + ix + cx;  // row + (-a) is the cell read
        for (std::int64_t a = a0; a < a1; ++a) acc = acc + k[b * Ix + a] * p[row - a];
      }
      out[iy * nx + ix] = acc;
    }
}

// Correction step 1 (4.12): q = l x prediction.
template <class T>
void multiply(std::int64_t n, const T* l, const T* pred, T* q) {
  for (std::int64_t i = 0; i < n; ++i) q[i] = l[i] * pred[i];
}

// Correction step 2: the sum of q, a serial chain (kernels::serial_sum, the cpu-window probe's V_CS).
template <class T>
T sum(std::int64_t n, const T* q) {
  return kernels::serial_sum(n, q);
}

// Correction step 3 (4.11): p = q / (A_c x sum). The caller checks that the sum is positive.
template <class T>
void normalize(std::int64_t n, const T* q, T cell_area, T s, T* p) {
  const T z = cell_area * s;
  for (std::int64_t i = 0; i < n; ++i) p[i] = q[i] / z;
}

}  // namespace dtflop::rbe::reference
