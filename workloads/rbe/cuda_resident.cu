// cuda-resident: the belief stays on the device. One step is one kernel (fused) or two (split):
//
//  fused  rbe_resident_fused<R>: load the block's input tile (output tile plus the kernel's
//         halo) of the unnormalized belief q_{k-1} into shared memory; x-pass into a shared u
//         tile (each thread 8 neighbouring outputs of one row from a register window); y-pass
//         (each thread R outputs of one column from a register window); multiply by the
//         previous step's scale 1 / (A_c S_{k-1}) and by the likelihood; store q_k; reduce the
//         block's share of S_k (float64) and add it atomically to S_k in device memory.
//  split  rbe_resident_xpass (x-pass to a device buffer u), then rbe_resident_ypass<R> (y-pass
//         from a shared u tile, correction and reduction as above); for kernels whose fused
//         tile would not fit in shared memory. A pass whose own tile would not fit either (a
//         kernel thousands of taps tall or wide) walks the kernel in chunks of taps, copying
//         each chunk's tile and accumulating in registers (resident_geometry.hpp).
//
// The normalization is never a pass of its own: S_k stays on the device and the next step
// scales by it. A run is captured into CUDA graphs (segments of up to kSegment steps), and
// the sums S_k, one scalar per step, come back in one copy per segment. The grids (q, l and u)
// are stored with a row pitch ld = n_x rounded up to a multiple of 4 floats, the padding columns
// zero: every row starts 16-byte aligned, so every tile is copied the same way whatever n_x is
// (by the tensor memory accelerator, or in 16-byte cp.async pieces where it cannot). Counts:
// cuda_resident_counts() (backend_counts.cpp), geometry: resident_geometry.hpp.
// No fmt here: its compile-time format checks do not compile under nvcc in C++20.
#include <cuda.h>  // CUtensorMap and its enums (the encoder is reached through the runtime)
#include <cuda_runtime.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <optional>
#include <stdexcept>

#include "workloads/rbe/backend_counts.hpp"
#include "workloads/rbe/cuda_fusion.hpp"
#include "workloads/rbe/cuda_summary.hpp"
#include "workloads/rbe/summary_counts.hpp"
#include "workloads/rbe/cuda_memory.hpp"
#include "workloads/rbe/fusion_counts.hpp"
#include "workloads/rbe/detail.hpp"
#include "workloads/rbe/resident_geometry.hpp"
#include "workloads/rbe/resident_sweep.hpp"
#include "cuda/tma.cuh"

