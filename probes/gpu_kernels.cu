// On-device probes: device->device copies (cudaMemcpy and a copy kernel), FMA rate, launch
// overhead. Timed with events on a dedicated stream; every result checked.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "probes/gpu_common.cuh"
#include "probes/probe.hpp"

namespace dtflop::probes::gpu {

namespace {

using detail::DeviceBuffer;
using detail::Event;
using detail::Stream;

constexpr int kCopyThreads = 256;
constexpr int kCopyUnroll = 4;  // 16-byte loads in flight per thread

// Each block copies one tile of kCopyUnroll * blockDim 16-byte words: all loads first, then
// all stores, so four loads per thread are in flight; consecutive threads touch consecutive
// words (coalesced).
__global__ void __launch_bounds__(kCopyThreads)
    copy_kernel(const uint4* __restrict__ in, uint4* __restrict__ out, std::size_t n) {
  const std::size_t base =
      static_cast<std::size_t>(blockIdx.x) * blockDim.x * kCopyUnroll + threadIdx.x;
  uint4 v[kCopyUnroll];
#pragma unroll
  for (int u = 0; u < kCopyUnroll; ++u) {
    const std::size_t i = base + static_cast<std::size_t>(u) * blockDim.x;
    if (i < n) v[u] = in[i];
  }
#pragma unroll
  for (int u = 0; u < kCopyUnroll; ++u) {
    const std::size_t i = base + static_cast<std::size_t>(u) * blockDim.x;
    if (i < n) out[i] = v[u];
  }
}

// The copy with its working set in the L2 cache: `passes` sweeps over buffers that fit it, each a
// grid-stride loop of kCopyUnroll 16-byte loads in flight per thread that bypass L1
// (ld.global.cg), then their stores. Each pass starts one block's span further on (wrapping), so
// that a line is read by another block than in the pass before.
__global__ void __launch_bounds__(kCopyThreads)
    l2_copy_kernel(const uint4* __restrict__ in, uint4* __restrict__ out, std::size_t n, int passes) {
  const std::size_t stride = static_cast<std::size_t>(gridDim.x) * blockDim.x;
  const std::size_t tid = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  for (int p = 0; p < passes; ++p) {
    const std::size_t shift = (static_cast<std::size_t>(p) * blockDim.x * kCopyUnroll) % n;
    for (std::size_t k = tid; k < n; k += kCopyUnroll * stride) {
      uint4 v[kCopyUnroll];
#pragma unroll
      for (int u = 0; u < kCopyUnroll; ++u) {
        const std::size_t j = k + static_cast<std::size_t>(u) * stride;
        if (j < n) v[u] = __ldcg(in + (j + shift < n ? j + shift : j + shift - n));
      }
#pragma unroll
      for (int u = 0; u < kCopyUnroll; ++u) {
        const std::size_t j = k + static_cast<std::size_t>(u) * stride;
        if (j < n) __stcg(out + (j + shift < n ? j + shift : j + shift - n), v[u]);
      }
    }
  }
}

constexpr int kFmaThreads = 256;
constexpr int kFmaUnroll = 32;

// Chains independent recurrences x = fma(x, a, b) per thread, kFmaUnroll steps per loop trip
// (Chains * kFmaUnroll FMAs between two loop branches). Every end value is stored, so the
// compiler must compute them, and the host checks them.
template <typename T, int Chains>
__global__ void __launch_bounds__(kFmaThreads)
    fma_kernel(T* __restrict__ out, long long trips, T a, T b) {
  const unsigned tid = blockIdx.x * blockDim.x + threadIdx.x;
  T x[Chains];
#pragma unroll
  for (int j = 0; j < Chains; ++j) x[j] = static_cast<T>((tid & 1023u) + j);
  for (long long i = 0; i < trips; ++i) {
#pragma unroll
    for (int u = 0; u < kFmaUnroll; ++u) {
#pragma unroll
      for (int j = 0; j < Chains; ++j) x[j] = fma(x[j], a, b);
    }
  }
#pragma unroll
  for (int j = 0; j < Chains; ++j) out[static_cast<std::size_t>(tid) * Chains + j] = x[j];
}

__global__ void empty_kernel() {}

// One round's fixed work of a tile kernel: every thread writes its part of a shared array, a
// barrier, one thread writes the block's result. The shared array is sized so that one block
// fills a multiprocessor.
__global__ void wave_kernel(int* __restrict__ out) {
  extern __shared__ int tile[];
  const int words = static_cast<int>(blockDim.x) * 4;
  for (int i = threadIdx.x; i < words; i += blockDim.x) tile[i] = i;
  __syncthreads();
  if (threadIdx.x == 0) out[blockIdx.x] = tile[words - 1] + static_cast<int>(blockIdx.x);
}

// Checks `bytes` of `dst` against the pattern `seed`; throws ValidationError naming `what`.
void check_pattern(const DeviceBuffer& dst, std::size_t bytes, std::uint32_t seed,
                   const Stream& s, const char* what) {
  const std::size_t words = bytes / 4;
  const auto bad = detail::count_mismatches_device(dst.get<std::uint32_t>(), words, seed, s);
  if (bad != 0) detail::mismatch(what, bytes, bad, words);
}

// Times a copy (a kernel, or cudaMemcpyAsync): `warmup` untimed launches, the destination poisoned, then `reps` launches
// with events around each; checks the destination against the source's pattern `seed`.
template <class Launch>
std::vector<double> time_copies(const Stream& s, const DeviceBuffer& dst, std::size_t bytes, std::uint32_t seed,
                                int warmup, int reps, const char* what, Launch launch) {
  auto once = [&] {
    launch();
    DTFLOP_CUDA_LAUNCHED();
  };
  for (int i = 0; i < warmup; ++i) once();
  DTFLOP_CUDA(cudaMemsetAsync(dst.get(), 0xA5, bytes, s.get()));
  Event start, stop;
  std::vector<double> t;
  for (int i = 0; i < reps; ++i) {
    start.record(s);
    once();
    stop.record(s);
    t.push_back(detail::elapsed(start, stop));
  }
  check_pattern(dst, bytes, seed, s, what);
  return t;
}

// Kernel launches captured once in a CUDA graph (`enqueue` launches them on the stream) and
// launched as a whole: the device starts them one after another, the host out of the way.
class GraphBatch {
 public:
  template <class Enqueue>
  GraphBatch(const Stream& s, Enqueue enqueue) {
    cudaGraph_t graph = nullptr;
    DTFLOP_CUDA(cudaStreamBeginCapture(s.get(), cudaStreamCaptureModeThreadLocal));
    enqueue();
    const cudaError_t launched = cudaGetLastError();
    const cudaError_t captured = cudaStreamEndCapture(s.get(), &graph);
    if (launched != cudaSuccess || captured != cudaSuccess) {
      if (graph) cudaGraphDestroy(graph);
      DTFLOP_CUDA(launched);
      DTFLOP_CUDA(captured);
    }
    const cudaError_t made = cudaGraphInstantiate(&exec_, graph, 0);
    cudaGraphDestroy(graph);
    DTFLOP_CUDA(made);
  }
  GraphBatch(const GraphBatch&) = delete;
  GraphBatch& operator=(const GraphBatch&) = delete;
  ~GraphBatch() {
    if (exec_) cudaGraphExecDestroy(exec_);
  }
  void launch(const Stream& s) const { DTFLOP_CUDA(cudaGraphLaunch(exec_, s.get())); }

