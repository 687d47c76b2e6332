// Internal to the CUDA side: failure reporting shared by gpu_host.cpp and the .cu files.
// Plain C++ (no CUDA types), implemented in gpu_host.cpp.
#pragma once

#include <cstdint>

namespace dtflop::probes::gpu::detail {

// Throws ValidationError: `bad` of `total` values of a `bytes`-byte result were wrong.
[[noreturn]] void mismatch(const char* what, std::uint64_t bytes, std::uint64_t bad,
                           std::uint64_t total);

// Selects device 0; throws GpuError with the reason when no device is usable.
void use_device();

}  // namespace dtflop::probes::gpu::detail