namespace dtflop::rbe::detail {
namespace {

using resident::kRx;
using resident::kScratchDoubles;

constexpr std::int64_t kSegment = 1000;  // steps per captured graph
constexpr std::int64_t kChunk = 50;      // steps per timing sample inside a graph
constexpr int kMaxBoxRows = 256;         // a tensor-map box is at most 256 elements each way
constexpr int kMaxBoxWidth = 256;

struct KernelArgs {
  const float* __restrict__ q_prev;
  float* __restrict__ q_next;
  const float* __restrict__ l;
  float* __restrict__ u;       // split: the x-pass result, n_x n_y values
  const float* __restrict__ kx;  // flipped, zero-padded to kx_len
  const float* __restrict__ ky;  // flipped, zero-padded to ky_len
  const double* sum_in;        // S_{k-1}
  double* sum_out;             // S_k (zeroed before the step)
  int nx, ny, Ix, Iy, hx, hy;  // hx, hy: halo before the cell (I - 1 - c); ny: rows of the buffers
  int y_begin, y_end;          // the correcting kernel's output rows [y_begin, y_end) (cuda-resident: 0,
                               // ny; cuda-bands: a range of a band's own rows, its halo rows around them)
  int ld;                      // row pitch of q, l and u in floats: n_x rounded up to a multiple of 4
  int x_shift;                 // x-pass tiles start x_shift cells left of a multiple of their width
  int tma;                     // the tile is copied by the tensor memory accelerator (TileMaps,
                               // tile_map_fits()); else in 16-byte cp.async pieces
  int in_rows, in_cols, in_pitch, u_rows, u_pitch, kx_len, ky_len;
  int chunk, chunks;           // split passes: taps per chunk (kx_len or ky_len of them in shared
                               // memory) and chunks (resident_geometry.hpp); the fused kernel: unused
  double cell_area;
};

__device__ __forceinline__ float4 lds4(const float* p) { return *reinterpret_cast<const float4*>(p); }
__device__ __forceinline__ void sts4(float* p, float a, float b, float c, float d) {
  *reinterpret_cast<float4*>(p) = make_float4(a, b, c, d);
}

// Asynchronous 4-byte copy global -> shared (cp.async, sm_80+); when !valid the destination
// is filled with zero and nothing is read. Every load of a tile is in flight at once instead
// of one round trip per loop iteration.
__device__ __forceinline__ void copy_async(float* dst, const float* src, bool valid) {
  const unsigned d = static_cast<unsigned>(__cvta_generic_to_shared(dst));
  asm volatile("cp.async.ca.shared.global [%0], [%1], 4, %2;\n" ::"r"(d), "l"(src), "r"(valid ? 4 : 0));
}
__device__ __forceinline__ void copy_async_wait() { asm volatile("cp.async.wait_all;\n" ::); }

// Copies a tile of `rows` x 4 `cols4` floats whose first column gx0 is a multiple of 4 in 16-byte
// pieces, zero outside the grid. The grid's rows are ld floats apart (ld a multiple of 4, the
// columns from n_x to ld zero), so a piece that starts inside a row lies wholly inside its padded
// row. Thread `tid` of T walks the piece columns tid % P, + P, ... (P = min(cols4, T)) from row
// tid / P in steps of T / P rows, with running pointers.
__device__ __forceinline__ void copy_tile16_async(float* tile, int pitch, int rows, int cols4, const float* base,
                                                  int nx, int ld, int ny, int gx0, int gy0, int tid, int T) {
  const int P = cols4 < T ? cols4 : T;
  const int dr = T / P;
  const int r0 = tid / P;
  if (r0 >= dr) return;  // the T - dr P threads left over
  const std::ptrdiff_t src_step = std::ptrdiff_t(dr) * ld;
  const unsigned dst_step = unsigned(dr * pitch) * 4u;
  for (int c4 = tid - r0 * P; c4 < cols4; c4 += P) {
    const int gx = gx0 + 4 * c4;
    const bool col_in = unsigned(gx) < unsigned(nx);
    int gy = gy0 + r0;
    const float* src = base + (std::ptrdiff_t(gy) * ld + gx);
    unsigned dst = static_cast<unsigned>(__cvta_generic_to_shared(tile + r0 * pitch + 4 * c4));
    for (int r = r0; r < rows; r += dr, gy += dr, src += src_step, dst += dst_step) {
      const bool valid = col_in && unsigned(gy) < unsigned(ny);
      asm volatile("cp.async.cg.shared.global [%0], [%1], 16, %2;\n" ::"r"(dst), "l"(valid ? src : base),
                   "r"(valid ? 16 : 0));
    }
  }
}

// Tile copy by the tensor memory accelerator (sm_90): one thread starts the copy of the whole
// tile of `rows` rows in boxes (rows of a box land in shared memory one after the other, so the
// box width is the tile's pitch; boxes reaching outside the grid, negative coordinates and the
// padding columns included, are filled with zeros), and every thread waits on an mbarrier that
// counts the bytes landed. One instruction per box instead of one per 16 bytes. A box has at
// most kMaxBoxRows rows: a taller tile is copied in boxes of kMaxBoxRows rows (`full`, each
// landing at a 128-byte aligned row, as the accelerator wants) and one of the rows left (`tail`).
struct TileMaps {
  CUtensorMap full;  // boxes of min(rows, kMaxBoxRows) rows
  CUtensorMap tail;  // a box of the rows after the last full box (unused when there are none)
};
__device__ __forceinline__ void tma_tile_start(float* dst, const TileMaps& maps, int x, int y, int rows, int pitch,
                                               unsigned long long* bar) {
  cuda::tma::arm(bar, unsigned(rows * pitch) * 4u);
  for (int r = 0; r < rows; r += kMaxBoxRows) {
    const CUtensorMap* map = r + kMaxBoxRows <= rows || r == 0 ? &maps.full : &maps.tail;
    cuda::tma::copy_box(dst + r * pitch, map, x, y + r, bar);
  }
}
// Waits for phase 0 of the mbarrier (the tile); call after a __syncthreads() that follows
// tma_tile_start, so that the barrier is initialized.
__device__ __forceinline__ void tma_tile_wait(unsigned long long* bar) { cuda::tma::wait(bar); }

// Ends the mbarrier's life (before its shared memory serves anything else); one thread, after a
// __syncthreads() that follows every thread's tma_tile_wait.
__device__ __forceinline__ void tma_tile_done(unsigned long long* bar) { cuda::tma::done(bar); }

// The likelihood of the R cells a thread corrects, loaded before the y-pass so that its latency
// hides behind it. gx may be negative (shifted tiles): outside, zero.
template <int R>
__device__ __forceinline__ void load_likelihood(const KernelArgs& a, int gx, int gy0, float (&lv)[R]) {
  const bool col_in = unsigned(gx) < unsigned(a.nx);
  const float* src = a.l + (std::ptrdiff_t(gy0) * a.ld + gx);
#pragma unroll
  for (int j = 0; j < R; ++j) {
    lv[j] = (col_in && gy0 + j < a.y_end) ? __ldg(src) : 0.f;
    src += a.ld;
  }
}

// 1 / (A_c S), or 0 when S is zero, not finite or the scale would overflow float (the host
// reports the error from the sums; the belief turns to zeros, never NaN).
__device__ inline double scale_from(double S, double area) {
  const double s = 1.0 / (area * S);
  return (S > 0.0 && s <= double(FLT_MAX)) ? s : 0.0;
}

// acc[j] += sum_{a < I} k[a] row[j + a], j < N outputs of one row (N = kRx = 8; 16 was measured
// slower: more registers and uneven task counts). row and k 16-byte aligned; k zero-padded to
// whole groups of 8 taps; row readable up to N + 8 ceil(I / 8) - 1. The window (N + 8 values) is
// read in float4s; taps go in groups of 8 (8 N FMAs per two float4 window loads and two float4
// coefficient loads). Unrolled by 3 groups: the window's shift by 8 becomes a renaming of
// registers, not moves (SASS: 219 instructions per 192 FMAs in the unrolled loop).
template <int N>
__device__ __forceinline__ void x_window(const float* row, const float* k, int I, float (&acc)[N]) {
  static_assert(N % 8 == 0, "the x-pass window is whole float4 pairs");
  float w[N + 8];
#pragma unroll
  for (int j = 0; j < N; j += 4) {
    const float4 v = lds4(row + j);
    w[j] = v.x, w[j + 1] = v.y, w[j + 2] = v.z, w[j + 3] = v.w;
  }
  const int full = I / 8;
#pragma unroll 3
  for (int g = 0; g < full; ++g) {
    const float* r = row + g * 8 + N;
    const float4 b0 = lds4(r), b1 = lds4(r + 4);
    w[N] = b0.x, w[N + 1] = b0.y, w[N + 2] = b0.z, w[N + 3] = b0.w;
    w[N + 4] = b1.x, w[N + 5] = b1.y, w[N + 6] = b1.z, w[N + 7] = b1.w;
    const float4 k0 = lds4(k + g * 8), k1 = lds4(k + g * 8 + 4);
    const float kk[8] = {k0.x, k0.y, k0.z, k0.w, k1.x, k1.y, k1.z, k1.w};
#pragma unroll
    for (int b = 0; b < 8; ++b)
#pragma unroll
      for (int j = 0; j < N; ++j) acc[j] = fmaf(kk[b], w[j + b], acc[j]);
#pragma unroll
    for (int j = 0; j < N; ++j) w[j] = w[8 + j];
  }
  const int rem = I - full * 8;
  if (rem > 0) {
    // Taps b < rem read w[j + b] up to w[N - 2 + rem]: the float4 at N only when rem > 1, the
    // one at N + 4 only when rem > 5; coefficients 4..7 only when rem > 4.
    const float* r = row + full * 8 + N;
    if (rem > 1) {
      const float4 b0 = lds4(r);
      w[N] = b0.x, w[N + 1] = b0.y, w[N + 2] = b0.z, w[N + 3] = b0.w;
    }
    if (rem > 5) {
      const float4 b1 = lds4(r + 4);
      w[N + 4] = b1.x, w[N + 5] = b1.y, w[N + 6] = b1.z, w[N + 7] = b1.w;
    }
    const float4 k0 = lds4(k + full * 8);
    const float4 k1 = rem > 4 ? lds4(k + full * 8 + 4) : make_float4(0.f, 0.f, 0.f, 0.f);
    const float kk[8] = {k0.x, k0.y, k0.z, k0.w, k1.x, k1.y, k1.z, k1.w};
#pragma unroll
    for (int b = 0; b < 8; ++b)
      if (b < rem) {
#pragma unroll
        for (int j = 0; j < N; ++j) acc[j] = fmaf(kk[b], w[j + b], acc[j]);
      }
  }
}

// The x-pass of one tile: rows x (segs N-wide segments) outputs from `in` (16-byte aligned rows
// of in_pitch floats) into `out` (rows of out_pitch floats, multiple of 4). Lanes of a warp take
// consecutive rows: with pitch / 4 odd their float4 reads and writes hit distinct bank groups.
template <int N>
__device__ __forceinline__ void x_pass_tile(const float* in, int in_pitch, float* out, int out_pitch, int rows,
                                            int segs, const float* kx, int Ix, int tid, int T) {
  const int tasks = rows * segs;
  int r = tid % rows, seg = tid / rows;
  const int dr = T % rows, dseg = T / rows;
  for (int t = tid; t < tasks; t += T) {
    float acc[N];
#pragma unroll
    for (int j = 0; j < N; ++j) acc[j] = 0.f;
    x_window<N>(in + r * in_pitch + seg * N, kx, Ix, acc);
    float* dst = out + r * out_pitch + seg * N;
#pragma unroll
    for (int j = 0; j < N; j += 4) sts4(dst + j, acc[j], acc[j + 1], acc[j + 2], acc[j + 3]);
    r += dr;
    seg += dseg;
    if (r >= rows) r -= rows, ++seg;
  }
}

// acc[j] += sum_{b < I} k[b] col[(j + b) pitch], j < R. k zero-padded to whole groups of R and
// 16-byte aligned; col readable up to row R ceil(I / R) + R - 1.
template <int R>
__device__ __forceinline__ void y_window(const float* col, int pitch, const float* k, int I, float (&acc)[R]) {
  float w[2 * R];
#pragma unroll
  for (int j = 0; j < R; ++j) w[j] = col[j * pitch];
  const int full = I / R;
  for (int g = 0; g < full; ++g) {
    const float* c = col + (g * R + R) * pitch;
#pragma unroll
    for (int j = 0; j < R; ++j) w[R + j] = c[j * pitch];
    float kk[R];
    if constexpr (R % 4 == 0) {
#pragma unroll
      for (int b = 0; b < R; b += 4) {
        const float4 k4 = lds4(k + g * R + b);
        kk[b] = k4.x, kk[b + 1] = k4.y, kk[b + 2] = k4.z, kk[b + 3] = k4.w;
      }
    } else {
#pragma unroll
      for (int b = 0; b < R; ++b) kk[b] = k[g * R + b];
    }
#pragma unroll
    for (int b = 0; b < R; ++b)
#pragma unroll
      for (int j = 0; j < R; ++j) acc[j] = fmaf(kk[b], w[j + b], acc[j]);
#pragma unroll
    for (int j = 0; j < R; ++j) w[j] = w[R + j];
  }
  const int rem = I - full * R;
  if (rem > 0) {
    // Taps b < rem read w[j + b] up to w[R + rem - 2]: only those rows are loaded.
    const float* c = col + (full * R + R) * pitch;
#pragma unroll
    for (int j = 0; j + 1 < R; ++j)
      if (j + 1 < rem) w[R + j] = c[j * pitch];
#pragma unroll
    for (int b = 0; b < R; ++b)
      if (b < rem) {
        const float kb = k[full * R + b];
#pragma unroll
        for (int j = 0; j < R; ++j) acc[j] = fmaf(kb, w[j + b], acc[j]);
      }
  }
}

// Correction of the y-pass's R outputs `acc` of this thread, store, block reduction, atomic add
// of the block's share of S_k. `red` holds 32 warp partials; red[32] the scale. Column
// gx = x0 + tx (may lie outside the grid: not stored, and its likelihood is zero).
template <int R>
__device__ __forceinline__ void y_correct(const KernelArgs& a, const float (&acc)[R], int x0, int y0,
                                          const float (&lv)[R], double* red) {
  const int tx = threadIdx.x, ty = threadIdx.y;
  const int tid = ty * blockDim.x + tx, T = blockDim.x * blockDim.y;
  const float s = static_cast<float>(red[32]);
  const int gx = x0 + tx, gy0 = y0 + ty * R;
  const bool col_in = unsigned(gx) < unsigned(a.nx);
  float* dst = a.q_next + (std::ptrdiff_t(gy0) * a.ld + gx);
  float part = 0.f;
#pragma unroll
  for (int j = 0; j < R; ++j) {
    // Rows past y_end add nothing, whatever their window read (cuda-bands: a halo still on its way).
    const bool in = col_in && gy0 + j < a.y_end;
    const float qv = in ? lv[j] * (s * acc[j]) : 0.f;
    if (in) *dst = qv;
    dst += a.ld;
    part += qv;
  }
  double v = part;
#pragma unroll
  for (int off = 16; off > 0; off >>= 1) v += __shfl_down_sync(0xffffffffu, v, off);
  const int lane = tid & 31, warp = tid >> 5;
  if (lane == 0) red[warp] = v;  // red[0..31]; the scale in red[32] stays

  __syncthreads();
  if (warp == 0) {
    v = lane < (T >> 5) ? red[lane] : 0.0;
#pragma unroll
    for (int off = 16; off > 0; off >>= 1) v += __shfl_down_sync(0xffffffffu, v, off);
    if (lane == 0) atomicAdd(a.sum_out, v);
  }
}

// Shared memory of the kernels (resident_geometry.hpp): the tile a kernel copies first (128-byte
// aligned for the tensor memory accelerator), then the others, the kernels, the scratch
// doubles (32 warp partials, the scale, the mbarrier).
//
// At most 80 registers: 3 blocks of 256 threads per multiprocessor (the layouts of 512 threads,
// R <= 8, take 64 or fewer: 2 blocks).
template <int R>
__global__ void __maxnreg__(resident::kFusedRegs) rbe_resident_fused(KernelArgs a, const __grid_constant__ TileMaps maps) {
  extern __shared__ __align__(128) double smem[];
  float* in = reinterpret_cast<float*>(smem);
  float* u = in + a.in_rows * a.in_pitch;
  float* kx = u + a.u_rows * a.u_pitch;
  float* ky = kx + a.kx_len;
  double* red = reinterpret_cast<double*>(ky + a.ky_len);
  auto* bar = reinterpret_cast<unsigned long long*>(red + 33);
  const int tx = threadIdx.x, ty = threadIdx.y, bx = blockDim.x, by = blockDim.y;
  const int tid = ty * bx + tx, T = bx * by;
  const int x0 = blockIdx.x * bx - a.x_shift, y0 = a.y_begin + blockIdx.y * by * R;
  const int gx0 = x0 - a.hx, gy0 = y0 - a.hy;  // gx0 is a multiple of 4
  if (a.tma) {
    if (tid == 0) tma_tile_start(in, maps, gx0, gy0, a.in_rows, a.in_pitch, bar);
  } else {
    copy_tile16_async(in, a.in_pitch, a.in_rows, a.in_cols / 4, a.q_prev, a.nx, a.ld, a.ny, gx0, gy0, tid, T);
  }
  for (int i = tid; i < a.kx_len; i += T) copy_async(kx + i, a.kx + i, true);
  for (int i = tid; i < a.ky_len; i += T) copy_async(ky + i, a.ky + i, true);
  float lv[R];
  load_likelihood<R>(a, x0 + tx, y0 + ty * R, lv);
  if (tid == 0) red[32] = scale_from(*a.sum_in, a.cell_area);
  // u rows below the x-pass's are read only by taps the y-pass skips: keep them finite.
  for (int i = tid; i < (a.u_rows - a.in_rows) * a.u_pitch; i += T) u[a.in_rows * a.u_pitch + i] = 0.f;
  copy_async_wait();
  __syncthreads();
  if (a.tma) tma_tile_wait(bar);
  x_pass_tile<kRx>(in, a.in_pitch, u, a.u_pitch, a.in_rows, bx / kRx, kx, a.Ix, tid, T);
  __syncthreads();
  if (a.tma && tid == 0) tma_tile_done(bar);
  float acc[R];
#pragma unroll
  for (int j = 0; j < R; ++j) acc[j] = 0.f;
  y_window<R>(u + (ty * R) * a.u_pitch + tx, a.u_pitch, ky, a.Iy, acc);
  y_correct<R>(a, acc, x0, y0, lv, red);
}

// Split x-pass: tile of 128 x (T / 16) outputs, one 8-wide segment per thread; writes u. Its
// tiles start x_shift cells left of multiples of 128. The kernel's I_x taps go in a.chunks
// chunks of a.chunk (a multiple of 8; one chunk: the whole kernel, a.chunk = kx_len): per chunk
// the block copies the input tile its taps read (128 + a.chunk columns, starting a.chunk
// columns further right each chunk) and the chunk's coefficients, and each thread adds the
// chunk's taps to its registers. The tensor memory accelerator copies only one-chunk tiles (its
// mbarrier serves one copy; the host clears a.tma for more).
__global__ void __maxnreg__(resident::kXpassRegs) rbe_resident_xpass(KernelArgs a, const __grid_constant__ TileMaps maps) {
  extern __shared__ __align__(128) double smem[];
  float* in = reinterpret_cast<float*>(smem);
  float* kx = in + a.in_rows * a.in_pitch;
  auto* bar = reinterpret_cast<unsigned long long*>(kx + a.kx_len) + 33;
  const int tid = threadIdx.y * blockDim.x + threadIdx.x, T = blockDim.x * blockDim.y;
  const int rows = a.in_rows;  // T / 16
  const int x0 = blockIdx.x * resident::kXpassWidth - a.x_shift, y0 = blockIdx.y * rows;
  const int r = tid % rows, seg = tid / rows;
  float acc[kRx];
#pragma unroll
  for (int j = 0; j < kRx; ++j) acc[j] = 0.f;
  for (int k0 = 0; k0 < a.Ix; k0 += a.chunk) {  // k0: the chunk's first tap
    if (k0 > 0) __syncthreads();  // every thread is done with the previous chunk's tile and taps
    for (int i = tid; i < a.kx_len; i += T) copy_async(kx + i, a.kx + k0 + i, true);
    const int gx0 = x0 - a.hx + k0;  // a multiple of 4 (a.chunk is a multiple of 8)
    if (a.tma) {
      if (tid == 0) tma_tile_start(in, maps, gx0, y0, rows, a.in_pitch, bar);
    } else {
      copy_tile16_async(in, a.in_pitch, rows, a.in_cols / 4, a.q_prev, a.nx, a.ld, a.ny, gx0, y0, tid, T);
    }
    copy_async_wait();
    __syncthreads();
    if (a.tma) tma_tile_wait(bar);
    x_window<kRx>(in + r * a.in_pitch + seg * kRx, kx, min(a.chunk, a.Ix - k0), acc);
  }
  // The outputs go out through shared memory: a thread's 8 neighbouring outputs stored straight
  // to u would make every store instruction of a warp touch 32 sectors in 16 rows, 4 bytes each
  // (measured: the x-pass then took ~3.7 us per block per multiprocessor whatever the kernel
  // width). Staged, a warp stores 32 consecutive floats of one row.
  __syncthreads();  // every thread is done reading the input tile, which now holds the outputs
  if (a.tma && tid == 0) tma_tile_done(bar);
  float* out = in + r * a.in_pitch + seg * kRx;
#pragma unroll
  for (int j = 0; j < kRx; j += 4) sts4(out + j, acc[j], acc[j + 1], acc[j + 2], acc[j + 3]);
  __syncthreads();
  constexpr int W = resident::kXpassWidth;
  for (int i = tid; i < rows * W; i += T) {
    const int row = i / W, col = i - row * W;
    const int gx = x0 + col, gy = y0 + row;
    if (unsigned(gx) < unsigned(a.nx) && gy < a.ny) a.u[std::ptrdiff_t(gy) * a.ld + gx] = in[row * a.in_pitch + col];
  }
}

// Split y-pass and correction: loads the u tile (with the y halo) from device memory. The
// kernel's I_y taps go in a.chunks chunks of a.chunk (a multiple of R and of 4; one chunk: the
// whole kernel, a.chunk = R G_y): per chunk the block copies the u tile its taps read (H +
// a.chunk rows, u_rows, starting a.chunk rows further down each chunk) and the chunk's
// coefficients, and each thread adds the chunk's taps to its R registers; the correction follows
// the last chunk. The tensor memory accelerator copies only one-chunk tiles (the host clears
// a.tma for more).
template <int R>
__global__ void __maxnreg__(resident::kYpassRegs) rbe_resident_ypass(KernelArgs a, const __grid_constant__ TileMaps maps) {
  extern __shared__ __align__(128) double smem[];
  float* u = reinterpret_cast<float*>(smem);
  float* ky = u + a.u_rows * a.u_pitch;
  double* red = reinterpret_cast<double*>(ky + a.ky_len);
  auto* bar = reinterpret_cast<unsigned long long*>(red + 33);
  const int tx = threadIdx.x, ty = threadIdx.y, bx = blockDim.x, by = blockDim.y;
  const int tid = ty * bx + tx, T = bx * by;
  const int x0 = blockIdx.x * bx, y0 = a.y_begin + blockIdx.y * by * R;
  if (tid == 0) red[32] = scale_from(*a.sum_in, a.cell_area);
  float lv[R];
  if (a.chunk >= a.Iy) load_likelihood<R>(a, x0 + tx, y0 + ty * R, lv);  // one chunk: its latency hides behind it
  float acc[R];
#pragma unroll
  for (int j = 0; j < R; ++j) acc[j] = 0.f;
  for (int k0 = 0; k0 < a.Iy; k0 += a.chunk) {  // k0: the chunk's first tap
    if (k0 > 0) __syncthreads();  // every thread is done with the previous chunk's tile and taps
    // Tile row i holds u's row y0 - h_y + k0 + i: output row y0 + t (t = ty R + j) takes taps
    // b of the chunk from tile row t + b (y_window).
    if (a.tma) {
      if (tid == 0) tma_tile_start(u, maps, x0, y0 - a.hy + k0, a.u_rows, a.u_pitch, bar);
    } else {
      copy_tile16_async(u, a.u_pitch, a.u_rows, bx / 4, a.u, a.nx, a.ld, a.ny, x0, y0 - a.hy + k0, tid, T);
    }
    for (int i = tid; i < a.ky_len; i += T) copy_async(ky + i, a.ky + k0 + i, true);
    copy_async_wait();
    __syncthreads();
    if (a.tma) tma_tile_wait(bar);
    y_window<R>(u + (ty * R) * a.u_pitch + tx, a.u_pitch, ky, min(a.chunk, a.Iy - k0), acc);
  }
  if (a.chunk < a.Iy) load_likelihood<R>(a, x0 + tx, y0 + ty * R, lv);  // chunks: not held across them
  y_correct<R>(a, acc, x0, y0, lv, red);  // has a __syncthreads() after every thread's wait
  if (a.tma && tid == 0) tma_tile_done(bar);
}

template <int R>
struct Kernels {
  static void* fused() { return reinterpret_cast<void*>(&rbe_resident_fused<R>); }
  static void* ypass() { return reinterpret_cast<void*>(&rbe_resident_ypass<R>); }
};

void* fused_kernel(int R) {
  switch (R) {
    case 1: return Kernels<1>::fused();
    case 2: return Kernels<2>::fused();
    case 4: return Kernels<4>::fused();
    case 8: return Kernels<8>::fused();
    default: return Kernels<16>::fused();
  }
}
void* ypass_kernel(int R) {
  switch (R) {
    case 1: return Kernels<1>::ypass();
    case 2: return Kernels<2>::ypass();
    case 4: return Kernels<4>::ypass();
    case 8: return Kernels<8>::ypass();
    default: return Kernels<16>::ypass();
  }
}

// A rectangle of a pitched grid set to v (a windowed likelihood's reset, Backend::step).
__global__ void rbe_resident_fill(float* __restrict__ g, int ld, int ix0, int iy0, int width, int rows, float v) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x < width && y < rows) g[static_cast<std::size_t>(iy0 + y) * std::size_t(ld) + std::size_t(ix0 + x)] = v;
}

