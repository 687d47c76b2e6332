// NCCL messages between GPUs 0 and 1 for the probe gpu-peer (gpu_peer.hpp). One process, one
// thread: the two communicators come from ncclCommInitAll, and each round trip's calls for both
// ranks go in one group.
#include "probes/gpu_peer.hpp"

#include <cuda_runtime_api.h>
#include <nccl.h>

#include <cmath>
#include <cstdlib>
#include <string>

#include <fmt/format.h>

#include "cuda/check.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes::gpu {
namespace {

void check(ncclResult_t r, const char* call) {
  if (r != ncclSuccess) throw cuda::Error(fmt::format("NCCL error in {}: {}", call, ncclGetErrorString(r)));
}
#define DTFLOP_NCCL(call) check((call), #call)

struct Side {
  float* send = nullptr;
  float* recv = nullptr;
  cudaStream_t stream = nullptr;
};

class Pair {
 public:
  explicit Pair(std::size_t floats) {
    ::setenv("NCCL_NVLS_ENABLE", "0", 0);  // NVLink multicast off unless the user asked for it
    int devs[2] = {0, 1};
    DTFLOP_NCCL(ncclCommInitAll(comms_, 2, devs));
    for (int d = 0; d < 2; ++d) {
      DTFLOP_CUDA(cudaSetDevice(d));
      DTFLOP_CUDA(cudaMalloc(&side_[d].send, floats * sizeof(float)));
      DTFLOP_CUDA(cudaMalloc(&side_[d].recv, floats * sizeof(float)));
      DTFLOP_CUDA(cudaStreamCreateWithFlags(&side_[d].stream, cudaStreamNonBlocking));
    }
    DTFLOP_CUDA(cudaSetDevice(0));
    DTFLOP_CUDA(cudaEventCreate(&start_));
    DTFLOP_CUDA(cudaEventCreate(&stop_));
  }
  ~Pair() {
    for (int d = 0; d < 2; ++d) {
      cudaSetDevice(d);
      if (side_[d].stream) cudaStreamSynchronize(side_[d].stream);
      if (comms_[d]) ncclCommDestroy(comms_[d]);
      cudaFree(side_[d].send);
      cudaFree(side_[d].recv);
      if (side_[d].stream) cudaStreamDestroy(side_[d].stream);
    }
    cudaSetDevice(0);
    if (start_) cudaEventDestroy(start_);
    if (stop_) cudaEventDestroy(stop_);
  }
  Pair(const Pair&) = delete;
  Pair& operator=(const Pair&) = delete;

  // Fills rank d's send buffer with value v(d) in its first `floats` values.
  void fill(std::size_t floats, float v0, float v1) {
    for (int d = 0; d < 2; ++d) {
      std::vector<float> h(floats, d == 0 ? v0 : v1);
      DTFLOP_CUDA(cudaSetDevice(d));
      DTFLOP_CUDA(cudaMemcpy(side_[d].send, h.data(), floats * sizeof(float), cudaMemcpyHostToDevice));
      DTFLOP_CUDA(cudaMemset(side_[d].recv, 0, floats * sizeof(float)));
    }
  }
  // Does rank d's receive buffer hold `v` in every one of its first `floats` values?
  bool holds(int d, std::size_t floats, float v) {
    std::vector<float> h(floats);
    DTFLOP_CUDA(cudaSetDevice(d));
    DTFLOP_CUDA(cudaMemcpy(h.data(), side_[d].recv, floats * sizeof(float), cudaMemcpyDeviceToHost));
    for (float x : h)
      if (x != v) return false;
    return true;
  }

