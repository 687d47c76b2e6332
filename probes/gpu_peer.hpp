// The NCCL side of the probe gpu-peer (probe_gpu_peer.cpp), callable from plain C++: messages
// between GPUs 0 and 1 of this process. Implemented in gpu_peer.cpp where dtflop was built with
// NCCL (DTFLOP_HAVE_NCCL); the probe says why it measures nothing elsewhere.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace dtflop::probes::gpu {

struct PeerTimes {
  std::int64_t bytes = 0;
  std::vector<double> send;       // one-way time of a point-to-point message (half a round trip), s
  std::vector<double> allreduce;  // one all-reduce of `bytes` per GPU over both GPUs, s
};

// Empty when GPUs 0 and 1 can exchange NCCL messages here; otherwise why not (fewer than two
// GPUs, dtflop built without NCCL).
std::string peer_unavailable_reason();

// For each size (bytes, a multiple of 4): `reps[i]` repetitions, each the mean over `batch[i]`
// back-to-back round trips (ncclSend/ncclRecv 0 -> 1 -> 0, timed by events on GPU 0's stream)
// and `batch[i]` all-reduces (float sums over both GPUs), after `warmup` untimed ones. Every
// message and every sum is checked; a wrong one throws ValidationError (probe.hpp). Sets
// NCCL_NVLS_ENABLE=0 unless the user set it.
std::vector<PeerTimes> time_peer(const std::vector<std::int64_t>& sizes, const std::vector<int>& reps,
                                 const std::vector<int>& batch, int warmup);

}  // namespace dtflop::probes::gpu