// cuTensorMapEncodeTiled, reached through the runtime (no link against the driver library);
// null when the driver does not offer it.
using EncodeTiled = CUresult (*)(CUtensorMap*, CUtensorMapDataType, cuuint32_t, void*, const cuuint64_t*,
                                 const cuuint64_t*, const cuuint32_t*, const cuuint32_t*, CUtensorMapInterleave,
                                 CUtensorMapSwizzle, CUtensorMapL2promotion, CUtensorMapFloatOOBfill);
EncodeTiled tensor_map_encoder() {
  static const EncodeTiled fn = [] {
    void* p = nullptr;
    cudaDriverEntryPointQueryResult q{};
    if (cudaGetDriverEntryPointByVersion("cuTensorMapEncodeTiled", &p, 12000, cudaEnableDefault, &q) != cudaSuccess ||
        q != cudaDriverEntryPointSuccess) {
      (void)cudaGetLastError();
      return EncodeTiled(nullptr);
    }
    return reinterpret_cast<EncodeTiled>(p);
  }();
  return fn;
}

// Whether tiles whose rows are `pitch` floats are copied by the tensor memory accelerator: a box
// row of at most 256 elements, the accelerator there (sm_90+), and DTFLOP_RBE_NO_TMA unset (a
// diagnostic switch: the 16-byte cp.async copies instead). The grids' row pitch (ld, a multiple
// of 4 floats) gives the 16-byte row strides a tensor map needs.
bool tile_map_fits(int pitch) {
  static const bool disabled = std::getenv("DTFLOP_RBE_NO_TMA") != nullptr;
  int dev = 0, major = 0;
  DTFLOP_CUDA(cudaGetDevice(&dev));
  DTFLOP_CUDA(cudaDeviceGetAttribute(&major, cudaDevAttrComputeCapabilityMajor, dev));
  return !disabled && major >= 9 && pitch % 4 == 0 && pitch <= kMaxBoxWidth &&
         tensor_map_encoder() != nullptr;
}

