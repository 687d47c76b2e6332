// Checking of CUDA runtime calls for the RBE backends: every call is checked, and the last
// error after every launch; a failure throws with the call, the file and line, and CUDA's text.
#pragma once

#include <cuda_runtime_api.h>

#include <stdexcept>
#include <string>

namespace dtflop::rbe::detail {

[[noreturn]] inline void cuda_fail(cudaError_t e, const char* call, const char* file, int line) {
  cudaGetLastError();  // clear a non-sticky error so that it is not reported again by a later call
  throw std::runtime_error(std::string("CUDA error ") + cudaGetErrorName(e) + " (" + cudaGetErrorString(e) +
                           ") in " + call + " at " + file + ":" + std::to_string(line));
}

}  // namespace dtflop::rbe::detail

#define DTFLOP_CUDA(call)                                                              \
  do {                                                                                 \
    const cudaError_t dtflop_e_ = (call);                                              \
    if (dtflop_e_ != cudaSuccess) ::dtflop::rbe::detail::cuda_fail(dtflop_e_, #call, __FILE__, __LINE__); \
  } while (0)

// After a kernel launch: the launch's own error (bad configuration, too much shared memory).
#define DTFLOP_CUDA_LAUNCHED() DTFLOP_CUDA(cudaGetLastError())
