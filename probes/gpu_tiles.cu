// Shared-memory tile fills (B_GS) and serialized atomics (L_atomic): the two things cuda-resident's
// tile kernel does besides its FMAs (workloads/rbe/cuda_resident.cu), each in a kernel of its own,
// timed with events on a dedicated stream, every result checked.
#include <cuda.h>  // CUtensorMap and its enums (the encoder is reached through the runtime)

#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

#include "cuda/tma.cuh"
#include "probes/gpu_common.cuh"
#include "probes/probe.hpp"
#include "probes/tile_fill.hpp"

namespace dtflop::probes::gpu {

namespace {

using detail::DeviceBuffer;
using detail::Event;
using detail::Stream;

constexpr int kCols4 = tiles::kCols / 4;  // 16-byte pieces in a tile row
// After the tile: 8 warp partials (floats) and the accelerator's mbarrier (8 bytes).
constexpr int kScratchBytes = 64;

// Block b fills its tile (tiles::tile_origin: x a multiple of 4, the tile inside the grid), waits
// for it, sums its rows x kCols values and writes the sum to out[b]. Tma: thread 0 starts one
// box copy of rows x kPitch floats (the box is as wide as the tile's pitch, as cuda-resident's)
// and every thread waits on an mbarrier counting the bytes; else every thread copies 16-byte
// pieces with cp.async and waits for its own, then a barrier.
template <bool Tma>
__global__ void __launch_bounds__(tiles::kThreads)
    fill_kernel(const float* __restrict__ grid, int n, int rows, int per_row, const __grid_constant__ CUtensorMap map,
                float* __restrict__ out) {
  extern __shared__ __align__(128) float tile[];
  float* red = tile + rows * tiles::kPitch;  // 16-byte aligned: kPitch x 4 bytes is a multiple of 16
  auto* bar = reinterpret_cast<unsigned long long*>(red + 8);
  const int tid = threadIdx.x, T = blockDim.x;
  const int b = blockIdx.x;
  const int x0 = (b % per_row) * tiles::kOutWidth;
  const int y0 = static_cast<int>(static_cast<long long>(b / per_row) * (rows - tiles::kHaloRows) % (n - rows + 1));
  if constexpr (Tma) {
    if (tid == 0) {
      cuda::tma::arm(bar, unsigned(rows * tiles::kPitch) * 4u);
      cuda::tma::copy_box(tile, &map, x0, y0, bar);
    }
    __syncthreads();  // the barrier is initialized before anyone waits on it
    cuda::tma::wait(bar);
  } else {
    for (int i = tid; i < rows * kCols4; i += T) {
      const int r = i / kCols4, c = i - r * kCols4;
      const float* src = grid + (static_cast<std::size_t>(y0 + r) * static_cast<std::size_t>(n) + x0 + 4 * c);
      asm volatile("cp.async.cg.shared.global [%0], [%1], 16;\n" ::"r"(cuda::tma::smem_addr(tile + r * tiles::kPitch + 4 * c)),
                   "l"(src)
                   : "memory");
    }
    asm volatile("cp.async.wait_all;\n" ::: "memory");
    __syncthreads();
  }
  // Consume the tile: every value of its kCols columns (not the pitch's padding), float4 loads.
  float s = 0.f;
  for (int i = tid; i < rows * kCols4; i += T) {
    const int r = i / kCols4, c = i - r * kCols4;
    const float4 v = *reinterpret_cast<const float4*>(tile + r * tiles::kPitch + 4 * c);
    s += (v.x + v.y) + (v.z + v.w);
  }
#pragma unroll
  for (int off = 16; off > 0; off >>= 1) s += __shfl_down_sync(0xffffffffu, s, off);
  const int lane = tid & 31, warp = tid >> 5;
  if (lane == 0) red[warp] = s;
  __syncthreads();
  if (warp == 0) {
    s = lane < (T >> 5) ? red[lane] : 0.f;
#pragma unroll
    for (int off = 16; off > 0; off >>= 1) s += __shfl_down_sync(0xffffffffu, s, off);
    if (lane == 0) out[b] = s;
  }
  if constexpr (Tma) {
    if (tid == 0) cuda::tma::done(bar);
  }
}

// cuTensorMapEncodeTiled through the runtime (no link against the driver library); null when the
// driver does not offer it.
using EncodeTiled = CUresult (*)(CUtensorMap*, CUtensorMapDataType, cuuint32_t, void*, const cuuint64_t*,
                                 const cuuint64_t*, const cuuint32_t*, const cuuint32_t*, CUtensorMapInterleave,
                                 CUtensorMapSwizzle, CUtensorMapL2promotion, CUtensorMapFloatOOBfill);
EncodeTiled tensor_map_encoder() {
  void* p = nullptr;
  cudaDriverEntryPointQueryResult q{};
  if (cudaGetDriverEntryPointByVersion("cuTensorMapEncodeTiled", &p, 12000, cudaEnableDefault, &q) != cudaSuccess ||
      q != cudaDriverEntryPointSuccess) {
    (void)cudaGetLastError();
    return nullptr;
  }
  return reinterpret_cast<EncodeTiled>(p);
}

}  // namespace

bool tma_available() {
  try {
    detail::use_device();
  } catch (const std::exception&) {
    return false;
  }
  int major = 0;
  if (cudaDeviceGetAttribute(&major, cudaDevAttrComputeCapabilityMajor, 0) != cudaSuccess) {
    (void)cudaGetLastError();
    return false;
  }
  return major >= 9 && tensor_map_encoder() != nullptr;
}

FillTiming time_tile_fills(bool tma, int rounds, int batch, int reps) {
  if (rounds < 1 || rounds > 64 || batch < 1 || reps < 1)
    throw std::invalid_argument("time_tile_fills: rounds in 1..64, batch and reps >= 1");
  detail::use_device();
  if (tma && !tma_available())
    throw GpuError("this device or driver has no tensor memory accelerator (compute capability 9 and "
                   "cuTensorMapEncodeTiled are needed)");
  int sms = 0, smem_per_sm = 0, max_optin = 0, reserved = 0;
  DTFLOP_CUDA(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, 0));
  DTFLOP_CUDA(cudaDeviceGetAttribute(&smem_per_sm, cudaDevAttrMaxSharedMemoryPerMultiprocessor, 0));
  DTFLOP_CUDA(cudaDeviceGetAttribute(&max_optin, cudaDevAttrMaxSharedMemoryPerBlockOptin, 0));
  DTFLOP_CUDA(cudaDeviceGetAttribute(&reserved, cudaDevAttrReservedSharedMemoryPerBlock, 0));
  // Every height gets the same shared memory: as much as lets kBlocksPerSm blocks share a
  // multiprocessor, so that the heights differ only in the bytes filled.
  const int smem = std::min(max_optin, (smem_per_sm / tiles::kBlocksPerSm - reserved) / 128 * 128);
  const std::vector<int> heights = tiles::fill_rows(smem, kScratchBytes);
  if (heights.size() < 3)
    throw ValidationError("the tile-fill kernel needs " + std::to_string(tiles::kBlocksPerSm) +
                          " blocks of at least 96 tile rows on a multiprocessor; this device has " +
                          std::to_string(smem_per_sm) + " bytes of shared memory per multiprocessor");
  const auto kernel = tma ? fill_kernel<true> : fill_kernel<false>;
  DTFLOP_CUDA(cudaFuncSetAttribute(kernel, cudaFuncAttributeMaxDynamicSharedMemorySize, smem));
  DTFLOP_CUDA(cudaFuncSetAttribute(kernel, cudaFuncAttributePreferredSharedMemoryCarveout, cudaSharedmemCarveoutMaxShared));
  FillTiming r;
  r.tma = tma;
  r.sms = sms;
  DTFLOP_CUDA(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&r.occ, kernel, tiles::kThreads, smem));
  if (r.occ < 1) throw ValidationError("the tile-fill kernel cannot run: no block fits on a multiprocessor");
  r.blocks = rounds * r.occ * sms;

  const int n = tiles::kGridN;
  const std::vector<float> host_grid = tiles::make_grid(n);
  const tiles::GridSums sums(host_grid, n);
  DeviceBuffer grid(host_grid.size() * sizeof(float)), out(static_cast<std::size_t>(r.blocks) * sizeof(float));
  Stream s;
  Event start, stop;
  DTFLOP_CUDA(cudaMemcpyAsync(grid.get(), host_grid.data(), grid.bytes(), cudaMemcpyHostToDevice, s.get()));
  const int per_row = (n - tiles::kPitch) / tiles::kOutWidth + 1;
  std::vector<float> got(static_cast<std::size_t>(r.blocks));
  for (const int rows : heights) {
    CUtensorMap map;
    std::memset(&map, 0, sizeof(map));
    if (tma) {
      // The grid as a 2D tensor, boxes of kPitch x rows floats (the padding columns of a tile's
      // rows come from the grid's next columns, which lie inside it: tile_origin()).
      const cuuint64_t dims[2] = {cuuint64_t(n), cuuint64_t(n)};
      const cuuint64_t strides[1] = {cuuint64_t(n) * sizeof(float)};
      const cuuint32_t box[2] = {cuuint32_t(tiles::kPitch), cuuint32_t(rows)};
      const cuuint32_t element_strides[2] = {1, 1};
      if (tensor_map_encoder()(&map, CU_TENSOR_MAP_DATA_TYPE_FLOAT32, 2, grid.get(), dims, strides, box,
                               element_strides, CU_TENSOR_MAP_INTERLEAVE_NONE, CU_TENSOR_MAP_SWIZZLE_NONE,
                               CU_TENSOR_MAP_L2_PROMOTION_L2_128B, CU_TENSOR_MAP_FLOAT_OOB_FILL_NONE) != CUDA_SUCCESS)
        throw GpuError("cuTensorMapEncodeTiled refused the tile-fill probe's tensor map (" + std::to_string(rows) +
                       " rows of " + std::to_string(tiles::kPitch) + " floats)");
    }
    auto launch = [&] {
      kernel<<<r.blocks, tiles::kThreads, smem, s.get()>>>(grid.get<const float>(), n, rows, per_row, map,
                                                           out.get<float>());
      DTFLOP_CUDA_LAUNCHED();
    };
    for (int i = 0; i < 3; ++i) launch();
    DTFLOP_CUDA(cudaMemsetAsync(out.get(), 0xFF, out.bytes(), s.get()));  // poison (NaN)
    FillPoint p;
    p.rows = rows;
    for (int k = 0; k < reps; ++k) {
      start.record(s);
      for (int i = 0; i < batch; ++i) launch();
      stop.record(s);
      p.seconds.push_back(detail::elapsed(start, stop) / batch);
    }
    DTFLOP_CUDA(cudaMemcpyAsync(got.data(), out.get(), out.bytes(), cudaMemcpyDeviceToHost, s.get()));
    s.sync();
    std::size_t bad = 0;
    for (int b = 0; b < r.blocks; ++b) {
      const tiles::Origin o = tiles::tile_origin(b, rows, n);
      bad += static_cast<double>(got[static_cast<std::size_t>(b)]) !=
             static_cast<double>(sums.sum(o.x, o.y, tiles::kCols, rows));
    }
    if (bad != 0)
      detail::mismatch(tma ? "GPU tile fills (tensor memory accelerator): block sums"
                           : "GPU tile fills (cp.async): block sums",
                       out.bytes(), bad, static_cast<std::uint64_t>(r.blocks));
    const std::int64_t values = std::int64_t{rows} * tiles::kCols;
    p.counted_bytes = tiles::counted_fill_bytes(r.blocks, sms, r.occ, values);
    p.filled_bytes = std::int64_t{r.blocks} * values * static_cast<std::int64_t>(sizeof(float));
    r.points.push_back(std::move(p));
  }
  return r;
}