// A 2D tensor map of an n_x x n_y float grid whose rows are ld floats apart, with boxes of
// box_w x box_h (what lies outside n_x x n_y, the padding columns included, reads as zero);
// false if the driver refuses it (the caller then copies with cp.async).
bool encode_tile_map(CUtensorMap& m, const float* base, int nx, int ld, int ny, int box_w, int box_h) {
  const EncodeTiled fn = tensor_map_encoder();
  if (!fn) return false;
  const cuuint64_t dims[2] = {cuuint64_t(nx), cuuint64_t(ny)};
  const cuuint64_t strides[1] = {cuuint64_t(ld) * sizeof(float)};
  const cuuint32_t box[2] = {cuuint32_t(box_w), cuuint32_t(box_h)};
  const cuuint32_t element_strides[2] = {1, 1};
  return fn(&m, CU_TENSOR_MAP_DATA_TYPE_FLOAT32, 2, const_cast<float*>(base), dims, strides, box, element_strides,
            CU_TENSOR_MAP_INTERLEAVE_NONE, CU_TENSOR_MAP_SWIZZLE_NONE, CU_TENSOR_MAP_L2_PROMOTION_L2_128B,
            CU_TENSOR_MAP_FLOAT_OOB_FILL_NONE) == CUDA_SUCCESS;
}

