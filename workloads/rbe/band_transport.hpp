// How cuda-bands' partitions talk (cuda_bands.cu): the halo messages of a step and the all-reduce
// of the correction's sum, behind one small interface with two transports. The band, halo and
// overlap code is the same for both; only the transport differs:
//  - NCCL, one partition per GPU (band_nccl.cpp): ncclSend/ncclRecv in one group, ncclAllReduce;
//    the communicators come from ncclCommInitAll (one process, one host thread drives every GPU);
//  - the same device (band_transport.cu), every partition on one GPU, where NCCL refuses two
//    ranks: cudaMemcpyAsync device-to-device between the band buffers, a reduction kernel.
// Everything is enqueued on the bands' message streams (`comm`): the caller records on them when
// the sum and the halos are ready, and its kernels wait for those events.
#pragma once

#include <cuda_runtime_api.h>

#include <cstddef>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

namespace dtflop::rbe::detail {

// One partition as a transport sees it.
struct BandEnds {
  int device = 0;
  cudaStream_t comm = nullptr;   // the band's stream for its messages and the all-reduce
  cudaEvent_t ready = nullptr;   // recorded after the band's last kernel of a step: its own rows and its
                                 // partial sum are final. The caller makes `comm` wait for it before it
                                 // calls allreduce().
  cudaEvent_t sent = nullptr;    // recorded once the rows the band sends are written (its edge rows; where
                                 // it has none, `ready`). The caller makes `comm` wait for it before it
                                 // calls exchange().
};

// `count` floats from band `from`'s buffer at `src` to band `to`'s at `dst`.
struct HaloMessage {
  std::size_t from = 0, to = 0;
  const float* src = nullptr;
  float* dst = nullptr;
  std::size_t count = 0;
};

class BandTransport {
 public:
  virtual ~BandTransport() = default;
  virtual std::string_view name() const = 0;
  // Enqueues the messages (each band's sends and receives on its own `comm`). Whatever reads
  // another band's memory waits for that band's `sent` event itself.
  virtual void exchange(std::span<const HaloMessage> messages) = 0;
  // Enqueues on each band's `comm`: *total[b] = the sum over bands a of *partial[a] (one float64
  // each), the same value on every band.
  virtual void allreduce(std::span<double* const> partial, std::span<double* const> total) = 0;
};

// Every partition on one device (the bands' `device`s are all the same).
std::unique_ptr<BandTransport> make_device_transport(std::vector<BandEnds> bands);
// One partition per GPU (the bands' devices distinct), over NCCL: sets NCCL_NVLS_ENABLE=0 (NVLink
// multicast off) in the process unless the user set it, before the communicators are made.
// Throws cuda::Unavailable where dtflop was built without NCCL.
std::unique_ptr<BandTransport> make_nccl_transport(std::vector<BandEnds> bands);
// Whether dtflop was built with NCCL.
bool nccl_built();

}  // namespace dtflop::rbe::detail
