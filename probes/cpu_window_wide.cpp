// The cpu-window probe's vectorized windows (cpu_kernels.hpp), in a file of its own: like cpu-par's
// loops they are compiled with -ffp-contract=fast (probes/CMakeLists.txt), so that a*b+c becomes one
// FMA, and cloned for x86-64-v3 as cpu-par is.
#include <cstdint>
#include <string_view>

#include "probes/cpu_kernels.hpp"

#include "kernels/vector_loops.hpp"

namespace dtflop::probes::cpu {

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define DTFLOP_WINDOW_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define DTFLOP_WINDOW_CLONES
#endif

// The vectorized windows: cpu-par's own blocks (kernels/vector_loops.hpp) in functions cloned
// for x86-64-v3 and the baseline as cpu-par's are, chosen at load time.
DTFLOP_WINDOW_CLONES
double window_wide(const float* in, const float* k, std::int64_t taps, std::int64_t n, float* out) {
  for (std::int64_t x = 0; x < n; x += kernels::kWideBlock)
    kernels::correlate_block(in + x, k, taps, out + x, out + x + kernels::kWideStrip);
  return 2.0 * static_cast<double>(n) * static_cast<double>(taps);
}

DTFLOP_WINDOW_CLONES
double window_aligned(const float* in, const float* k, std::int64_t taps, std::int64_t rows, float* out) {
  constexpr std::int64_t B = kernels::kWideStrip;
  for (std::int64_t y = 0; y < rows; y += 2) kernels::combine_block(in + y * B, k, taps, out + y * B, out + (y + 1) * B);
  return 2.0 * static_cast<double>(rows * B) * static_cast<double>(taps);
}

std::string_view window_wide_isa() {
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") && __builtin_cpu_supports("bmi2"))
    return "x86-64-v3 (AVX2+FMA)";
#endif
  return "baseline";
}

}  // namespace dtflop::probes::cpu