// The maps of tiles of `rows` rows x `pitch` floats (TileMaps).
bool encode_tile_maps(TileMaps& m, const float* base, int nx, int ld, int ny, int pitch, int rows) {
  const int full = rows < kMaxBoxRows ? rows : kMaxBoxRows;
  const int tail = rows - (rows - 1) / kMaxBoxRows * kMaxBoxRows;
  return encode_tile_map(m.full, base, nx, ld, ny, pitch, full) && encode_tile_map(m.tail, base, nx, ld, ny, pitch, tail);
}

class CudaResident final : public Backend {
 public:
  explicit CudaResident(const BackendOptions& o) : options_(o) {
    // Reject layouts that break a rule whatever the grid (the smem rule needs the shape).
    (void)resident_plan({1024, 1024, 1, 1}, o.layout);
  }
  ~CudaResident() override = default;

  std::string_view name() const override { return "cuda-resident"; }
  std::string_view description() const override {
    return "belief resident on the GPU: fused tile kernel, device-side sum, CUDA graph";
  }
  bool needs_gpu() const override { return true; }
  const BackendOptions& options() const override { return options_; }
  // Counts for o.gpu_sms multiprocessors; 0: this machine's GPU (counted_gpu_sms).
  CostCounts step_counts(const Shape& s, const BackendOptions& o) const override {
    return cuda_resident_counts(s, o.layout, counted_gpu_sms(o));
  }
  CostCounts run_counts(const Shape& s, const BackendOptions& o, std::int64_t steps) const override {
    // Each segment of up to kSegment steps brings its sums back in one copy.
    return cuda_resident_run_counts(s, o.layout, counted_gpu_sms(o), steps, kSegment, o.graph);
  }
  std::vector<std::string_view> kernel_names() const override {
    return {"rbe_resident_fused", "rbe_resident_xpass", "rbe_resident_ypass"};
  }

  void init(const Problem& problem) override {
    ready_ = false;
    if (const auto why = cuda_unavailable_reason(); !why.empty()) throw DeviceUnavailable("cuda-resident: " + why);
    const auto prior = normalized_prior(problem);
    resolve_prediction(options_, problem.kernel, false, name());
    shape_ = problem.shape();
    grid_ = problem.grid;
    mask_ = problem.mask;
    int dev = 0;
    DTFLOP_CUDA(cudaGetDevice(&dev));
    // The counts (options()) are for this device's multiprocessors unless the caller chose.
    if (options_.gpu_sms <= 0) DTFLOP_CUDA(cudaDeviceGetAttribute(&options_.gpu_sms, cudaDevAttrMultiProcessorCount, dev));
    // The plan first (it throws for a kernel this layout cannot run), then the grids.
    plan_ = plan_for(shape_);

    // Pitched grids, every value zero to start with: the padding columns stay zero (no kernel
    // writes them, no copy touches them).
    ld_ = static_cast<std::size_t>(resident::row_pitch(shape_.nx));
    const std::size_t nx = static_cast<std::size_t>(shape_.nx), ny = static_cast<std::size_t>(shape_.ny);
    q_[0] = zeroed(true);
    q_[1] = zeroed(true);
    l_ = zeroed(true);
    sums_ = DeviceArray<double>(kSegment + 1);
    last_ = DeviceArray<double>(1);
    host_sums_ = HostArray<double>(kSegment, true);
    if (!stream_) stream_.emplace();
    if (!events_) events_.emplace(kSegment + 1);

    std::vector<float> p(prior.begin(), prior.end());
    q_[0].upload_rows(p.data(), nx, ny, ld_);
    if (options_.poison)  // all bits set: a NaN in every float of the grid the steps must overwrite
      DTFLOP_CUDA(cudaMemset2D(q_[1].get(), ld_ * sizeof(float), 0xff, nx * sizeof(float), ny));
    const double last = 1.0 / grid_.cell_area();  // scale 1: the prior is normalized
    last_.upload(&last, 1);
    upload_likelihood(masked_likelihood(problem.likelihood, mask_, shape_.cells()));
    configure(problem.kernel);
    DTFLOP_CUDA(cudaDeviceSynchronize());
    cur_ = 0;
    steps_ = 0;
    failed_ = false;
    ready_ = true;
  }

  // A new motion kernel (a step of another length) for the belief that stays where it is: only
  // the kernel, the plan and what depends on them are made again (no belief copied either way).
  void set_kernel(const MotionKernel& kernel) override {
    check_ready();
    resolve_prediction(options_, kernel, false, name());
    if (kernel.Ix() > shape_.nx || kernel.Iy() > shape_.ny)
      throw InputError("a " + std::to_string(kernel.Ix()) + "x" + std::to_string(kernel.Iy()) +
                       " kernel is larger than the " + std::to_string(shape_.nx) + "x" + std::to_string(shape_.ny) +
                       " grid; give a smaller kernel");
    Shape next = shape_;
    next.Ix = kernel.Ix();
    next.Iy = kernel.Iy();
    const ResidentPlan plan = plan_for(next);  // throws before anything changes
    stream_->sync();
    ready_ = false;  // until the kernel is in place (configure may throw: then init() again)
    shape_ = next;
    plan_ = plan;
    configure(kernel);
    DTFLOP_CUDA(cudaDeviceSynchronize());
    ready_ = true;
  }

  RunResult run(std::int64_t steps) override {
    if (steps < 1) throw InputError("a run needs at least one step, got " + std::to_string(steps));
    check_ready();
    RunResult r;
    r.steps = steps;
    r.steps_per_sample = options_.graph ? kChunk : 1;
    for (std::int64_t done = 0; done < steps;) {
      const std::int64_t n = std::min(kSegment, steps - done);
      const std::int64_t chunk = options_.graph ? kChunk : 1;
      double t0 = seconds_now();
      if (options_.graph) {
        const auto key = std::make_pair(n, cur_);
        auto it = graphs_.find(key);
        if (it == graphs_.end()) {
          cudaGraph_t graph = nullptr;
          DTFLOP_CUDA(cudaStreamBeginCapture(stream_->get(), cudaStreamCaptureModeThreadLocal));
          try {
            enqueue(n, chunk, true);
          } catch (...) {
            cudaStreamEndCapture(stream_->get(), &graph);
            if (graph) cudaGraphDestroy(graph);
            throw;
          }
          DTFLOP_CUDA(cudaStreamEndCapture(stream_->get(), &graph));
          GraphExec exec(graph);
          cudaGraphDestroy(graph);
          DTFLOP_CUDA(cudaGraphUpload(exec.get(), stream_->get()));
          stream_->sync();
          it = graphs_.emplace(key, std::move(exec)).first;
          const double t1 = seconds_now();
          r.setup_seconds += t1 - t0;
          t0 = t1;
        }
        DTFLOP_CUDA(cudaGraphLaunch(it->second.get(), stream_->get()));
      } else {
        enqueue(n, chunk, true);
      }
      stream_->sync();
      r.wall_seconds += seconds_now() - t0;
      // Timing samples: the mean step of each chunk, from the events between chunks.
      append_segment(
          r, n, chunk, [&](std::size_t c) { return events_->seconds(c, c + 1); },
          std::span<const double>(host_sums_.get(), std::size_t(n)), grid_.cell_area(), steps_, name(), failed_);
      cur_ ^= int(n & 1);
      steps_ += n;
      done += n;
    }
    return r;
  }

  StepTimes step(std::span<const double> likelihood) override {
    check_ready();
    const auto l = masked_likelihood(likelihood, mask_, shape_.cells());
    const double t0 = seconds_now();
    upload_likelihood(l);
    return finish_step(t0);
  }

