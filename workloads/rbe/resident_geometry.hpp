// Tile geometry of cuda-resident's kernels, shared by the host code that declares its counts
// (backend_counts.cpp) and the kernels (cuda_resident.cu), so both always agree.
//
// The grids live in device memory with a row pitch of n_x rounded up to a multiple of 4 floats
// (row_pitch), the padding columns zero. Every x-pass tile starts its input at a column that is
// a multiple of 4: the tiles of a row start `x_shift` cells left of a multiple of the tile width
// (x_shift = (-h_x) mod 4, h_x = I_x - 1 - c the halo left of a cell), so that the input tile's
// first column x0 - h_x is a multiple of 4. Then every tile row is copied in 16-byte pieces (by
// the tensor memory accelerator, or cp.async), whatever n_x is, and the x-pass reads its
// register window in aligned float4s from shared memory. Pitches are
// multiples of 4 floats with pitch / 4 odd: 8 lanes on 8 consecutive rows reading (or writing)
// one float4 each hit 8 distinct 16-byte bank groups (one shared-memory wavefront).
//
// Fused kernel, block bx x by threads, R = cells_per_thread, tile W x H = bx x (by R) outputs:
//   input tile : H + I_y - 1 rows x (W + 8 G_x) columns (G_x = ceil(I_x / 8): the x-pass reads
//                its 8-wide register window in groups of 8 taps), pitch (W + 8 G_x) + 4;
//   u tile     : H + R G_y rows (G_y = ceil(I_y / R)) x W columns, pitch W + 4;
//   kernels    : 8 G_x + (R G_y rounded up to a multiple of 4) floats (flipped, zero-padded to
//                whole groups);
//   scratch    : 34 doubles (32 warp partials, the scale, the tile copy's mbarrier).
// Shared memory: input tile | u tile | kx | ky | scratch: the tile copied first sits at the
// (128-byte aligned) start, as the tensor memory accelerator wants; every part is 16-byte aligned.
// Split y-pass kernel: u tile | ky | scratch. Split x-pass kernel: input tile | kx | scratch,
// 128 x (T / 16) outputs (T threads, one 8-wide segment each), input tile T/16 rows x
// (128 + 8 G_x) columns, pitch + 4.
//
// Chunked split passes: when a split pass's tile for the whole kernel does not fit a block's
// shared memory (a kernel thousands of taps tall or wide), the pass walks the kernel in chunks of
// C taps, C a multiple of the pass's register group (x: 8; y: R, and of 4 so the parts after the
// coefficients stay 16-byte aligned): per chunk it copies the tile its C taps read (y: H + C u
// rows, x: 128 + C input columns) and the chunk's C coefficients, and accumulates into the same
// registers, so the tile holds C taps, not the kernel. One chunk is the pass as above. The
// coefficients in device memory are zero-padded to whole chunks.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "model/cost_counts.hpp"  // ceil_div
#include "workloads/rbe/backend.hpp"

namespace dtflop::rbe::resident {

inline constexpr int kRx = 8;          // x-pass: outputs per thread (register window)

// What one multiprocessor holds on sm_90 (H100, H200), for the blocks a kernel runs at once:
// 64 K registers, 2048 threads, 32 blocks, 228 KiB of shared memory of which each block's
// runtime takes 1 KiB besides its own.
inline constexpr int kSmRegisters = 65536;
inline constexpr int kSmThreads = 2048;
inline constexpr int kSmBlocks = 32;
inline constexpr std::size_t kSmShared = 233472;
inline constexpr std::size_t kSharedReservedPerBlock = 1024;
// Registers per thread of the kernels, at most (__maxnreg__ in cuda_resident.cu): the fused
// kernel, the split x-pass and the split y-pass. The counts assume these (a y-pass with fewer
// cells per thread takes fewer and may run more blocks at once than counted).
inline constexpr int kFusedRegs = 80;
inline constexpr int kXpassRegs = 48;
inline constexpr int kYpassRegs = 72;
inline constexpr int kXpassWidth = 128;  // split x-pass tile width
inline constexpr int kScratchDoubles = 34;

// Cells the tiles of a row start left of a multiple of the tile width: (-h_x) mod 4, with
// h_x = I_x - 1 - c and c = (I_x - 1) / 2 the kernel's centre (motion.hpp).
inline int x_shift(const Shape& s) {
  const auto hx = static_cast<int>(s.Ix - 1 - (s.Ix - 1) / 2);
  return (4 - hx % 4) % 4;
}

// The row pitch (floats) of the grids in device memory: n_x rounded up to a multiple of 4.
inline std::int64_t row_pitch(std::int64_t nx) { return (nx + 3) / 4 * 4; }

// A pitch (floats) for rows of `cols` floats: a multiple of 4 with pitch / 4 odd.
inline int vec_pitch(int cols) {
  const int q = (cols + 3) / 4;
  return 4 * (q | 1);
}

struct TileGeometry {
  int out_w = 0, out_h = 0;        // outputs per block
  int x_shift = 0;                 // tiles of a row start x_shift cells left of k W
  int in_rows = 0, in_cols = 0, in_pitch = 0;  // input tile (0 rows when there is none)
  int u_rows = 0, u_pitch = 0;     // u tile (0 rows when there is none)
  int kx_len = 0, ky_len = 0;      // padded kernel lengths in shared memory
  // Split passes: the taps each chunk covers and the chunks (one: the whole kernel at once).
  int chunk = 0, chunks = 1;
  std::size_t smem_bytes = 0;
};

// Blocks of `smem` bytes of dynamic shared memory (and the 1 KiB the runtime keeps for each) one
// multiprocessor's shared memory holds.
inline std::int64_t blocks_by_shared(std::size_t smem) {
  return static_cast<std::int64_t>(kSmShared / (smem + kSharedReservedPerBlock));
}

// Blocks of `threads` threads, `regs` registers each and `smem` bytes of dynamic shared memory
// one multiprocessor runs at once (registers are given out per warp in units of 256).
inline int blocks_per_sm(int threads, int regs, std::size_t smem) {
  const std::int64_t warps = ceil_div(threads, 32);
  const std::int64_t per_warp = ceil_div(std::int64_t{regs} * 32, 256) * 256;
  std::int64_t n = kSmBlocks;
  n = std::min<std::int64_t>(n, kSmRegisters / (warps * per_warp));
  n = std::min<std::int64_t>(n, kSmThreads / threads);
  n = std::min<std::int64_t>(n, blocks_by_shared(smem));
  return static_cast<int>(std::max<std::int64_t>(n, 1));
}

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
  g.x_shift = x_shift(s);
  const auto gx = ceil_div(s.Ix, kRx), gy = ceil_div(s.Iy, R);
  g.kx_len = static_cast<int>(gx * kRx);
  g.ky_len = static_cast<int>(ceil_div(gy * R, 4) * 4);
  g.in_rows = static_cast<int>(g.out_h + s.Iy - 1);
  g.in_cols = g.out_w + g.kx_len;
  g.in_pitch = vec_pitch(g.in_cols);
  g.u_rows = static_cast<int>(g.out_h + gy * R);
  g.u_pitch = vec_pitch(g.out_w);
  g.smem_bytes = smem_of(g);
  return g;
}