 private:
  cudaGraphExec_t exec_ = nullptr;
};

template <typename T, int Chains>
FmaTiming run_fma(double target_seconds, int reps) {
  detail::use_device();
  int sms = 0, per_sm = 0;
  DTFLOP_CUDA(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, 0));
  DTFLOP_CUDA(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, fma_kernel<T, Chains>,
                                                             kFmaThreads, 0));
  FmaTiming r;
  r.blocks = sms * std::max(per_sm, 1);
  r.threads_per_block = kFmaThreads;
  r.chains = Chains;
  const std::size_t threads = static_cast<std::size_t>(r.blocks) * kFmaThreads;
  DeviceBuffer out(threads * Chains * sizeof(T));
  Stream s;
  Event start, stop;
  // a = -1 and b = 3 arrive as kernel arguments, unknown to the compiler: each step is a real
  // FMA, and the exact result alternates between x0 and b - x0 (small integers, no rounding).
  const T a = T(-1), b = T(3);

  auto launch = [&](long long trips) {
    start.record(s);
    fma_kernel<T, Chains><<<r.blocks, kFmaThreads, 0, s.get()>>>(out.get<T>(), trips, a, b);
    DTFLOP_CUDA_LAUNCHED();
    stop.record(s);
    return detail::elapsed(start, stop);
  };
  // Warm-up, then size the kernel to the target time from a calibration run.
  launch(16);
  long long trips = 64;
  double t = launch(trips);
  while (t < target_seconds / 20 && trips < (1LL << 36)) {
    trips *= 8;
    t = launch(trips);
  }
  if (t > 0) {
    const double scaled = static_cast<double>(trips) * target_seconds / t;
    trips = std::clamp(static_cast<long long>(scaled), 1LL, 1LL << 40);
  }
  r.steps = trips * kFmaUnroll;
  r.flops = 2.0 * static_cast<double>(threads) * Chains * static_cast<double>(r.steps);
  DTFLOP_CUDA(cudaMemsetAsync(out.get(), 0xFF, out.bytes(), s.get()));  // poison (NaN)
  for (int i = 0; i < reps; ++i) r.seconds.push_back(launch(trips));