  // Only the window goes up: the cells of the previous window are reset to `outside` first (the
  // whole grid when `outside` changed), by a kernel, then the window's rows are copied.
  StepTimes step(const WindowedLikelihood& likelihood) override {
    check_ready();
    validate(likelihood, grid_);
    if (!mask_.empty()) return step(expand(likelihood, grid_));
    const Window& w = likelihood.window;
    const float outside = static_cast<float>(likelihood.outside);
    std::vector<float> f(likelihood.values.begin(), likelihood.values.end());
    const cudaStream_t st = stream_->get();
    const double t0 = seconds_now();
    if (!l_outside_ || *l_outside_ != outside) {
      launch_fill(0, 0, shape_.nx, shape_.ny, outside, st);
    } else if (l_window_.cells() > 0) {
      launch_fill(l_window_.ix0, l_window_.iy0, l_window_.ix1 - l_window_.ix0 + 1, l_window_.iy1 - l_window_.iy0 + 1,
                  outside, st);
    }
    l_outside_ = outside;
    l_window_ = w;
    if (w.cells() > 0) {
      const std::size_t width = static_cast<std::size_t>(w.ix1 - w.ix0 + 1), rows = static_cast<std::size_t>(w.iy1 - w.iy0 + 1);
      float* dst = l_.get() + static_cast<std::size_t>(w.iy0) * ld_ + static_cast<std::size_t>(w.ix0);
      DTFLOP_CUDA(cudaMemcpy2DAsync(dst, ld_ * sizeof(float), f.data(), width * sizeof(float), width * sizeof(float), rows,
                                    cudaMemcpyHostToDevice, st));
    }
    stream_->sync();
    return finish_step(t0);
  }

  std::vector<double> belief() override {
    check_ready();
    stream_->sync();
    const auto n = static_cast<std::size_t>(shape_.cells());
    std::vector<float> q(n);
    double last = 0;
    q_[cur_].download_rows(q.data(), static_cast<std::size_t>(shape_.nx), static_cast<std::size_t>(shape_.ny), ld_);
    DTFLOP_CUDA(cudaMemcpy(&last, last_.get(), sizeof(double), cudaMemcpyDeviceToHost));
    const double s = 1.0 / (grid_.cell_area() * last);
    std::vector<double> p(n);
    for (std::size_t i = 0; i < n; ++i) p[i] = double(q[i]) * s;
    return p;
  }

  // Belief fusion where the belief lives: the others go up, one kernel fuses them with q into the
  // other q buffer, which becomes the belief, and its sum becomes the pending normalization
  // (last_) of the next step, as a step's would. Only the wire belief comes back (wire_belief).
  // Counts: cuda_resident_fusion_counts(), cuda_resident_wire_counts().
  CostCounts fusion_counts(const Shape& s, FusionRule rule, std::int64_t platforms,
                           const BackendOptions& o) const override {
    return cuda_resident_fusion_counts(s.cells(), rule, platforms, counted_gpu_sms(o));
  }
  CostCounts wire_counts(const Shape& s, const BackendOptions& o) const override {
    return cuda_resident_wire_counts(s.cells(), counted_gpu_sms(o));
  }

  // The summary where the belief lives: two reduction kernels, 9 + P doubles back
  // (cuda_summary.hpp). Counts: cuda_resident_summary_counts().
  Summary summarize(const Footprint& f, std::span<const Point> at) override {
    check_ready();
    return summary_.summarize(q_[cur_].get(), last_.get(), grid_, std::int64_t(ld_), f, at, stream_->get());
  }
  CostCounts summary_counts(const Grid& g, const Footprint& f, std::span<const Point> at,
                            const BackendOptions& o) const override {
    return cuda_resident_summary_counts(g, f, at, counted_gpu_sms(o));
  }

  std::vector<float> wire_belief() override {
    check_ready();
    const cudaStream_t st = stream_->get();
    const auto n = static_cast<std::size_t>(shape_.cells());
    if (wire_.size() < n) wire_ = DeviceArray<float>(n);
    launch_fusion_scale(q_[cur_].get(), shape_.nx, shape_.ny, std::int64_t(ld_), last_.get(), grid_.cell_area(), 0.f,
                        wire_.get(), st);
    std::vector<float> w(n);
    DTFLOP_CUDA(cudaMemcpyAsync(w.data(), wire_.get(), n * sizeof(float), cudaMemcpyDeviceToHost, st));
    stream_->sync();
    return w;
  }

  void fuse(FusionRule rule, std::span<const std::span<const float>> others, std::size_t position) override {
    check_ready();
    check_others(others, position, shape_.cells(), name());
    const cudaStream_t st = stream_->get();
    const double S = fusion_.fuse(rule, q_[cur_].get(), last_.get(), grid_.cell_area(), position, q_[cur_ ^ 1].get(),
                                  shape_.nx, shape_.ny, std::int64_t(ld_), others, st);
    check_fusion_sum(S, others.size() + 1, rule, name());  // q_[cur_] is untouched
    DTFLOP_CUDA(cudaMemcpyAsync(last_.get(), fusion_.sum(), sizeof(double), cudaMemcpyDeviceToDevice, st));
    cur_ ^= 1;
  }

 private:
  void check_ready() const {
    if (!ready_ || failed_) throw_not_ready(name(), failed_);
  }

  DeviceArray<float> zeroed(bool wanted) const {
    const std::size_t n = ld_ * static_cast<std::size_t>(shape_.ny);
    DeviceArray<float> a(wanted ? n : 0);
    if (wanted) DTFLOP_CUDA(cudaMemset(a.get(), 0, n * sizeof(float)));
    return a;
  }

  // One step after its likelihood went up (from t0, host clock): the step, its sum back, the times.
  StepTimes finish_step(double t0) {
    const double t1 = seconds_now();
    enqueue(1, 1, false);
    stream_->sync();
    const double t2 = seconds_now();
    double S = 0;
    DTFLOP_CUDA(cudaMemcpy(&S, sums_.get() + 1, sizeof(double), cudaMemcpyDeviceToHost));
    const double t3 = seconds_now();
    StepTimes t;
    t.part(StepPart::to_device) = t1 - t0;
    t.part(StepPart::device_step) = events_->seconds(0, 1);
    t.part(StepPart::to_host) = t3 - t2;
    t.total = t3 - t0;
    cur_ ^= 1;
    if (!(S > 0 && std::isfinite(S))) {
      failed_ = true;
      check_sum(S, steps_, name());
    }
    ++steps_;
    return t;
  }

  ResidentPlan plan_for(const Shape& shape) const {
    int dev = 0, max_smem = 0;
    DTFLOP_CUDA(cudaGetDevice(&dev));
    DTFLOP_CUDA(cudaDeviceGetAttribute(&max_smem, cudaDevAttrMaxSharedMemoryPerBlockOptin, dev));
    return resident_plan(shape, options_.layout, static_cast<std::size_t>(max_smem));
  }

