// gpu-mls's kernel: the DCT cuda backend's MLS point (kernels::mls_point_device) over a support
// table, one point a thread, timed with events.
#include <stdexcept>
#include <vector>

#include "kernels/point_fields.hpp"
#include "probes/gpu_common.cuh"

namespace dtflop::probes::gpu {

namespace {

using detail::DeviceBuffer;
using detail::Stream;

constexpr int kBatch = 5;  // launches a timed repetition holds

// The backend's field kernel (workloads/dct/cuda_kernels.cu, k_mls), line for line.
__global__ void mls_kernel(int n, kernels::MlsDeviceTable t, kernels::FieldValue<float>* out) {
  const int m = blockIdx.x * blockDim.x + threadIdx.x;
  if (m < n) out[m] = kernels::mls_point_device(t, m);
}

template <class T>
void upload(DeviceBuffer& d, const std::vector<T>& h, const Stream& s) {
  DTFLOP_CUDA(cudaMemcpyAsync(d.get(), h.data(), h.size() * sizeof(T), cudaMemcpyHostToDevice, s.get()));
}

}  // namespace

MlsTiming time_mls(const MlsDots& dots, const std::vector<MlsTable>& tables, int block, int reps, int warmup) {
  const std::size_t n_dots = dots.reference_xy.size() / 2;
  if (n_dots == 0 || dots.reference_xy.size() != 2 * n_dots || dots.disp_xy.size() != 2 * n_dots || tables.empty() ||
      block < 32 || block > 1024 || block % 32 != 0 || reps < 1 || warmup < 0)
    throw std::invalid_argument("time_mls: dots with positions and displacements, at least one table, block a "
                                "multiple of 32 in 32..1024, reps >= 1, warmup >= 0");
  detail::use_device();
  Stream s;
  DeviceBuffer ref(dots.reference_xy.size() * sizeof(double)), disp(dots.disp_xy.size() * sizeof(float)),
      valid(n_dots);
  upload(ref, dots.reference_xy, s);
  upload(disp, dots.disp_xy, s);
  DTFLOP_CUDA(cudaMemsetAsync(valid.get(), 1, n_dots, s.get()));  // every dot tracked
  MlsTiming r;
  for (const MlsTable& t : tables) {
    const std::size_t n = t.rho.size();
    if (n == 0 || t.points_xy.size() != 2 * n || t.offsets.size() != n + 1 || t.offsets.front() != 0 ||
        static_cast<std::size_t>(t.offsets.back()) != t.dots.size())
      throw std::invalid_argument("time_mls: a table needs points (x, y), radii and offsets of the same points");
    for (int j : t.dots)
      if (j < 0 || static_cast<std::size_t>(j) >= n_dots) throw std::invalid_argument("time_mls: a dot index is out of range");
    DeviceBuffer pts(t.points_xy.size() * sizeof(double)), rho(n * sizeof(float)), geometry(n),
        offsets(t.offsets.size() * sizeof(int)), idx(t.dots.size() * sizeof(int)),
        out(n * sizeof(kernels::FieldValue<float>));
    upload(pts, t.points_xy, s);
    upload(rho, t.rho, s);
    upload(offsets, t.offsets, s);
    upload(idx, t.dots, s);
    DTFLOP_CUDA(cudaMemsetAsync(geometry.get(), 0, n, s.get()));  // every point inside the dots
    const kernels::MlsDeviceTable dt{pts.get<const double2>(), rho.get<const float>(),
                                     geometry.get<const unsigned char>(), offsets.get<const int>(),
                                     idx.get<const int>(), ref.get<const double2>(), disp.get<const float2>(),
                                     valid.get<const unsigned char>(),
                                     static_cast<int>(kernels::Weight::cubic_spline), 6, 1e-5f};
    const int nn = static_cast<int>(n);
    const unsigned grid = static_cast<unsigned>((n + static_cast<std::size_t>(block) - 1) / static_cast<std::size_t>(block));
    auto launch = [&] {
      mls_kernel<<<grid, block, 0, s.get()>>>(nn, dt, out.get<kernels::FieldValue<float>>());
      DTFLOP_CUDA_LAUNCHED();
    };
    for (int i = 0; i < warmup; ++i) launch();
    DTFLOP_CUDA(cudaMemsetAsync(out.get(), 0xFF, out.bytes(), s.get()));  // poison: a point not written fails the check
    std::vector<double> seconds = detail::time_queued(s, launch, reps, kBatch);
    std::vector<kernels::FieldValue<float>> host(n);
    DTFLOP_CUDA(cudaMemcpyAsync(host.data(), out.get(), out.bytes(), cudaMemcpyDeviceToHost, s.get()));
    s.sync();
    r.seconds.push_back(std::move(seconds));
    r.fields.push_back(std::move(host));
  }
  return r;
}

}  // namespace dtflop::probes::gpu
