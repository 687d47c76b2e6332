// Tile geometry of cuda-resident's kernels, shared by the host code that declares its counts
// (backend_counts.cpp) and the kernels (cuda_resident.cu), so both always agree.
//
// Fused kernel, block bx x by threads, R = cells_per_thread, tile W x H = bx x (by R) outputs:
//   input tile : H + I_y - 1 rows x (W + 8 G_x) columns (G_x = ceil(I_x / 8): the x-pass reads
//                its 8-wide register window in groups of 8 taps), odd pitch so that the lanes of
//                a warp, one row each, hit distinct banks;
//   u tile     : H + R G_y rows (G_y = ceil(I_y / R)) x W columns, pitch W + 1;
//   kernels    : 8 G_x + R G_y floats (flipped, zero-padded to whole groups);
//   scratch    : 34 doubles (block reduction, the scale).
// Split y-pass kernel: the u tile and kernels only. Split x-pass kernel: 128 x (T / 16) outputs
// (T threads, one 8-wide segment each), input tile T/16 rows x (128 + 8 G_x) columns.
#pragma once

#include <cstddef>
#include <cstdint>

#include "workloads/rbe/backend.hpp"

namespace dtflop::rbe::resident {

inline constexpr int kRx = 8;          // x-pass: outputs per thread (register window)
inline constexpr int kXpassWidth = 128;  // split x-pass tile width
inline constexpr int kScratchDoubles = 34;

struct TileGeometry {
  int out_w = 0, out_h = 0;        // outputs per block
  int in_rows = 0, in_cols = 0, in_pitch = 0;  // input tile (0 rows when there is none)
  int u_rows = 0, u_pitch = 0;     // u tile (0 rows when there is none)
  int kx_len = 0, ky_len = 0;      // padded kernel lengths in shared memory
  std::size_t smem_bytes = 0;
};

inline std::int64_t ceil_div(std::int64_t a, std::int64_t b) { return (a + b - 1) / b; }

inline std::size_t smem_of(const TileGeometry& g) {
  const std::int64_t floats = std::int64_t{g.in_rows} * g.in_pitch + std::int64_t{g.u_rows} * g.u_pitch +
                              g.kx_len + g.ky_len;
  return kScratchDoubles * sizeof(double) + static_cast<std::size_t>(floats) * sizeof(float);
}

inline TileGeometry fused_geometry(const Shape& s, const Layout& l) {
  TileGeometry g;
  const int R = l.cells_per_thread;
  g.out_w = l.block_x;
  g.out_h = l.block_y * R;
  const auto gx = ceil_div(s.Ix, kRx), gy = ceil_div(s.Iy, R);
  g.kx_len = static_cast<int>(gx * kRx);
  g.ky_len = static_cast<int>(gy * R);
  g.in_rows = static_cast<int>(g.out_h + s.Iy - 1);
  g.in_cols = g.out_w + g.kx_len;
  g.in_pitch = g.in_cols | 1;
  g.u_rows = g.out_h + g.ky_len;
  g.u_pitch = g.out_w + 1;
  g.smem_bytes = smem_of(g);
  return g;
}

inline TileGeometry ypass_geometry(const Shape& s, const Layout& l) {
  TileGeometry g = fused_geometry(s, l);
  g.in_rows = g.in_cols = g.in_pitch = 0;
  g.kx_len = 0;
  g.smem_bytes = smem_of(g);
  return g;
}

inline TileGeometry xpass_geometry(const Shape& s, const Layout& l) {
  TileGeometry g;
  const int threads = l.block_x * l.block_y;
  g.out_w = kXpassWidth;
  g.out_h = threads / (kXpassWidth / kRx);
  g.kx_len = static_cast<int>(ceil_div(s.Ix, kRx) * kRx);
  g.in_rows = g.out_h;
  g.in_cols = g.out_w + g.kx_len;
  g.in_pitch = g.in_cols | 1;
  g.smem_bytes = smem_of(g);
  return g;
}

}  // namespace dtflop::rbe::resident
