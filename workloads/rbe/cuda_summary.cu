// cuda-resident's summary (cuda_summary.hpp). Two reduction kernels in the layout of the fusion
// kernel (a thread takes kFusionCells cells kFusionThreads apart, coalesced; warp shuffles, then
// one atomic per value per block), accumulating in float64:
//   rbe_summary_moments: over every cell, w = q and its raw moments about the grid's centre
//     (sum w, w x, w y, w x^2, w x y, w y^2), sum w ln w, and the largest cell as one 64-bit key
//     (the float's bits, then the complement of the cell's index: ties go to the first cell, as
//     in estimate());
//   rbe_summary_footprints: for each point (blockIdx.y), sum q exp(-d^2 / (2 spread^2)) over
//     its window.
// The host finishes from those sums: p = w / W, mean = centre + (w x) / W, covariance = (w x x) /
// W - mean^2, entropy = ln W - (w ln w) / W, mass = W / S, footprint = peak / S x its sum, where
// the belief is q / (A_c S). Counts: cuda_resident_summary_counts() (summary_counts.hpp).
#include <cuda_runtime.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "cuda/check.hpp"
#include "model/errors.hpp"
#include "workloads/rbe/cuda_summary.hpp"
#include "workloads/rbe/fusion_counts.hpp"
#include "workloads/rbe/summary_counts.hpp"

