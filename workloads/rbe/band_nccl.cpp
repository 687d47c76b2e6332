// cuda-bands' NCCL transport (band_transport.hpp): one partition per GPU, one process, one host
// thread driving every GPU. The communicators come from ncclCommInitAll over the bands' devices
// (rank b = band b); every call of a step is issued for all ranks inside one ncclGroupStart/End,
// so one thread can drive them without deadlock (a per-GPU thread would need a barrier per
// step to keep the ranks' calls in the same order; one thread keeps them in order by itself and
// leaves the GPUs' work asynchronous). Each rank's calls go on its band's message stream, one
// stream per rank, so NCCL's operations of a communicator never run concurrently.
// Built where NCCL was found (DTFLOP_HAVE_NCCL); elsewhere make_nccl_transport() says so.
#include <cstdlib>
#include <string>

#include <fmt/format.h>

#include "cuda/check.hpp"
#include "workloads/rbe/band_transport.hpp"

#ifdef DTFLOP_HAVE_NCCL
#include <nccl.h>
#endif

namespace dtflop::rbe::detail {

#ifdef DTFLOP_HAVE_NCCL
namespace {

void check(ncclResult_t r, const char* call) {
  if (r == ncclSuccess) return;
  throw cuda::Error(fmt::format("NCCL error in {}: {} (run with NCCL_DEBUG=WARN for NCCL's own account)", call,
                                ncclGetErrorString(r)));
}
#define DTFLOP_NCCL(call) check((call), #call)

class NcclTransport final : public BandTransport {
 public:
  explicit NcclTransport(std::vector<BandEnds> bands) : bands_(std::move(bands)) {
    // NVLink multicast (NVLS) stays off unless the user asked for it: it needs fabric support
    // that the lent machines do not give, and a halo exchange has no use for it.
    ::setenv("NCCL_NVLS_ENABLE", "0", 0);
    std::vector<int> devices;
    for (const BandEnds& b : bands_) devices.push_back(b.device);
    comms_.assign(bands_.size(), nullptr);
    DTFLOP_NCCL(ncclCommInitAll(comms_.data(), int(comms_.size()), devices.data()));
  }
  ~NcclTransport() override {
    for (ncclComm_t c : comms_)
      if (c) ncclCommDestroy(c);
  }
  std::string_view name() const override { return "NCCL"; }

  void exchange(std::span<const HaloMessage> messages) override {
    DTFLOP_NCCL(ncclGroupStart());
    for (const HaloMessage& m : messages) {
      DTFLOP_NCCL(ncclSend(m.src, m.count, ncclFloat, int(m.to), comms_.at(m.from), bands_.at(m.from).comm));
      DTFLOP_NCCL(ncclRecv(m.dst, m.count, ncclFloat, int(m.from), comms_.at(m.to), bands_.at(m.to).comm));
    }
    DTFLOP_NCCL(ncclGroupEnd());
  }

  void allreduce(std::span<double* const> partial, std::span<double* const> total) override {
    DTFLOP_NCCL(ncclGroupStart());
    for (std::size_t b = 0; b < bands_.size(); ++b)
      DTFLOP_NCCL(ncclAllReduce(partial[b], total[b], 1, ncclDouble, ncclSum, comms_[b], bands_[b].comm));
    DTFLOP_NCCL(ncclGroupEnd());
  }

 private:
  std::vector<BandEnds> bands_;
  std::vector<ncclComm_t> comms_;
};

}  // namespace

std::unique_ptr<BandTransport> make_nccl_transport(std::vector<BandEnds> bands) {
  return std::make_unique<NcclTransport>(std::move(bands));
}
bool nccl_built() { return true; }

#else

std::unique_ptr<BandTransport> make_nccl_transport(std::vector<BandEnds>) {
  throw cuda::Unavailable(
      "cuda-bands: dtflop was built without NCCL, so its partitions cannot span several GPUs; run them on one GPU "
      "(--gpus 1), or rebuild where NCCL is found (cmake -DNCCL_ROOT=...)");
}
bool nccl_built() { return false; }

#endif

}  // namespace dtflop::rbe::detail