// Taps per chunk of the split y-pass: a multiple of R and of 4.
inline int ypass_chunk_step(const Layout& l) { return std::max(l.cells_per_thread, 4); }
// Taps per chunk of the split x-pass: a multiple of its register group.
inline constexpr int kXpassChunkStep = kRx;

// The split y-pass with chunks of `chunk` taps (a multiple of ypass_chunk_step), or the whole
// kernel in one (chunk 0: u tile H + R G_y rows, coefficients R G_y rounded up to 4).
inline TileGeometry ypass_geometry(const Shape& s, const Layout& l, int chunk = 0) {
  TileGeometry g = fused_geometry(s, l);
  g.x_shift = 0;  // reads u in grid columns: its tiles start at multiples of W
  g.in_rows = g.in_cols = g.in_pitch = 0;
  g.kx_len = 0;
  if (chunk > 0) {
    g.u_rows = g.out_h + chunk;
    g.ky_len = chunk;
    g.chunk = chunk;
    g.chunks = static_cast<int>(ceil_div(s.Iy, chunk));
  } else {
    g.chunk = static_cast<int>(g.u_rows - g.out_h);  // R G_y >= I_y
    g.chunks = 1;
  }
  g.smem_bytes = smem_of(g);
  return g;
}

// The split x-pass with chunks of `chunk` taps (a multiple of 8), or the whole kernel in one
// (chunk 0).
inline TileGeometry xpass_geometry(const Shape& s, const Layout& l, int chunk = 0) {
  TileGeometry g;
  const int threads = l.block_x * l.block_y;
  g.out_w = kXpassWidth;
  g.out_h = threads / (kXpassWidth / kRx);
  g.x_shift = x_shift(s);
  g.kx_len = chunk > 0 ? chunk : static_cast<int>(ceil_div(s.Ix, kRx) * kRx);
  g.chunk = g.kx_len;
  g.chunks = static_cast<int>(ceil_div(s.Ix, g.kx_len));
  g.in_rows = g.out_h;
  g.in_cols = g.out_w + g.kx_len;
  g.in_pitch = vec_pitch(g.in_cols);
  g.smem_bytes = smem_of(g);
  return g;
}

// The chunk (taps) of a split pass whose whole-kernel tile needs more than `max_shared` bytes:
// the most taps, a multiple of `step`, whose tile fits the shared memory of two blocks on one
// multiprocessor, or failing that of one block (`max_shared`); 0 when the whole kernel fits
// `max_shared` (one chunk) or when not even `step` taps fit. `geometry(chunk)` gives the pass's
// tile for a chunk; `taps` is the kernel's length along the pass.
template <class Geometry>
int pass_chunk(Geometry geometry, std::int64_t taps, int step, std::size_t max_shared) {
  if (geometry(0).smem_bytes <= max_shared) return 0;
  const std::size_t two = kSmShared / 2 - kSharedReservedPerBlock;
  for (const std::size_t budget : {std::min(two, max_shared), max_shared}) {
    // The tile grows with the chunk: walk down from the whole kernel in whole steps.
    for (std::int64_t c = ceil_div(taps, step) * step; c >= step; c -= step)
      if (geometry(static_cast<int>(c)).smem_bytes <= budget) return static_cast<int>(c);
  }
  return 0;
}

}  // namespace dtflop::rbe::resident
