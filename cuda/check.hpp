// Checking of CUDA runtime calls, the same everywhere: every call is checked, and the last
// error after every launch; a failure throws cuda::Error with the call, the file and line, and
// CUDA's name and text of the error.
#pragma once

#include <cuda_runtime_api.h>

#include <string>

#include "cuda/error.hpp"

namespace dtflop::cuda {

[[noreturn]] inline void fail(cudaError_t e, const char* call, const char* file, int line) {
  cudaGetLastError();  // clear a non-sticky error so that a later call does not report it again
  throw Error(std::string("CUDA error ") + cudaGetErrorName(e) + " (" + cudaGetErrorString(e) + ") in " + call +
              " at " + file + ":" + std::to_string(line));
}

}  // namespace dtflop::cuda

#define DTFLOP_CUDA(call)                                                                        \
  do {                                                                                           \
    const cudaError_t dtflop_e_ = (call);                                                        \
    if (dtflop_e_ != cudaSuccess) ::dtflop::cuda::fail(dtflop_e_, #call, __FILE__, __LINE__);     \
  } while (0)

// After a kernel launch: the launch's own error (bad configuration, too much shared memory).
#define DTFLOP_CUDA_LAUNCHED() DTFLOP_CUDA(cudaGetLastError())