  std::vector<T> host(threads * Chains);
  DTFLOP_CUDA(cudaMemcpyAsync(host.data(), out.get(), out.bytes(), cudaMemcpyDeviceToHost, s.get()));
  s.sync();
  const bool odd = (r.steps % 2) != 0;
  std::size_t bad = 0;
  for (std::size_t t = 0; t < threads; ++t)
    for (int j = 0; j < Chains; ++j) {
      const T x0 = static_cast<T>((t & 1023u) + static_cast<unsigned>(j));
      const T expect = odd ? b - x0 : x0;
      bad += host[t * Chains + static_cast<std::size_t>(j)] != expect;
    }
  if (bad != 0)
    detail::mismatch(sizeof(T) == 8 ? "GPU fp64 FMA kernel: chain end values"
                                    : "GPU fp32 FMA kernel: chain end values",
                     out.bytes(), bad, threads * Chains);
  return r;
}

// cuda-seed's row pass without its multiply by the likelihood: the same loop, shape and layout.
__global__ void rows_kernel(const float* __restrict__ u, const float* __restrict__ k, int taps, int centre, int n,
                            float* __restrict__ out) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= n || y >= n) return;
  float acc = 0.f;
  for (int b = 0; b < taps; ++b) {
    const int j = y - (b - centre);
    acc = fmaf(k[b], (j >= 0 && j < n) ? u[std::size_t(j) * std::size_t(n) + x] : 0.f, acc);
  }
  out[std::size_t(y) * std::size_t(n) + x] = acc;
}

// cuda-seed's column pass: the same loop along the row (rbe_seed_column).
__global__ void along_row_kernel(const float* __restrict__ u, const float* __restrict__ k, int taps, int centre, int n,
                                 float* __restrict__ out) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= n || y >= n) return;
  const float* row = u + std::size_t(y) * std::size_t(n);
  float acc = 0.f;
  for (int a = 0; a < taps; ++a) {
    const int j = x - (a - centre);
    acc = fmaf(k[a], (j >= 0 && j < n) ? row[j] : 0.f, acc);
  }
  out[std::size_t(y) * std::size_t(n) + x] = acc;
}

}  // namespace