  // What depends on the kernel (shape_ and plan_ set): the kernels' attributes, the split pass's
  // grid, the flipped kernel taps, the kernel arguments and the tile maps; the step graphs go.
  void configure(const MotionKernel& kernel) {
    prepare_kernels();
    graphs_.clear();
    const std::size_t nx = static_cast<std::size_t>(shape_.nx), ny = static_cast<std::size_t>(shape_.ny);
    u_ = zeroed(plan_.passes == Layout::Passes::split);
    if (options_.poison && u_.get())
      DTFLOP_CUDA(cudaMemset2D(u_.get(), ld_ * sizeof(float), 0xff, nx * sizeof(float), ny));

    // Flipped kernels, zero-padded to whole register groups, and for chunked split passes to
    // whole chunks (every chunk copies a.chunk coefficients: resident_geometry.hpp).
    const bool split = plan_.passes == Layout::Passes::split;
    const auto fused = resident::fused_geometry(shape_, options_.layout);
    const auto yg = resident::ypass_geometry(shape_, options_.layout, plan_.y_chunk);
    const auto xg = resident::xpass_geometry(shape_, options_.layout, plan_.x_chunk);
    const int kx_len = fused.kx_len, ky_len = fused.ky_len;
    const std::size_t kx_all = std::max<std::size_t>(std::size_t(kx_len), split ? std::size_t(xg.chunks) * std::size_t(xg.chunk) : 0);
    const std::size_t ky_all = std::max<std::size_t>(std::size_t(ky_len), split ? std::size_t(yg.chunks) * std::size_t(yg.chunk) : 0);
    std::vector<float> kx(kx_all, 0.f), ky(ky_all, 0.f);
    for (std::int64_t a = 0; a < shape_.Ix; ++a)
      kx[std::size_t(a)] = float(kernel.kx()[std::size_t(shape_.Ix - 1 - a)]);
    for (std::int64_t b = 0; b < shape_.Iy; ++b)
      ky[std::size_t(b)] = float(kernel.ky()[std::size_t(shape_.Iy - 1 - b)]);
    kx_ = DeviceArray<float>(kx.size());
    ky_ = DeviceArray<float>(ky.size());
    kx_.upload(kx);
    ky_.upload(ky);

    args_ = KernelArgs{};
    args_.l = l_.get();
    args_.u = u_.get();
    args_.kx = kx_.get();
    args_.ky = ky_.get();
    args_.nx = int(shape_.nx);
    args_.ld = int(ld_);
    args_.ny = int(shape_.ny);
    args_.y_begin = 0;
    args_.y_end = int(shape_.ny);
    args_.Ix = int(shape_.Ix);
    args_.Iy = int(shape_.Iy);
    args_.hx = int(shape_.Ix - 1 - kernel_centre(shape_.Ix));
    args_.hy = int(shape_.Iy - 1 - kernel_centre(shape_.Iy));
    args_.cell_area = grid_.cell_area();
    const auto& g = split ? yg : fused;
    args_.x_shift = g.x_shift;
    args_.in_rows = g.in_rows;
    args_.in_cols = g.in_cols;
    args_.in_pitch = g.in_pitch;
    args_.u_rows = g.u_rows;
    args_.u_pitch = g.u_pitch;
    args_.kx_len = kx_len;
    args_.ky_len = split ? yg.ky_len : ky_len;
    args_.chunk = split ? yg.chunk : 0;
    args_.chunks = split ? yg.chunks : 1;
    xargs_ = args_;
    if (split) {
      xargs_.in_rows = xg.in_rows;
      xargs_.in_cols = xg.in_cols;
      xargs_.in_pitch = xg.in_pitch;
      xargs_.x_shift = xg.x_shift;
      xargs_.u_rows = 0;
      xargs_.u_pitch = 0;
      xargs_.kx_len = xg.kx_len;
      xargs_.ky_len = 0;
      xargs_.chunk = xg.chunk;
      xargs_.chunks = xg.chunks;
    }
    // The plan's chunks are the geometry's (resident_plan made them from the same functions).
    if (split && (xg.chunks != plan_.x_chunks || yg.chunks != plan_.y_chunks || yg.smem_bytes != plan_.smem_bytes ||
                  xg.smem_bytes != plan_.xsmem_bytes))
      throw std::logic_error("cuda-resident: the split passes' geometry disagrees with the plan");
    // Tile copies by the tensor memory accelerator where a tile's rows fit a box (else cp.async).
    std::memset(static_cast<void*>(maps_), 0, sizeof(maps_));
    std::memset(static_cast<void*>(xmaps_), 0, sizeof(xmaps_));
    std::memset(static_cast<void*>(&umap_), 0, sizeof(umap_));
    auto encode_q = [&](TileMaps (&maps)[2], int pitch, int rows) {
      return encode_tile_maps(maps[0], q_[0].get(), args_.nx, args_.ld, args_.ny, pitch, rows) &&
             encode_tile_maps(maps[1], q_[1].get(), args_.nx, args_.ld, args_.ny, pitch, rows);
    };
    if (plan_.passes == Layout::Passes::fused) {
      args_.tma = tile_map_fits(args_.in_pitch) && encode_q(maps_, args_.in_pitch, args_.in_rows);
    } else {
      // One copy per kernel for the accelerator's mbarrier: chunked passes copy with cp.async.
      xargs_.tma = xargs_.chunks == 1 && tile_map_fits(xargs_.in_pitch) &&
                   encode_q(xmaps_, xargs_.in_pitch, xargs_.in_rows);
      args_.tma = args_.chunks == 1 && tile_map_fits(args_.u_pitch) &&
                  encode_tile_maps(umap_, u_.get(), args_.nx, args_.ld, args_.ny, args_.u_pitch, args_.u_rows);
    }
  }

  void prepare_kernels() {
    const int R = options_.layout.cells_per_thread;
    const int T = plan_.threads;
    auto prepare = [&](void* fn, std::size_t smem, const char* what) {
      DTFLOP_CUDA(cudaFuncSetAttribute(fn, cudaFuncAttributeMaxDynamicSharedMemorySize, int(smem)));
      cudaFuncAttributes attr{};
      DTFLOP_CUDA(cudaFuncGetAttributes(&attr, fn));
      if (attr.maxThreadsPerBlock < T)
        throw InputError("layout " + to_string(options_.layout) + " is invalid on this device: the " + what +
                         " kernel with " + std::to_string(R) + " cells per thread takes " +
                         std::to_string(attr.numRegs) + " registers per thread and runs at most " +
                         std::to_string(attr.maxThreadsPerBlock) + " threads per block, fewer than " +
                         std::to_string(T) + "; use a smaller block");
    };
    if (plan_.passes == Layout::Passes::fused) {
      prepare(fused_kernel(R), plan_.smem_bytes, "fused");
    } else {
      prepare(reinterpret_cast<void*>(&rbe_resident_xpass), plan_.xsmem_bytes, "x-pass");
      prepare(ypass_kernel(R), plan_.smem_bytes, "y-pass");
    }
  }

  void upload_likelihood(const std::vector<double>& l) {
    l_outside_.reset();  // the whole grid is written: no window to reset
    std::vector<float> f(l.begin(), l.end());
    l_.upload_rows(f.data(), static_cast<std::size_t>(shape_.nx), static_cast<std::size_t>(shape_.ny), ld_);
  }

  void launch_fill(std::int64_t ix0, std::int64_t iy0, std::int64_t width, std::int64_t rows, float v, cudaStream_t s) {
    const dim3 block(32, 8);
    const dim3 grid(unsigned((width + 31) / 32), unsigned((rows + 7) / 8));
    rbe_resident_fill<<<grid, block, 0, s>>>(l_.get(), int(ld_), int(ix0), int(iy0), int(width), int(rows), v);
    DTFLOP_CUDA_LAUNCHED();
  }

  template <int R>
  void launch_correcting(const KernelArgs& a, int prev, cudaStream_t s) {
    const dim3 block(unsigned(options_.layout.block_x), unsigned(options_.layout.block_y));
    const dim3 grid(unsigned(plan_.blocks_x), unsigned(plan_.blocks_y));
    if (plan_.passes == Layout::Passes::fused)
      rbe_resident_fused<R><<<grid, block, plan_.smem_bytes, s>>>(a, maps_[prev]);
    else
      rbe_resident_ypass<R><<<grid, block, plan_.smem_bytes, s>>>(a, umap_);
    DTFLOP_CUDA_LAUNCHED();
  }

  void launch_step(std::int64_t k) {
    const cudaStream_t s = stream_->get();
    const int prev = cur_ ^ int(k & 1);
    KernelArgs a = args_;
    a.q_prev = q_[prev].get();
    a.q_next = q_[prev ^ 1].get();
    a.sum_in = sums_.get() + k;
    a.sum_out = sums_.get() + k + 1;
    if (plan_.passes == Layout::Passes::split) {
      KernelArgs x = xargs_;
      x.q_prev = a.q_prev;
      const dim3 block(unsigned(options_.layout.block_x), unsigned(options_.layout.block_y));
      const dim3 grid(unsigned(plan_.xblocks_x), unsigned(plan_.xblocks_y));
      rbe_resident_xpass<<<grid, block, plan_.xsmem_bytes, s>>>(x, xmaps_[prev]);
      DTFLOP_CUDA_LAUNCHED();
    }
    switch (options_.layout.cells_per_thread) {
      case 1: launch_correcting<1>(a, prev, s); break;
      case 2: launch_correcting<2>(a, prev, s); break;
      case 4: launch_correcting<4>(a, prev, s); break;
      case 8: launch_correcting<8>(a, prev, s); break;
      default: launch_correcting<16>(a, prev, s); break;
    }
  }


