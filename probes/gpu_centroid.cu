// gpu-centroid's kernel: the DCT cuda backend's centroid block (kernels::centroid_block) over a
// frame's dots, one block a dot, timed with events.
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

#include "kernels/dot_centroid.hpp"
#include "probes/gpu_common.cuh"

namespace dtflop::probes::gpu {

namespace {

using detail::DeviceBuffer;
using detail::Stream;

constexpr int kBatch = 5;  // launches a timed repetition holds

// The backend's centroid kernel (workloads/dct/cuda_kernels.cu, k_centroid) without its filters:
// every dot here is kept. A label is read as the backend reads its own (one load, -1 background).
__global__ void centroid_kernel(const std::uint8_t* img, const int* L, int w, int h, const int4* windows,
                                const int* component, int margin, double2* out) {
  const int4 q = windows[blockIdx.x];
  kernels::DotWindow win;
  win.x0 = q.x;
  win.y0 = q.y;
  win.w = q.z;
  win.h = q.w;
  auto label = [&](int x, int y) -> int {
    if (x < 0 || y < 0 || x >= w || y >= h) return -1;
    return L[static_cast<long long>(y) * w + x];
  };
  const kernels::DotSums d = kernels::centroid_block(img, w, win, label, component[blockIdx.x], margin, false);
  if (threadIdx.x == 0)
    out[blockIdx.x] = d.w > 0.f ? make_double2(static_cast<double>(d.cx) + static_cast<double>(d.wx / d.w),
                                               static_cast<double>(d.cy) + static_cast<double>(d.wy / d.w))
                                : make_double2(std::numeric_limits<double>::quiet_NaN(), 0.0);
}

void check(const CentroidFrame& f) {
  const auto dots = f.component.size();
  const auto pixels = static_cast<std::size_t>(f.width) * static_cast<std::size_t>(f.height);
  if (f.width < 1 || f.height < 1 || f.image.size() != pixels || f.labels.size() != pixels || dots == 0 ||
      f.windows.size() != 4 * dots || dots > static_cast<std::size_t>(std::numeric_limits<int>::max()))
    throw std::invalid_argument("time_centroids: a frame needs an image and labels of width x height pixels and at "
                                "least one dot, with a window (4 numbers) and a component each");
  for (std::size_t j = 0; j < dots; ++j) {
    const int* q = &f.windows[4 * j];
    if (q[0] < 0 || q[1] < 0 || q[2] < 1 || q[3] < 1 || q[2] > f.width - q[0] || q[3] > f.height - q[1] ||
        f.component[j] < 0)
      throw std::invalid_argument("time_centroids: a dot's window lies outside the image or its component is < 0");
  }
}

template <class T>
void upload(DeviceBuffer& d, const std::vector<T>& h, const Stream& s) {
  DTFLOP_CUDA(cudaMemcpyAsync(d.get(), h.data(), h.size() * sizeof(T), cudaMemcpyHostToDevice, s.get()));
}

}  // namespace

CentroidTiming time_centroids(const std::vector<CentroidFrame>& frames, int margin, int block, int reps, int warmup) {
  if (frames.empty() || margin < 0 || margin > 16 || block < 32 || block > 1024 || block % 32 != 0 || reps < 1 ||
      warmup < 0)
    throw std::invalid_argument("time_centroids: at least one frame, margin in 0..16, block a multiple of 32 in "
                                "32..1024, reps >= 1, warmup >= 0");
  for (const CentroidFrame& f : frames) check(f);
  detail::use_device();
  Stream s;
  CentroidTiming r;
  for (const CentroidFrame& f : frames) {
    const std::size_t dots = f.component.size();
    DeviceBuffer img(f.image.size()), labels(f.labels.size() * sizeof(int)), windows(f.windows.size() * sizeof(int)),
        component(dots * sizeof(int)), out(dots * sizeof(double2));
    upload(img, f.image, s);
    upload(labels, f.labels, s);
    upload(windows, f.windows, s);
    upload(component, f.component, s);
    const auto grid = static_cast<unsigned>(dots);
    auto launch = [&] {
      centroid_kernel<<<grid, block, kernels::kCentroidStageBytes, s.get()>>>(
          img.get<const std::uint8_t>(), labels.get<const int>(), f.width, f.height, windows.get<const int4>(),
          component.get<const int>(), margin, out.get<double2>());
      DTFLOP_CUDA_LAUNCHED();
    };
    for (int i = 0; i < warmup; ++i) launch();
    DTFLOP_CUDA(cudaMemsetAsync(out.get(), 0xFF, out.bytes(), s.get()));  // poison: a dot not written fails the check
    std::vector<double> seconds = detail::time_queued(s, launch, reps, kBatch);
    std::vector<double> host(2 * dots);
    DTFLOP_CUDA(cudaMemcpyAsync(host.data(), out.get(), out.bytes(), cudaMemcpyDeviceToHost, s.get()));
    s.sync();
    r.seconds.push_back(std::move(seconds));
    r.centroids.push_back(std::move(host));
  }
  return r;
}

}  // namespace dtflop::probes::gpu