  // `n` round trips of `floats` values, 0 -> 1 -> 0; seconds of all of them (GPU 0's events).
  double round_trips(std::size_t floats, int n) {
    return timed(n, [&] {
      DTFLOP_NCCL(ncclGroupStart());
      DTFLOP_NCCL(ncclSend(side_[0].send, floats, ncclFloat, 1, comms_[0], side_[0].stream));
      DTFLOP_NCCL(ncclRecv(side_[1].recv, floats, ncclFloat, 0, comms_[1], side_[1].stream));
      DTFLOP_NCCL(ncclGroupEnd());
      DTFLOP_NCCL(ncclGroupStart());
      DTFLOP_NCCL(ncclSend(side_[1].send, floats, ncclFloat, 0, comms_[1], side_[1].stream));
      DTFLOP_NCCL(ncclRecv(side_[0].recv, floats, ncclFloat, 1, comms_[0], side_[0].stream));
      DTFLOP_NCCL(ncclGroupEnd());
    });
  }
  // `n` all-reduces (sums) of `floats` values per GPU.
  double allreduces(std::size_t floats, int n) {
    return timed(n, [&] {
      DTFLOP_NCCL(ncclGroupStart());
      for (int d = 0; d < 2; ++d)
        DTFLOP_NCCL(ncclAllReduce(side_[d].send, side_[d].recv, floats, ncclFloat, ncclSum, comms_[d], side_[d].stream));
      DTFLOP_NCCL(ncclGroupEnd());
    });
  }

 private:
  template <class F>
  double timed(int n, F&& once) {
    DTFLOP_CUDA(cudaSetDevice(0));
    DTFLOP_CUDA(cudaEventRecord(start_, side_[0].stream));
    for (int i = 0; i < n; ++i) once();
    DTFLOP_CUDA(cudaSetDevice(0));
    DTFLOP_CUDA(cudaEventRecord(stop_, side_[0].stream));
    for (int d = 0; d < 2; ++d) {
      DTFLOP_CUDA(cudaSetDevice(d));
      DTFLOP_CUDA(cudaStreamSynchronize(side_[d].stream));
    }
    float ms = 0;
    DTFLOP_CUDA(cudaEventElapsedTime(&ms, start_, stop_));
    return double(ms) * 1e-3;
  }

  ncclComm_t comms_[2] = {nullptr, nullptr};
  Side side_[2];
  cudaEvent_t start_ = nullptr, stop_ = nullptr;
};

}  // namespace

std::string peer_unavailable_reason() {
  int n = 0;
  if (cudaGetDeviceCount(&n) != cudaSuccess) {
    (void)cudaGetLastError();
    return "no usable CUDA device";
  }
  if (n < 2)
    return fmt::format("gpu-peer measures messages between two GPUs; this process sees {} (CUDA_VISIBLE_DEVICES "
                       "applies)",
                       n);
  return {};
}

std::vector<PeerTimes> time_peer(const std::vector<std::int64_t>& sizes, const std::vector<int>& reps,
                                 const std::vector<int>& batch, int warmup) {
  std::int64_t largest = 4;
  for (auto s : sizes) largest = std::max(largest, s);
  Pair pair(std::size_t(largest / 4));
  std::vector<PeerTimes> out;
  for (std::size_t i = 0; i < sizes.size(); ++i) {
    const std::size_t floats = std::size_t(std::max<std::int64_t>(sizes[i] / 4, 1));
    PeerTimes t;
    t.bytes = std::int64_t(floats * 4);
    // Round trips: rank 0 sends 1.5s, rank 1 sends 2.5s; each must receive the other's.
    pair.fill(floats, 1.5f, 2.5f);
    (void)pair.round_trips(floats, warmup);
    for (int r = 0; r < reps[i]; ++r) t.send.push_back(pair.round_trips(floats, batch[i]) / (2.0 * batch[i]));
    if (!pair.holds(1, floats, 1.5f) || !pair.holds(0, floats, 2.5f))
      throw ValidationError(
          fmt::format("gpu-peer: a point-to-point message of {} bytes arrived with other values than were sent", t.bytes));
    // All-reduces: 1.5 + 2.5 = 4 on both GPUs (exact in float).
    (void)pair.allreduces(floats, warmup);
    for (int r = 0; r < reps[i]; ++r) t.allreduce.push_back(pair.allreduces(floats, batch[i]) / batch[i]);
    if (!pair.holds(0, floats, 4.f) || !pair.holds(1, floats, 4.f))
      throw ValidationError(
          fmt::format("gpu-peer: an all-reduce of {} bytes per GPU gave another sum than 1.5 + 2.5", t.bytes));
    out.push_back(std::move(t));
  }
  return out;
}

}  // namespace dtflop::probes::gpu
