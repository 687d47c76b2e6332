#include "cuda/device.hpp"

#ifdef DTFLOP_HAVE_CUDA
#include <cuda_runtime_api.h>
#endif

namespace dtflop::cuda {

std::string unavailable_reason() {
#ifdef DTFLOP_HAVE_CUDA
  int n = 0;
  const cudaError_t e = cudaGetDeviceCount(&n);
  if (e != cudaSuccess) {
    cudaGetLastError();
    return std::string("no usable CUDA device (") + cudaGetErrorString(e) + ")";
  }
  if (n == 0) return "no CUDA device found";
  return {};
#else
  return "dtflop was built without CUDA (nvcc was not found when it was configured)";
#endif
}

std::string device_name() {
#ifdef DTFLOP_HAVE_CUDA
  if (!unavailable_reason().empty()) return {};
  cudaDeviceProp prop{};
  if (cudaGetDeviceProperties(&prop, 0) != cudaSuccess) {
    cudaGetLastError();
    return {};
  }
  return prop.name;
#else
  return {};
#endif
}

int device_sms() {
#ifdef DTFLOP_HAVE_CUDA
  static const int sms = [] {  // device 0 of this process does not change
    if (!unavailable_reason().empty()) return 0;
    int n = 0;
    if (cudaDeviceGetAttribute(&n, cudaDevAttrMultiProcessorCount, 0) != cudaSuccess) {
      cudaGetLastError();
      return 0;
    }
    return n;
  }();
  return sms;
#else
  return 0;
#endif
}

int device_count() {
#ifdef DTFLOP_HAVE_CUDA
  if (!unavailable_reason().empty()) return 0;
  int n = 0;
  if (cudaGetDeviceCount(&n) != cudaSuccess) {
    cudaGetLastError();
    return 0;
  }
  return n;
#else
  return 0;
#endif
}

}  // namespace dtflop::cuda