RowsTiming time_rows(int n, int taps, int reps, int warmup, TapDirection direction) {
  if (n < 64 || n > 16384 || taps < 1 || taps > 1025 || reps < 1 || warmup < 0)
    throw std::invalid_argument("time_rows: n in 64..16384, taps in 1..1025, reps >= 1, warmup >= 0");
  detail::use_device();
  const std::size_t cells = std::size_t(n) * std::size_t(n);
  DeviceBuffer u(cells * sizeof(float)), out(cells * sizeof(float)), k(std::size_t(taps) * sizeof(float));
  Stream s;
  Event start, stop;
  {
    const std::vector<float> ones(cells, 1.0f), halves(std::size_t(taps), 0.5f);
    DTFLOP_CUDA(cudaMemcpyAsync(u.get(), ones.data(), u.bytes(), cudaMemcpyHostToDevice, s.get()));
    DTFLOP_CUDA(cudaMemcpyAsync(k.get(), halves.data(), k.bytes(), cudaMemcpyHostToDevice, s.get()));
    s.sync();
  }
  const int centre = taps / 2;
  const dim3 block(32, 8), grid(unsigned((n + 31) / 32), unsigned((n + 7) / 8));
  const bool across = direction == TapDirection::across_rows;
  auto launch = [&] {
    if (across)
      rows_kernel<<<grid, block, 0, s.get()>>>(u.get<const float>(), k.get<const float>(), taps, centre, n,
                                               out.get<float>());
    else
      along_row_kernel<<<grid, block, 0, s.get()>>>(u.get<const float>(), k.get<const float>(), taps, centre, n,
                                                    out.get<float>());
    DTFLOP_CUDA_LAUNCHED();
  };
  for (int i = 0; i < warmup; ++i) launch();
  DTFLOP_CUDA(cudaMemsetAsync(out.get(), 0xFF, out.bytes(), s.get()));  // poison (NaN)
  RowsTiming r;
  r.n = n;
  r.taps = taps;
  r.flops = 2.0 * static_cast<double>(cells) * taps;
  for (int i = 0; i < reps; ++i) {
    start.record(s);
    launch();
    stop.record(s);
    r.seconds.push_back(detail::elapsed(start, stop));
  }
  std::vector<float> host(cells);
  DTFLOP_CUDA(cudaMemcpyAsync(host.data(), out.get(), out.bytes(), cudaMemcpyDeviceToHost, s.get()));
  s.sync();
  std::size_t bad = 0;
  // In-grid taps of cell (x, y): j = i - b + centre in [0, n) with i = y across rows, x along one.
  auto expect = [&](int i) {
    const int lo = std::max(0, i + centre - (n - 1)), hi = std::min(taps - 1, i + centre);
    return 0.5f * static_cast<float>(hi - lo + 1);
  };
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) bad += host[std::size_t(y) * std::size_t(n) + x] != expect(across ? y : x);
  if (bad != 0)
    detail::mismatch(across ? "GPU across-rows kernel: output cells" : "GPU along-row kernel: output cells", out.bytes(),
                     bad, cells);
  return r;
}

std::vector<double> time_d2d_memcpy(std::int64_t bytes, int reps, int warmup) {
  if (bytes <= 0 || bytes % 4 != 0 || reps < 1)
    throw std::invalid_argument("time_d2d_memcpy: bytes must be a positive multiple of 4, reps >= 1");
  detail::use_device();
  const auto n = static_cast<std::size_t>(bytes);
  DeviceBuffer src(n), dst(n);
  Stream s;
  const std::uint32_t seed = 0xD2D0u;
  detail::fill_pattern_device(src.get<std::uint32_t>(), n / 4, seed, s);
  return time_copies(s, dst, n, seed, warmup, reps, "device->device cudaMemcpy", [&] {
    DTFLOP_CUDA(cudaMemcpyAsync(dst.get(), src.get(), n, cudaMemcpyDeviceToDevice, s.get()));
  });
}

std::vector<double> time_copy_kernel(std::int64_t bytes, int reps, int warmup) {
  if (bytes <= 0 || bytes % 16 != 0 || reps < 1)
    throw std::invalid_argument("time_copy_kernel: bytes must be a positive multiple of 16, reps >= 1");
  detail::use_device();
  const auto n = static_cast<std::size_t>(bytes);
  const std::size_t words16 = n / 16;
  DeviceBuffer src(n), dst(n);
  Stream s;
  const std::uint32_t seed = 0xC0B1u;
  detail::fill_pattern_device(src.get<std::uint32_t>(), n / 4, seed, s);
  const std::size_t per_block = static_cast<std::size_t>(kCopyThreads) * kCopyUnroll;
  const auto blocks = static_cast<unsigned>((words16 + per_block - 1) / per_block);
  return time_copies(s, dst, n, seed, warmup, reps, "device copy kernel", [&] {
    copy_kernel<<<blocks, kCopyThreads, 0, s.get()>>>(src.get<const uint4>(), dst.get<uint4>(), words16);
  });
}