namespace {

// Block b's threads hold ((t + b) & 7), thread 0 also b % 5: the block's sum is 896 + b % 5
// (256 threads: each residue mod 8 32 times), exact in float64. Atomic: added to *sum; else
// stored to out[b].
template <bool Atomic>
__global__ void __launch_bounds__(256) atomic_kernel(double* __restrict__ sum, double* __restrict__ out) {
  __shared__ double red[8];
  const int tid = threadIdx.x, b = blockIdx.x;
  double v = static_cast<double>((tid + b) & 7) + (tid == 0 ? static_cast<double>(b % 5) : 0.0);
#pragma unroll
  for (int off = 16; off > 0; off >>= 1) v += __shfl_down_sync(0xffffffffu, v, off);
  const int lane = tid & 31, warp = tid >> 5;
  if (lane == 0) red[warp] = v;
  __syncthreads();
  if (warp == 0) {
    v = lane < 8 ? red[lane] : 0.0;
#pragma unroll
    for (int off = 4; off > 0; off >>= 1) v += __shfl_down_sync(0xffffffffu, v, off);
    if (lane == 0) {
      if constexpr (Atomic)
        atomicAdd(sum, v);
      else
        out[b] = v;
    }
  }
}

double block_sum(int b) { return 896.0 + b % 5; }

}  // namespace

