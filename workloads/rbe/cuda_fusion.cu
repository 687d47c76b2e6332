// The device's belief fusion (cuda_fusion.hpp). One thread takes kFusionCells cells kFusionThreads
// apart (coalesced), a block kFusionThreads x kFusionCells consecutive cells; the block's sum is
// reduced by warp shuffles and added to one float64 in device memory. Counts: fusion_counts.hpp.
#include <cuda_runtime.h>

#include "cuda/check.hpp"
#include "workloads/rbe/cuda_fusion.hpp"
#include "workloads/rbe/fusion_counts.hpp"

namespace dtflop::rbe::detail {
namespace {

constexpr int T = int(kFusionThreads);
constexpr int C = int(kFusionCells);
static_assert(T % 32 == 0 && T <= 1024, "whole warps");

// The m beliefs in order: others[] around the own one at `position` (own x s, s = 1 / (area x
// *den) when den is given: its wire values). product: v = b_0 x b_1 x ...; log-linear: v = exp(w
// (log b_0 + log b_1 + ...)) (log 0 = -inf, exp(-inf) = 0: a zero stays zero at the same cost).
template <bool kLog>
__global__ void __launch_bounds__(T) rbe_fuse(const float* __restrict__ own, const double* __restrict__ den,
                                              double area, int position, float* __restrict__ out, int nx, int ld,
                                              long long n, const float* __restrict__ others, int m, float w,
                                              double* __restrict__ sum) {
  const float s = den ? static_cast<float>(1.0 / (area * *den)) : 1.f;
  const long long base = static_cast<long long>(blockIdx.x) * (T * C);
  float acc = 0.f;
  for (int c = 0; c < C; ++c) {
    const long long i = base + c * T + threadIdx.x;
    if (i >= n) break;
    const long long y = i / nx, x = i - y * nx;
    const long long at = y * ld + x;
    const float mine = den ? own[at] * s : own[at];
    float v = 0.f;
    for (int j = 0; j < m; ++j) {
      const float b = j == position ? mine : others[(j < position ? j : j - 1) * n + i];
      if (!kLog) v = j == 0 ? b : v * b;
      else v = j == 0 ? logf(b) : v + logf(b);
    }
    if (kLog) v = expf(w * v);
    out[at] = v;
    acc += v;
  }
  for (int off = 16; off > 0; off >>= 1) acc += __shfl_down_sync(0xffffffffu, acc, off);
  __shared__ float red[T / 32];
  const int lane = threadIdx.x % 32, warp = threadIdx.x / 32;
  if (lane == 0) red[warp] = acc;
  __syncthreads();
  if (warp == 0) {
    acc = lane < T / 32 ? red[lane] : 0.f;
    for (int off = 16; off > 0; off >>= 1) acc += __shfl_down_sync(0xffffffffu, acc, off);
    if (lane == 0) atomicAdd(sum, static_cast<double>(acc));
  }
}

__global__ void __launch_bounds__(T) rbe_fusion_scale(const float* __restrict__ in, int nx, int ld, long long n,
                                                      const double* __restrict__ denominator, double area, float scale,
                                                      float* __restrict__ out) {
  const float s = denominator ? static_cast<float>(1.0 / (area * *denominator)) : scale;
  const long long base = static_cast<long long>(blockIdx.x) * (T * C);
  for (int j = 0; j < C; ++j) {
    const long long i = base + j * T + threadIdx.x;
    if (i >= n) break;
    const long long y = i / nx, x = i - y * nx;
    out[i] = in[y * ld + x] * s;
  }
}

}  // namespace

double DeviceFusion::fuse(FusionRule rule, const float* own, const double* own_denominator, double area,
                          std::size_t position, float* out, std::int64_t nx, std::int64_t ny, std::int64_t ld,
                          std::span<const std::span<const float>> others, cudaStream_t stream) {
  const std::int64_t n = nx * ny;
  const std::size_t k = others.size();
  if (others_.size() < k * std::size_t(n)) others_ = DeviceArray<float>(k * std::size_t(n));
  if (!sum_.get()) sum_ = DeviceArray<double>(1);
  for (std::size_t p = 0; p < k; ++p)
    DTFLOP_CUDA(cudaMemcpyAsync(others_.get() + p * std::size_t(n), others[p].data(), std::size_t(n) * sizeof(float),
                                cudaMemcpyHostToDevice, stream));
  DTFLOP_CUDA(cudaMemsetAsync(sum_.get(), 0, sizeof(double), stream));
  const unsigned blocks = static_cast<unsigned>(fusion_blocks(n));
  const int m = int(k + 1);
  const float w = 1.0f / static_cast<float>(m);
  if (rule == FusionRule::product)
    rbe_fuse<false><<<blocks, T, 0, stream>>>(own, own_denominator, area, int(position), out, int(nx), int(ld), n,
                                               others_.get(), m, w, sum_.get());
  else
    rbe_fuse<true><<<blocks, T, 0, stream>>>(own, own_denominator, area, int(position), out, int(nx), int(ld), n,
                                              others_.get(), m, w, sum_.get());
  DTFLOP_CUDA_LAUNCHED();
  double S = 0;
  DTFLOP_CUDA(cudaMemcpyAsync(&S, sum_.get(), sizeof(double), cudaMemcpyDeviceToHost, stream));
  DTFLOP_CUDA(cudaStreamSynchronize(stream));
  return S;
}

void launch_fusion_scale(const float* in, std::int64_t nx, std::int64_t ny, std::int64_t ld, const double* denominator,
                         double area, float scale, float* out, cudaStream_t stream) {
  const std::int64_t n = nx * ny;
  rbe_fusion_scale<<<static_cast<unsigned>(fusion_blocks(n)), T, 0, stream>>>(in, int(nx), int(ld), n, denominator,
                                                                               area, scale, out);
  DTFLOP_CUDA_LAUNCHED();
}

}  // namespace dtflop::rbe::detail
