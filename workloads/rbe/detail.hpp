// Internal helpers shared by the RBE backends (not part of the public interface).
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#ifdef DTFLOP_HAVE_CUDA
#include <nvtx3/nvToolsExt.h>
#endif

#include "workloads/rbe/backend.hpp"

namespace dtflop::rbe::detail {

inline double seconds_now() {
  using clock = std::chrono::steady_clock;
  return std::chrono::duration<double>(clock::now().time_since_epoch()).count();
}

// An NVTX range ("rbe/<name>") around host work, so a CUPTI/Nsight profile can attribute it.
class Range {
 public:
  explicit Range([[maybe_unused]] const char* name) {
#ifdef DTFLOP_HAVE_CUDA
    nvtxRangePushA(name);
#endif
  }
  ~Range() {
#ifdef DTFLOP_HAVE_CUDA
    nvtxRangePop();
#endif
  }
  Range(const Range&) = delete;
  Range& operator=(const Range&) = delete;
};

// The prior with the mask applied, normalized so that sum x A_c = 1. Throws InputError when it
// has no mass. Validates the problem first.
std::vector<double> normalized_prior(const Problem& problem);
// A copy of `likelihood` with the mask applied; throws InputError for a wrong size, a negative
// or non-finite value.
std::vector<double> masked_likelihood(std::span<const double> likelihood,
                                      std::span<const std::uint8_t> mask, std::int64_t cells);
// The prediction a backend computes for `kernel`; throws InputError when the options ask for
// the separable one with a full kernel, or when the backend supports only separable kernels.
Prediction resolve_prediction(const BackendOptions& options, const MotionKernel& kernel,
                              bool supports_full, std::string_view backend);
// Throws NumericalError for a correction whose sum (of q, before A_c) is zero or not finite.
void check_sum(double sum, std::int64_t step, std::string_view backend);
// The belief was left invalid by a NumericalError, or init() was never called.
[[noreturn]] void throw_not_ready(std::string_view backend, bool failed);

std::unique_ptr<Backend> make_cpu_seq(const BackendOptions& options);
std::unique_ptr<Backend> make_cpu_par(const BackendOptions& options);
std::unique_ptr<Backend> make_cuda_seed(const BackendOptions& options);
std::unique_ptr<Backend> make_cuda_resident(const BackendOptions& options);

}  // namespace dtflop::rbe::detail