std::vector<double> time_l2_copy(std::int64_t bytes, int passes, int reps, int warmup) {
  if (bytes <= 0 || bytes % 16 != 0 || passes < 1 || reps < 1)
    throw std::invalid_argument("time_l2_copy: bytes must be a positive multiple of 16, passes and reps >= 1");
  detail::use_device();
  int sms = 0, per_sm = 0;
  DTFLOP_CUDA(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, 0));
  DTFLOP_CUDA(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, l2_copy_kernel, kCopyThreads, 0));
  const auto n = static_cast<std::size_t>(bytes);
  const std::size_t words16 = n / 16;
  DeviceBuffer src(n), dst(n);
  Stream s;
  const std::uint32_t seed = 0xC0B2u;
  detail::fill_pattern_device(src.get<std::uint32_t>(), n / 4, seed, s);
  // As many blocks as run at once: every multiprocessor busy, none waiting for a slot.
  const auto blocks = static_cast<unsigned>(sms * std::max(per_sm, 1));
  return time_copies(s, dst, n, seed, warmup, reps, "L2-resident copy kernel", [&] {
    l2_copy_kernel<<<blocks, kCopyThreads, 0, s.get()>>>(src.get<const uint4>(), dst.get<uint4>(), words16, passes);
  });
}

std::vector<double> time_graph_launches(int batch, int reps) {
  if (batch < 1 || reps < 1) throw std::invalid_argument("time_graph_launches: batch and reps must be >= 1");
  detail::use_device();
  Stream s;
  Event start, stop;
  const GraphBatch g(s, [&] {
    for (int i = 0; i < batch; ++i) empty_kernel<<<1, 32, 0, s.get()>>>();
  });
  g.launch(s);  // the first launch uploads the graph: out of the figures
  s.sync();
  std::vector<double> t;
  for (int k = 0; k < reps; ++k) {
    start.record(s);
    g.launch(s);
    stop.record(s);
    t.push_back(detail::elapsed(start, stop) / batch);
  }
  return t;
}

FmaTiming time_fma(bool fp64, double target_seconds, int reps, int chains) {
  if (!(target_seconds > 0) || reps < 1)
    throw std::invalid_argument("time_fma: target_seconds must be > 0 and reps >= 1");
  switch (chains) {
    case 4: return fp64 ? run_fma<double, 4>(target_seconds, reps) : run_fma<float, 4>(target_seconds, reps);
    case 8: return fp64 ? run_fma<double, 8>(target_seconds, reps) : run_fma<float, 8>(target_seconds, reps);
    case 16: return fp64 ? run_fma<double, 16>(target_seconds, reps) : run_fma<float, 16>(target_seconds, reps);
  }
  throw std::invalid_argument("time_fma: chains must be 4, 8 or 16");
}

LaunchTiming time_launches(int batch, int reps) {
  if (batch < 1 || reps < 1) throw std::invalid_argument("time_launches: batch and reps must be >= 1");
  detail::use_device();
  Stream s;
  Event start, stop;
  LaunchTiming r;
  r.batch = batch;
  // Warm-up: module load and the first launch's set-up stay out of the figures.
  for (int i = 0; i < 100; ++i) {
    empty_kernel<<<1, 32, 0, s.get()>>>();
    DTFLOP_CUDA_LAUNCHED();
  }
  s.sync();
  for (int k = 0; k < reps; ++k) {
    start.record(s);
    for (int i = 0; i < batch; ++i) {
      empty_kernel<<<1, 32, 0, s.get()>>>();
      DTFLOP_CUDA_LAUNCHED();
    }
    stop.record(s);
    r.per_launch.push_back(detail::elapsed(start, stop) / batch);
  }
  // Round trips are cheap: ten times as many, for a steady median.
  for (int k = 0; k < 10 * reps; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    empty_kernel<<<1, 32, 0, s.get()>>>();
    DTFLOP_CUDA_LAUNCHED();
    s.sync();
    const auto t1 = std::chrono::steady_clock::now();
    r.round_trip.push_back(std::chrono::duration<double>(t1 - t0).count());
  }
  return r;
}