AtomicTiming time_atomics(std::span<const int> blocks_per_sm, int batch, int reps) {
  if (blocks_per_sm.size() < 3 || batch < 1 || reps < 1)
    throw std::invalid_argument("time_atomics: at least 3 block counts, batch and reps >= 1");
  for (int k : blocks_per_sm)
    if (k < 1 || k > 1024) throw std::invalid_argument("time_atomics: blocks per multiprocessor in 1..1024");
  detail::use_device();
  int sms = 0;
  DTFLOP_CUDA(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, 0));
  const int most = *std::max_element(blocks_per_sm.begin(), blocks_per_sm.end()) * sms;
  DeviceBuffer sum(sizeof(double)), out(static_cast<std::size_t>(most) * sizeof(double));
  Stream s;
  Event start, stop;
  AtomicTiming r;
  for (const int k : blocks_per_sm) {
    const int blocks = k * sms;
    double per_launch = 0;
    for (int b = 0; b < blocks; ++b) per_launch += block_sum(b);
    std::vector<double> ta, tb;
    // Atomic adds: the sum is zeroed before each batch and must be the batch's launches' total.
    for (int i = 0; i < 3; ++i) {
      atomic_kernel<true><<<blocks, 256, 0, s.get()>>>(sum.get<double>(), nullptr);
      DTFLOP_CUDA_LAUNCHED();
    }
    for (int rep = 0; rep < reps; ++rep) {
      DTFLOP_CUDA(cudaMemsetAsync(sum.get(), 0, sizeof(double), s.get()));
      start.record(s);
      for (int i = 0; i < batch; ++i) {
        atomic_kernel<true><<<blocks, 256, 0, s.get()>>>(sum.get<double>(), nullptr);
        DTFLOP_CUDA_LAUNCHED();
      }
      stop.record(s);
      ta.push_back(detail::elapsed(start, stop) / batch);
      double got = 0;
      DTFLOP_CUDA(cudaMemcpyAsync(&got, sum.get(), sizeof(double), cudaMemcpyDeviceToHost, s.get()));
      s.sync();
      if (got != per_launch * batch)
        throw ValidationError("GPU atomics: " + std::to_string(batch) + " launches of " + std::to_string(blocks) +
                              " blocks added " + std::to_string(got) + " to the one sum, not " +
                              std::to_string(per_launch * batch));
    }
    // Stores: every block's word, checked after the last batch.
    for (int i = 0; i < 3; ++i) {
      atomic_kernel<false><<<blocks, 256, 0, s.get()>>>(nullptr, out.get<double>());
      DTFLOP_CUDA_LAUNCHED();
    }
    DTFLOP_CUDA(cudaMemsetAsync(out.get(), 0xFF, out.bytes(), s.get()));  // poison (NaN)
    for (int rep = 0; rep < reps; ++rep) {
      start.record(s);
      for (int i = 0; i < batch; ++i) {
        atomic_kernel<false><<<blocks, 256, 0, s.get()>>>(nullptr, out.get<double>());
        DTFLOP_CUDA_LAUNCHED();
      }
      stop.record(s);
      tb.push_back(detail::elapsed(start, stop) / batch);
    }
    std::vector<double> host(static_cast<std::size_t>(blocks));
    DTFLOP_CUDA(cudaMemcpyAsync(host.data(), out.get(), host.size() * sizeof(double), cudaMemcpyDeviceToHost, s.get()));
    s.sync();
    std::size_t bad = 0;
    for (int b = 0; b < blocks; ++b) bad += host[static_cast<std::size_t>(b)] != block_sum(b);
    if (bad != 0)
      detail::mismatch("GPU block sums (the atomics probe's control kernel)", host.size() * sizeof(double), bad,
                       host.size());
    r.blocks.push_back(blocks);
    r.atomic.push_back(std::move(ta));
    r.stored.push_back(std::move(tb));
  }
  return r;
}

}  // namespace dtflop::probes::gpu
