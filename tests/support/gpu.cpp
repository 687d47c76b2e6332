#include "tests/support/gpu.hpp"

#ifdef DTFLOP_HAVE_CUDA
#include <cuda_runtime_api.h>
#endif

namespace dtflop::test {

std::string gpu_unavailable_reason() {
#ifdef DTFLOP_HAVE_CUDA
  int n = 0;
  const cudaError_t e = cudaGetDeviceCount(&n);
  if (e != cudaSuccess) {
    cudaGetLastError();
    return std::string("no usable CUDA device: ") + cudaGetErrorString(e);
  }
  if (n == 0) return "no CUDA device found";
  return {};
#else
  return "dtflop was built without CUDA (nvcc not found at configure time)";
#endif
}

}  // namespace dtflop::test