namespace dtflop::rbe::detail {
namespace {

constexpr int T = int(kFusionThreads);
constexpr int C = int(kFusionCells);
constexpr int kSums = 7;    // W, Wx, Wy, Wxx, Wxy, Wyy, W ln w
constexpr int kKey = 7;     // the largest cell's key (as the bits of a double slot)
constexpr int kScale = 8;   // the pending normalization S, copied beside the sums
constexpr int kHead = 9;    // then one footprint sum per point

struct DevicePoint {  // 32 bytes: 8 four-byte values (summary_counts.hpp)
  double x, y;
  int ix0, iy0, wx, wy;
};
static_assert(sizeof(DevicePoint) == 32, "8 values a point");

__device__ double warp_sum(double v) {
  for (int off = 16; off > 0; off >>= 1) v += __shfl_down_sync(0xffffffffu, v, off);
  return v;
}
__device__ unsigned long long warp_max(unsigned long long v) {
  for (int off = 16; off > 0; off >>= 1) {
    const unsigned long long o = __shfl_down_sync(0xffffffffu, v, off);
    v = o > v ? o : v;
  }
  return v;
}

__global__ void __launch_bounds__(T) rbe_summary_moments(const float* __restrict__ q, int nx, int ld, long long n,
                                                         double x0, double dx, double y0, double dy,
                                                         const double* __restrict__ den, double* __restrict__ out) {
  double s[kSums] = {0, 0, 0, 0, 0, 0, 0};
  unsigned long long key = 0;
  const long long base = static_cast<long long>(blockIdx.x) * (T * C);
  for (int c = 0; c < C; ++c) {
    const long long i = base + c * T + threadIdx.x;
    if (i >= n) break;
    const long long iy = i / nx, ix = i - iy * nx;
    const float v = q[iy * ld + ix];
    const double w = v;
    const double x = (double(ix) + 0.5) * dx + x0, y = (double(iy) + 0.5) * dy + y0;
    const double wx = w * x, wy = w * y;
    s[0] += w;
    s[1] += wx;
    s[2] += wy;
    s[3] += wx * x;
    s[4] += wx * y;
    s[5] += wy * y;
    if (v > 0.f) s[6] += w * log(w);
    const unsigned long long k =
        (static_cast<unsigned long long>(v > 0.f ? __float_as_uint(v) : 0u) << 32) |  // -0 and 0 alike
        (0xffffffffull - static_cast<unsigned long long>(i));
    key = k > key ? k : key;
  }
  __shared__ double red[kSums][T / 32];
  __shared__ unsigned long long kred[T / 32];
  const int lane = threadIdx.x % 32, warp = threadIdx.x / 32;
  for (int j = 0; j < kSums; ++j) {
    const double v = warp_sum(s[j]);
    if (lane == 0) red[j][warp] = v;
  }
  key = warp_max(key);
  if (lane == 0) kred[warp] = key;
  __syncthreads();
  if (warp == 0) {
    for (int j = 0; j < kSums; ++j) {
      const double v = warp_sum(lane < T / 32 ? red[j][lane] : 0.0);
      if (lane == 0) atomicAdd(out + j, v);
    }
    const unsigned long long k = warp_max(lane < T / 32 ? kred[lane] : 0ull);
    if (lane == 0) atomicMax(reinterpret_cast<unsigned long long*>(out + kKey), k);
  }
  if (blockIdx.x == 0 && threadIdx.x == 0) out[kScale] = *den;
}

__global__ void __launch_bounds__(T) rbe_summary_footprints(const float* __restrict__ q, int ld, double x0, double dx,
                                                            double y0, double dy, const DevicePoint* __restrict__ pts,
                                                            double neg_inv_two_s2, double* __restrict__ out) {
  const DevicePoint p = pts[blockIdx.y];
  const long long cells = static_cast<long long>(p.wx) * p.wy;
  const long long base = static_cast<long long>(blockIdx.x) * (T * C);
  double acc = 0;
  for (int c = 0; c < C; ++c) {
    const long long i = base + c * T + threadIdx.x;
    if (i >= cells) break;
    const long long ry = i / p.wx, rx = i - ry * p.wx;
    const long long ix = p.ix0 + rx, iy = p.iy0 + ry;
    const double ex = (double(ix) + 0.5) * dx + x0 - p.x, ey = (double(iy) + 0.5) * dy + y0 - p.y;
    acc += double(q[iy * ld + ix]) * exp((ex * ex + ey * ey) * neg_inv_two_s2);
  }
  __shared__ double red[T / 32];
  const int lane = threadIdx.x % 32, warp = threadIdx.x / 32;
  acc = warp_sum(acc);
  if (lane == 0) red[warp] = acc;
  __syncthreads();
  if (warp == 0) {
    acc = warp_sum(lane < T / 32 ? red[lane] : 0.0);
    if (lane == 0) atomicAdd(out + kHead + blockIdx.y, acc);
  }
}

}  // namespace

Summary DeviceSummary::summarize(const float* q, const double* denominator, const Grid& grid, std::int64_t ld,
                                 const Footprint& f, std::span<const Point> at, cudaStream_t stream) {
  check_footprint(f, at);
  if (at.size() > 65535)
    throw InputError(std::to_string(at.size()) + " footprint points asked for; give at most 65535");
  const std::size_t P = at.size();
  const std::int64_t nx = grid.nx(), n = grid.cells();
  if (out_.size() < kHead + P) out_ = DeviceArray<double>(kHead + P);
  DTFLOP_CUDA(cudaMemsetAsync(out_.get(), 0, (kHead + P) * sizeof(double), stream));
  // Coordinates about the grid's centre (xc, yc): raw second moments without cancellation.
  const double xc = 0.5 * (grid.x_min() + grid.x_max()), yc = 0.5 * (grid.y_min() + grid.y_max());
  const double x0 = grid.x_min() - xc, dx = grid.dx(), y0 = grid.y_min() - yc, dy = grid.dy();
  rbe_summary_moments<<<static_cast<unsigned>(fusion_blocks(n)), T, 0, stream>>>(q, int(nx), int(ld), n, x0, dx, y0,
                                                                                  dy, denominator, out_.get());
  DTFLOP_CUDA_LAUNCHED();
  std::vector<DevicePoint> pts(P);
  if (P > 0) {
    std::int64_t largest = 0;
    for (std::size_t j = 0; j < P; ++j) {
      const Window w = footprint_window(grid, f, at[j]);
      const bool empty = w.cells() == 0;
      pts[j] = {at[j].x - xc, at[j].y - yc, int(empty ? 0 : w.ix0), int(empty ? 0 : w.iy0), int(empty ? 0 : w.ix1 - w.ix0 + 1),
                int(empty ? 0 : w.iy1 - w.iy0 + 1)};
      largest = std::max(largest, w.cells());
    }
    const std::size_t bytes = P * sizeof(DevicePoint);
    if (points_.size() < bytes) points_ = DeviceArray<unsigned char>(bytes);
    DTFLOP_CUDA(cudaMemcpyAsync(points_.get(), pts.data(), bytes, cudaMemcpyHostToDevice, stream));
    const std::int64_t per_point = std::max<std::int64_t>(1, (largest + T * C - 1) / (T * C));
    const dim3 blocks(static_cast<unsigned>(per_point), static_cast<unsigned>(P));
    rbe_summary_footprints<<<blocks, T, 0, stream>>>(q, int(ld), x0, dx, y0, dy,
                                                      reinterpret_cast<const DevicePoint*>(points_.get()),
                                                      -1.0 / (2 * f.spread * f.spread), out_.get());
    DTFLOP_CUDA_LAUNCHED();
  }
  std::vector<double> h(kHead + P);
  DTFLOP_CUDA(cudaMemcpyAsync(h.data(), out_.get(), h.size() * sizeof(double), cudaMemcpyDeviceToHost, stream));
  DTFLOP_CUDA(cudaStreamSynchronize(stream));

  const double W = h[0], S = h[kScale];
  if (!(W > 0) || !std::isfinite(W) || !(S > 0) || !std::isfinite(S))
    throw InputError("summary: the belief holds no mass (sum " + std::to_string(W) + ", normalization " +
                     std::to_string(S) + "); give a belief with a positive cell");
  Summary r;
  Estimate& e = r.estimate;
  const double mx = h[1] / W, my = h[2] / W;  // about the centre
  e.mean_x = xc + mx;
  e.mean_y = yc + my;
  e.cov_xx = h[3] / W - mx * mx;
  e.cov_xy = h[4] / W - mx * my;
  e.cov_yy = h[5] / W - my * my;
  e.entropy = std::log(W) - h[6] / W;
  e.mass = W / S;
  unsigned long long key = 0;
  std::memcpy(&key, &h[kKey], sizeof key);
  const std::int64_t i = static_cast<std::int64_t>(0xffffffffull - (key & 0xffffffffull));
  e.map_iy = i / nx;
  e.map_ix = i - e.map_iy * nx;
  const Point mc = grid.centre(e.map_ix, e.map_iy);
  e.map_x = mc.x;
  e.map_y = mc.y;
  r.footprints.resize(P);
  const double scale = f.peak / S;
  for (std::size_t j = 0; j < P; ++j) r.footprints[j] = h[kHead + j] * scale;
  return r;
}

}  // namespace dtflop::rbe::detail