WaveTiming time_waves(int batch, int reps) {
  if (batch < 1 || reps < 1) throw std::invalid_argument("time_waves: batch and reps must be >= 1");
  detail::use_device();
  int sms = 0, max_smem = 0, smem_per_sm = 0;
  DTFLOP_CUDA(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, 0));
  DTFLOP_CUDA(cudaDeviceGetAttribute(&max_smem, cudaDevAttrMaxSharedMemoryPerBlockOptin, 0));
  DTFLOP_CUDA(cudaDeviceGetAttribute(&smem_per_sm, cudaDevAttrMaxSharedMemoryPerMultiprocessor, 0));
  const int threads = 256;
  // More than half of what an SM holds, so one block per SM; at least what the tile needs.
  const int smem = std::max(threads * 4 * static_cast<int>(sizeof(int)), std::min(max_smem, smem_per_sm / 2 + 1024));
  DTFLOP_CUDA(cudaFuncSetAttribute(wave_kernel, cudaFuncAttributeMaxDynamicSharedMemorySize, smem));
  WaveTiming r;
  DTFLOP_CUDA(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&r.blocks_per_sm, wave_kernel, threads, smem));
  if (r.blocks_per_sm < 1) throw ValidationError("the wave kernel cannot run: no block fits on a multiprocessor");
  // Rounds enough that a launch lasts longer than the launch rate allows (back-to-back launches
  // of a kernel shorter than that all take the launch interval, and their slope would be zero).
  const std::vector<int> rounds = {4, 8, 16, 32};
  const int max_waves = rounds.back();
  const std::int64_t max_blocks = static_cast<std::int64_t>(max_waves) * sms * r.blocks_per_sm;
  DeviceBuffer out(static_cast<std::size_t>(max_blocks) * sizeof(int));
  Stream s;
  Event start, stop;
  for (int waves : rounds) {
    const int blocks = waves * sms * r.blocks_per_sm;
    DTFLOP_CUDA(cudaMemsetAsync(out.get(), 0xFF, out.bytes(), s.get()));  // poison: -1 everywhere
    wave_kernel<<<blocks, threads, smem, s.get()>>>(out.get<int>());  // writes every block's result
    DTFLOP_CUDA_LAUNCHED();
    // Every block wrote its result: the kernel really ran, with that many blocks.
    std::vector<int> host(static_cast<std::size_t>(blocks));
    DTFLOP_CUDA(cudaMemcpyAsync(host.data(), out.get(), host.size() * sizeof(int), cudaMemcpyDeviceToHost, s.get()));
    s.sync();
    const int last = threads * 4 - 1;
    for (int b = 0; b < blocks; ++b)
      if (host[static_cast<std::size_t>(b)] != last + b)
        throw ValidationError("the wave kernel's block " + std::to_string(b) + " wrote " +
                              std::to_string(host[static_cast<std::size_t>(b)]) + ", not " + std::to_string(last + b));
    // The batch is a CUDA graph: the device starts its kernels one after another, so a kernel
    // shorter than the host's launch interval is timed as itself, not as that interval (launched
    // from the host, 4 and 8 rounds took the same 4.5 us on an H200 and the slope could vanish).
    const GraphBatch g(s, [&] {
      for (int i = 0; i < batch; ++i) wave_kernel<<<blocks, threads, smem, s.get()>>>(out.get<int>());
    });
    for (int i = 0; i < 2; ++i) g.launch(s);  // upload, warm-up
    std::vector<double> t;
    for (int k = 0; k < reps; ++k) {
      start.record(s);
      g.launch(s);
      stop.record(s);
      t.push_back(detail::elapsed(start, stop) / batch);
    }
    std::nth_element(t.begin(), t.begin() + static_cast<std::ptrdiff_t>(t.size() / 2), t.end());
    r.waves.push_back(waves);
    r.seconds.push_back(t[t.size() / 2]);
  }
  // Least-squares slope of time against rounds.
  double mx = 0, my = 0;
  for (std::size_t i = 0; i < r.waves.size(); ++i) {
    mx += r.waves[i];
    my += r.seconds[i];
  }
  mx /= static_cast<double>(r.waves.size());
  my /= static_cast<double>(r.waves.size());
  double sxy = 0, sxx = 0;
  for (std::size_t i = 0; i < r.waves.size(); ++i) {
    sxy += (r.waves[i] - mx) * (r.seconds[i] - my);
    sxx += (r.waves[i] - mx) * (r.waves[i] - mx);
  }
  r.per_wave = sxy / sxx;
  return r;
}

}  // namespace dtflop::probes::gpu
