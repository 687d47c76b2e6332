// gpu-frame-pass's kernels: passes over a whole frame, a thread a pixel, in the three shapes the DCT
// cuda backend's labelling passes take (workloads/dct/cuda_kernels.cu: k_init; k_union's reads of a
// pixel's left and upper neighbours; k_compress and k_ids following a label), timed with events.
// They are not the backend's kernels: a probe measures the machine, and these are what any
// labelling of a frame does a pixel at a time.
#include <algorithm>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

#include "probes/gpu_common.cuh"

namespace dtflop::probes::gpu {

namespace {

using detail::DeviceBuffer;
using detail::Stream;

constexpr int kBatch = 5;        // launches a timed repetition holds
constexpr int kThreshold = 127;  // pixels above it are foreground
constexpr int kPitch = 32;       // the frame's dots: one every 32 px each way,
constexpr int kRadius = 5;       // of radius 5 px (7.7% of the pixels)

// The frame: bright dots on a dark background, as a labelling's frames are (the DCT workload's
// hold 100-1600 dots of radius 4-24 px on 0.3-24 MP). Most warps of a pass then find only
// background and take its short path, as the workload's do; a pattern scattered pixel by pixel would
// send every warp down the foreground's path and price a pass 30-70% higher than a frame's.
__host__ __device__ inline std::uint8_t grey(std::int64_t i, int w) {
  const int x = static_cast<int>(i % w) % kPitch - kPitch / 2, y = static_cast<int>(i / w) % kPitch - kPitch / 2;
  return x * x + y * y <= kRadius * kRadius ? 200 : 40;
}

// The grid of a pass launched as the backend launches its own: a thread a pixel, capped where the
// grid is wider than a dimension allows, the threads then striding over the rest.
int grid_for(std::int64_t n, int block) {
  const std::int64_t g = (n + block - 1) / block;
  return static_cast<int>(std::min<std::int64_t>(std::max<std::int64_t>(g, 1), 65535LL * 32));
}

__global__ void threshold_pass(const std::uint8_t* img, std::int64_t n, int* out) {
  for (std::int64_t i = blockIdx.x * static_cast<std::int64_t>(blockDim.x) + threadIdx.x; i < n;
       i += static_cast<std::int64_t>(gridDim.x) * blockDim.x)
    out[i] = img[i] > kThreshold ? static_cast<int>(i) : -1;
}

// The two passes after the threshold write a foreground pixel's label only, as a labelling's unions
// and relabellings do (its background stays -1); out of place, so that the result does not depend
// on the threads' order, into a buffer filled with -1 first (the background the threshold wrote).
__global__ void neighbours_pass(const int* in, int w, std::int64_t n, int* out) {
  for (std::int64_t i = blockIdx.x * static_cast<std::int64_t>(blockDim.x) + threadIdx.x; i < n;
       i += static_cast<std::int64_t>(gridDim.x) * blockDim.x) {
    int v = in[i];
    if (v < 0) continue;
    const int x = static_cast<int>(i % w);
    const int left = x > 0 ? in[i - 1] : -1, up = i >= w ? in[i - w] : -1;
    if (left >= 0) v = min(v, left);
    if (up >= 0) v = min(v, up);
    out[i] = v;
  }
}

__global__ void relabel_pass(const int* in, std::int64_t n, int* out) {
  for (std::int64_t i = blockIdx.x * static_cast<std::int64_t>(blockDim.x) + threadIdx.x; i < n;
       i += static_cast<std::int64_t>(gridDim.x) * blockDim.x) {
    const int v = in[i];
    if (v >= 0) out[i] = in[v];
  }
}

// The same passes on the host, for the check.
std::vector<int> host_pass(FramePass pass, const std::vector<std::uint8_t>& img, const std::vector<int>& in, int w) {
  const std::size_t n = img.size();
  std::vector<int> out(n, -1);
  for (std::size_t i = 0; i < n; ++i) {
    switch (pass) {
      case FramePass::threshold: out[i] = img[i] > kThreshold ? static_cast<int>(i) : -1; break;
      case FramePass::neighbours: {
        int v = in[i];
        if (v < 0) break;
        const int left = i % static_cast<std::size_t>(w) > 0 ? in[i - 1] : -1;
        const int up = i >= static_cast<std::size_t>(w) ? in[i - w] : -1;
        if (left >= 0) v = std::min(v, left);
        if (up >= 0) v = std::min(v, up);
        out[i] = v;
        break;
      }
      case FramePass::relabel:
        if (in[i] >= 0) out[i] = in[static_cast<std::size_t>(in[i])];
        break;
    }
  }
  return out;
}

}  // namespace

FramePassTiming time_frame_passes(int width, std::span<const int> rows, int block, int reps, int warmup) {
  if (width < 1 || rows.empty() || block < 32 || block > 1024 || block % 32 != 0 || reps < 1 || warmup < 0)
    throw std::invalid_argument("time_frame_passes: width >= 1, at least one size, block a multiple of 32 in "
                                "32..1024, reps >= 1, warmup >= 0");
  for (int r : rows)
    if (r < 1 || static_cast<std::int64_t>(r) * width > std::numeric_limits<int>::max())
      throw std::invalid_argument("time_frame_passes: every frame needs at least one row and fewer than 2^31 pixels "
                                  "(its labels are ints)");
  detail::use_device();
  Stream s;
  FramePassTiming t;
  for (int r : rows) {
    const std::int64_t n = static_cast<std::int64_t>(r) * width;
    t.pixels.push_back(n);
    std::vector<std::uint8_t> img(static_cast<std::size_t>(n));
    for (std::int64_t i = 0; i < n; ++i) img[static_cast<std::size_t>(i)] = grey(i, width);
    DeviceBuffer d_img(img.size()), a(img.size() * sizeof(int)), b(img.size() * sizeof(int)),
        c(img.size() * sizeof(int));
    DTFLOP_CUDA(cudaMemcpyAsync(d_img.get(), img.data(), img.size(), cudaMemcpyHostToDevice, s.get()));
    const int g = grid_for(n, block);
    // Each pass reads what the one before wrote: the threshold a, the neighbours a -> b, the relabel b -> c.
    std::vector<int> expected;
    for (FramePass pass : kFramePasses) {
      auto launch = [&] {
        switch (pass) {
          case FramePass::threshold: threshold_pass<<<g, block, 0, s.get()>>>(d_img.get<std::uint8_t>(), n, a.get<int>()); break;
          case FramePass::neighbours: neighbours_pass<<<g, block, 0, s.get()>>>(a.get<int>(), width, n, b.get<int>()); break;
          case FramePass::relabel: relabel_pass<<<g, block, 0, s.get()>>>(b.get<int>(), n, c.get<int>()); break;
        }
        DTFLOP_CUDA_LAUNCHED();
      };
      DeviceBuffer& out = pass == FramePass::threshold ? a : pass == FramePass::neighbours ? b : c;
      // The threshold writes every pixel: poisoned first, a pixel it misses fails the check. The
      // others write the foreground's: -1 first, as the threshold left the background.
      DTFLOP_CUDA(cudaMemsetAsync(out.get(), pass == FramePass::threshold ? 0x5A : 0xFF, out.bytes(), s.get()));
      for (int i = 0; i < warmup; ++i) launch();
      t.seconds[static_cast<int>(pass)].push_back(detail::time_queued(s, launch, reps, kBatch));
      std::vector<int> got(img.size());
      DTFLOP_CUDA(cudaMemcpyAsync(got.data(), out.get(), out.bytes(), cudaMemcpyDeviceToHost, s.get()));
      s.sync();
      expected = host_pass(pass, img, expected, width);
      for (std::size_t i = 0; i < got.size(); ++i) t.mismatches += got[i] != expected[i];
    }
  }
  return t;
}

}  // namespace dtflop::probes::gpu
