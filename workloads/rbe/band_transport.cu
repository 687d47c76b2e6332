// cuda-bands' same-device transport (band_transport.hpp): the partitions share one GPU, so a
// halo message is a device-to-device copy on the receiver's message stream, once the sender's
// edge rows are written, and the all-reduce is a reduction kernel on every band's message
// stream, after every band's step, adding the partial sums in band order (the same total on
// every band).
#include <cuda_runtime.h>

#include <string>

#include "cuda/check.hpp"
#include "workloads/rbe/band_counts.hpp"
#include "workloads/rbe/band_transport.hpp"

namespace dtflop::rbe::detail {
namespace {

struct Partials {
  const double* p[kMaxPartitions];
};

__global__ void rbe_bands_reduce(Partials in, int n, double* out) {
  if (threadIdx.x != 0 || blockIdx.x != 0) return;
  double s = 0;
  for (int a = 0; a < n; ++a) s += *in.p[a];
  *out = s;
}

class DeviceTransport final : public BandTransport {
 public:
  explicit DeviceTransport(std::vector<BandEnds> bands) : bands_(std::move(bands)) {
    for (const BandEnds& b : bands_)
      if (b.device != bands_.front().device)
        throw cuda::Error("cuda-bands: the same-device transport got bands on devices " +
                          std::to_string(bands_.front().device) + " and " + std::to_string(b.device));
    if (bands_.size() > std::size_t(kMaxPartitions))
      throw cuda::Error("cuda-bands: more than " + std::to_string(kMaxPartitions) + " partitions");
  }
  std::string_view name() const override { return "same device"; }

  void exchange(std::span<const HaloMessage> messages) override {
    DTFLOP_CUDA(cudaSetDevice(bands_.front().device));
    for (const HaloMessage& m : messages) {
      const cudaStream_t s = bands_.at(m.to).comm;
      DTFLOP_CUDA(cudaStreamWaitEvent(s, bands_.at(m.from).sent, 0));
      DTFLOP_CUDA(cudaMemcpyAsync(m.dst, m.src, m.count * sizeof(float), cudaMemcpyDeviceToDevice, s));
    }
  }

  void allreduce(std::span<double* const> partial, std::span<double* const> total) override {
    DTFLOP_CUDA(cudaSetDevice(bands_.front().device));
    Partials in{};
    const int n = int(partial.size());
    for (int a = 0; a < n; ++a) in.p[a] = partial[std::size_t(a)];
    for (std::size_t b = 0; b < bands_.size(); ++b) {
      const cudaStream_t s = bands_[b].comm;
      for (std::size_t a = 0; a < bands_.size(); ++a)
        if (a != b) DTFLOP_CUDA(cudaStreamWaitEvent(s, bands_[a].ready, 0));
      rbe_bands_reduce<<<1, 32, 0, s>>>(in, n, total[b]);
      DTFLOP_CUDA_LAUNCHED();
    }
  }

 private:
  std::vector<BandEnds> bands_;
};

}  // namespace

std::unique_ptr<BandTransport> make_device_transport(std::vector<BandEnds> bands) {
  return std::make_unique<DeviceTransport>(std::move(bands));
}

}  // namespace dtflop::rbe::detail
