// Internal helpers shared by the RBE backends (not part of the public interface).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
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

// A run of backends that step one at a time: `advance(sum)` performs one step, returns its
// times and sets `sum` to the step's unnormalized sum; the run records each step's times and
// its normalizing integral (sum x cell area).
template <class Advance>
RunResult run_step_by_step(std::int64_t steps, double cell_area, Advance&& advance) {
  if (steps < 1) throw InputError("a run needs at least one step, got " + std::to_string(steps));
  RunResult r;
  r.steps = steps;
  r.samples.reserve(static_cast<std::size_t>(steps));
  r.sums.reserve(static_cast<std::size_t>(steps));
  const double t0 = seconds_now();
  for (std::int64_t i = 0; i < steps; ++i) {
    double sum = 0;
    r.samples.push_back(advance(sum));
    r.sums.push_back(sum * cell_area);
  }
  r.wall_seconds = seconds_now() - t0;
  return r;
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
Convolution resolve_prediction(const BackendOptions& options, const MotionKernel& kernel,
                              bool supports_full, std::string_view backend);
// Throws NumericalError for a correction whose sum (of q, before A_c) is zero or not finite.
void check_sum(double sum, std::int64_t step, std::string_view backend);
// One segment of `n` steps of a GPU run timed in chunks of `chunk` steps: appends to `r` a sample
// per chunk (its mean step, chunk_seconds(c) the device time of chunk c) and each step's sum
// (host_sums[k] x cell_area), checking each (check_sum, steps numbered from first_step; `failed`
// is set before it throws).
void append_segment(RunResult& r, std::int64_t n, std::int64_t chunk,
                    const std::function<double(std::size_t chunk)>& chunk_seconds, std::span<const double> host_sums,
                    double cell_area, std::int64_t first_step, std::string_view backend, bool& failed);
// Throws InputError unless there is at least one other belief, each has `cells` values and the
// own belief's position is at most the number of others.
void check_others(std::span<const std::span<const float>> others, std::size_t position, std::int64_t cells,
                  std::string_view backend);
// Throws NumericalError for a fusion whose sum (before A_c) is zero or not finite.
void check_fusion_sum(double sum, std::size_t platforms, FusionRule rule, std::string_view backend);
// Backend::summarize on the host: estimate() and footprint_sums() of `belief`.
Summary host_summary(const Grid& grid, std::span<const double> belief, const Footprint& f, std::span<const Point> at);
// The belief was left invalid by a NumericalError, or init() was never called.
[[noreturn]] void throw_not_ready(std::string_view backend, bool failed);

std::unique_ptr<Backend> make_cpu_seq(const BackendOptions& options);
std::unique_ptr<Backend> make_cpu_par(const BackendOptions& options);
std::unique_ptr<Backend> make_cuda_seed(const BackendOptions& options);
std::unique_ptr<Backend> make_cuda_resident(const BackendOptions& options);
std::unique_ptr<Backend> make_cuda_bands(const BackendOptions& options);

}  // namespace dtflop::rbe::detail
