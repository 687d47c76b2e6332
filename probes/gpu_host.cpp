// Host-only half of the CUDA side (compiled by the C++ compiler, built only with CUDA):
// error messages, device identity, buffer sizing.
#include <cuda_runtime_api.h>

#include <fstream>
#include <sstream>
#include <string>

#include <fmt/format.h>

#include "cuda/check.hpp"
#include "probes/gpu.hpp"
#include "probes/gpu_errors.hpp"
#include "probes/identity.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes::gpu {

namespace detail {

void mismatch(const char* what, std::uint64_t bytes, std::uint64_t bad, std::uint64_t total) {
  throw ValidationError(fmt::format("{} of {} bytes: {} of {} values differ from what was expected",
                                    what, bytes, bad, total));
}

void use_device() {
  int n = 0;
  const cudaError_t e = cudaGetDeviceCount(&n);
  if (e != cudaSuccess) {
    cudaGetLastError();
    if (e == cudaErrorInsufficientDriver && !std::ifstream("/proc/driver/nvidia/version"))
      throw GpuError(fmt::format(
          "no NVIDIA driver is loaded on this machine (the CUDA runtime says: {})",
          cudaGetErrorString(e)));
    throw GpuError(fmt::format("no usable CUDA device: {}", cudaGetErrorString(e)));
  }
  if (n == 0) throw GpuError("no CUDA device found");
  const cudaError_t s = cudaSetDevice(0);
  if (s != cudaSuccess) cuda::fail(s, "cudaSetDevice(0)", __FILE__, __LINE__);
}

}  // namespace detail

namespace {

std::string version_string(int v) { return fmt::format("{}.{}", v / 1000, (v % 1000) / 10); }

std::string kernel_module_version() {
  std::ifstream f("/proc/driver/nvidia/version");
  std::string line;
  if (!std::getline(f, line)) return {};
  return nvidia_driver_version(line);
}

void check(cudaError_t e, const char* call) {
  if (e != cudaSuccess) cuda::fail(e, call, __FILE__, __LINE__);
}

}  // namespace

DeviceInfo device_info() {
  DeviceInfo d;
  try {
    detail::use_device();
    cudaDeviceProp p{};
    check(cudaGetDeviceProperties(&p, 0), "cudaGetDeviceProperties");
    d.name = p.name;
    d.sm_count = p.multiProcessorCount;
    d.l2_bytes = p.l2CacheSize;
    d.cc_major = p.major;
    d.cc_minor = p.minor;
    std::size_t free = 0, total = 0;
    check(cudaMemGetInfo(&free, &total), "cudaMemGetInfo");
    d.free_bytes = static_cast<std::int64_t>(free);
    d.total_bytes = static_cast<std::int64_t>(total);
    int khz = 0;
    if (cudaDeviceGetAttribute(&khz, cudaDevAttrClockRate, 0) == cudaSuccess && khz > 0)
      d.sm_clock_ghz = khz / 1e6;
    else
      cudaGetLastError();
    int rt = 0, drv = 0;
    check(cudaRuntimeGetVersion(&rt), "cudaRuntimeGetVersion");
    check(cudaDriverGetVersion(&drv), "cudaDriverGetVersion");
    d.runtime_version = version_string(rt);
    d.driver_cuda_version = version_string(drv);
    d.driver_version = kernel_module_version();
    if (d.driver_version.empty()) d.driver_version = fmt::format("CUDA driver API {}", d.driver_cuda_version);
    d.usable = true;
  } catch (const GpuError& e) {
    d.usable = false;
    d.reason = e.what();
  }
  return d;
}

std::int64_t fit_device_buffer(std::int64_t bytes, int buffers) {
  detail::use_device();
  std::size_t free = 0, total = 0;
  check(cudaMemGetInfo(&free, &total), "cudaMemGetInfo");
  const std::int64_t mib = 1 << 20;
  const std::int64_t cap = static_cast<std::int64_t>(free) / 4 / (buffers > 0 ? buffers : 1);
  std::int64_t b = bytes < cap ? bytes : cap;
  b = b / mib * mib;
  return b < mib ? mib : b;
}

}  // namespace dtflop::probes::gpu