  // n steps: zero their sums, carry S in, the steps (an event after every `chunk`), carry S
  // out, and (optionally) the n sums to the host in one copy.
  void enqueue(std::int64_t n, std::int64_t chunk, bool sums_back) {
    const cudaStream_t s = stream_->get();
    DTFLOP_CUDA(cudaMemsetAsync(sums_.get() + 1, 0, std::size_t(n) * sizeof(double), s));
    DTFLOP_CUDA(cudaMemcpyAsync(sums_.get(), last_.get(), sizeof(double), cudaMemcpyDeviceToDevice, s));
    // Inside a capture, an event must be recorded as an external node to time the graph.
    cudaStreamCaptureStatus capture = cudaStreamCaptureStatusNone;
    DTFLOP_CUDA(cudaStreamIsCapturing(s, &capture));
    auto record = [&](std::size_t e) {
      if (capture == cudaStreamCaptureStatusActive)
        DTFLOP_CUDA(cudaEventRecordWithFlags((*events_)[e], s, cudaEventRecordExternal));
      else
        DTFLOP_CUDA(cudaEventRecord((*events_)[e], s));
    };
    record(0);
    std::size_t e = 1;
    for (std::int64_t k = 0; k < n; ++k) {
      launch_step(k);
      if ((k + 1) % chunk == 0 || k + 1 == n) record(e++);
    }
    DTFLOP_CUDA(cudaMemcpyAsync(last_.get(), sums_.get() + n, sizeof(double), cudaMemcpyDeviceToDevice, s));
    if (sums_back)
      DTFLOP_CUDA(cudaMemcpyAsync(host_sums_.get(), sums_.get() + 1, std::size_t(n) * sizeof(double),
                                  cudaMemcpyDeviceToHost, s));
  }

  BackendOptions options_;
  Shape shape_;
  Grid grid_;
  std::vector<std::uint8_t> mask_;
  ResidentPlan plan_;
  KernelArgs args_{}, xargs_{};
  // Tensor maps of the tiles: maps_[i] (fused) and xmaps_[i] (split x-pass) read q_[i]; umap_
  // (split y-pass) reads u_. Zeros when the kernel copies with cp.async.
  TileMaps maps_[2]{}, xmaps_[2]{}, umap_{};
  DeviceArray<float> q_[2], l_, u_, kx_, ky_, wire_;
  DeviceFusion fusion_;
  DeviceSummary summary_;
  // What l_ holds after a windowed step: `outside` but on the window (unset: anything).
  std::optional<float> l_outside_;
  Window l_window_;
  DeviceArray<double> sums_, last_;
  HostArray<double> host_sums_;
  std::optional<Stream> stream_;
  std::optional<Events> events_;
  std::map<std::pair<std::int64_t, int>, GraphExec> graphs_;
  std::size_t ld_ = 0;  // row pitch of q_, l_ and u_ (floats)
  int cur_ = 0;
  std::int64_t steps_ = 0;
  bool ready_ = false;
  bool failed_ = false;
};

}  // namespace

// ---- FusedSweep (resident_sweep.hpp) ---------------------------------------------------------

struct FusedSweep::Impl {
  Layout layout;
  ResidentPlan plan;
  KernelArgs args{};
  TileMaps maps[2]{};
  const float* q[2]{};
  DeviceArray<float> kx, ky;
};

FusedSweep::FusedSweep(const Shape& shape, const Layout& layout, std::int64_t rows, const float* q0, const float* q1,
                       const float* l, std::span<const double> kx_in, std::span<const double> ky_in, double cell_area)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.layout = layout;
  int dev = 0, max_smem = 0;
  DTFLOP_CUDA(cudaGetDevice(&dev));
  DTFLOP_CUDA(cudaDeviceGetAttribute(&max_smem, cudaDevAttrMaxSharedMemoryPerBlockOptin, dev));
  m.plan = resident_plan(shape, layout, static_cast<std::size_t>(max_smem));
  if (m.plan.passes != Layout::Passes::fused)
    throw InputError("cuda-bands runs cuda-resident's fused kernel only, and layout " + to_string(layout) +
                     " with a " + std::to_string(shape.Ix) + "x" + std::to_string(shape.Iy) +
                     " kernel needs the split passes; use a layout whose fused tile fits, or cuda-resident");
  const int R = layout.cells_per_thread;
  void* fn = fused_kernel(R);
  DTFLOP_CUDA(cudaFuncSetAttribute(fn, cudaFuncAttributeMaxDynamicSharedMemorySize, int(m.plan.smem_bytes)));
  cudaFuncAttributes attr{};
  DTFLOP_CUDA(cudaFuncGetAttributes(&attr, fn));
  if (attr.maxThreadsPerBlock < m.plan.threads)
    throw InputError("layout " + to_string(layout) + " is invalid on this device: the fused kernel runs at most " +
                     std::to_string(attr.maxThreadsPerBlock) + " threads per block; use a smaller block");
  const auto g = resident::fused_geometry(shape, layout);
  std::vector<float> kx(static_cast<std::size_t>(g.kx_len), 0.f), ky(static_cast<std::size_t>(g.ky_len), 0.f);
  for (std::int64_t a = 0; a < shape.Ix; ++a) kx[std::size_t(a)] = float(kx_in[std::size_t(shape.Ix - 1 - a)]);
  for (std::int64_t b = 0; b < shape.Iy; ++b) ky[std::size_t(b)] = float(ky_in[std::size_t(shape.Iy - 1 - b)]);
  m.kx = DeviceArray<float>(kx.size());
  m.ky = DeviceArray<float>(ky.size());
  m.kx.upload(kx);
  m.ky.upload(ky);
  m.q[0] = q0;
  m.q[1] = q1;
  KernelArgs& a = m.args;
  a.l = l;
  a.u = nullptr;
  a.kx = m.kx.get();
  a.ky = m.ky.get();
  a.nx = int(shape.nx);
  a.ld = int(resident::row_pitch(shape.nx));
  a.ny = int(rows);
  a.Ix = int(shape.Ix);
  a.Iy = int(shape.Iy);
  a.hx = int(shape.Ix - 1 - kernel_centre(shape.Ix));
  a.hy = int(shape.Iy - 1 - kernel_centre(shape.Iy));
  a.cell_area = cell_area;
  a.x_shift = g.x_shift;
  a.in_rows = g.in_rows;
  a.in_cols = g.in_cols;
  a.in_pitch = g.in_pitch;
  a.u_rows = g.u_rows;
  a.u_pitch = g.u_pitch;
  a.kx_len = g.kx_len;
  a.ky_len = g.ky_len;
  std::memset(static_cast<void*>(m.maps), 0, sizeof(m.maps));
  a.tma = tile_map_fits(a.in_pitch) && encode_tile_maps(m.maps[0], q0, a.nx, a.ld, a.ny, a.in_pitch, a.in_rows) &&
          encode_tile_maps(m.maps[1], q1, a.nx, a.ld, a.ny, a.in_pitch, a.in_rows);
}

FusedSweep::~FusedSweep() = default;

void FusedSweep::launch(int prev, std::int64_t begin, std::int64_t end, const double* sum_in, double* sum_out,
                        cudaStream_t stream) const {
  const Impl& m = *impl_;
  if (end <= begin) return;
  KernelArgs a = m.args;
  a.q_prev = m.q[prev];
  a.q_next = const_cast<float*>(m.q[prev ^ 1]);
  a.sum_in = sum_in;
  a.sum_out = sum_out;
  a.y_begin = int(begin);
  a.y_end = int(end);
  const dim3 block(unsigned(m.layout.block_x), unsigned(m.layout.block_y));
  const dim3 grid(unsigned(m.plan.blocks_x), unsigned(ceil_div(end - begin, m.plan.tile_h)));
  switch (m.layout.cells_per_thread) {
    case 1: rbe_resident_fused<1><<<grid, block, m.plan.smem_bytes, stream>>>(a, m.maps[prev]); break;
    case 2: rbe_resident_fused<2><<<grid, block, m.plan.smem_bytes, stream>>>(a, m.maps[prev]); break;
    case 4: rbe_resident_fused<4><<<grid, block, m.plan.smem_bytes, stream>>>(a, m.maps[prev]); break;
    case 8: rbe_resident_fused<8><<<grid, block, m.plan.smem_bytes, stream>>>(a, m.maps[prev]); break;
    default: rbe_resident_fused<16><<<grid, block, m.plan.smem_bytes, stream>>>(a, m.maps[prev]); break;
  }
  DTFLOP_CUDA_LAUNCHED();
}

std::unique_ptr<Backend> make_cuda_resident(const BackendOptions& options) {
  return std::make_unique<CudaResident>(options);
}

}  // namespace dtflop::rbe::detail
