// The cpu-window probe's vectorized window (cpu_kernels.hpp), in a file of its own: like cpu-par's
// loops it is compiled with -ffp-contract=fast (probes/CMakeLists.txt), so that a*b+c becomes one
// FMA, and cloned for x86-64-v3 as cpu-par is.
#include <cstdint>
#include <string_view>

#include "probes/cpu_kernels.hpp"

namespace dtflop::probes::cpu {

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define DTFLOP_WINDOW_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define DTFLOP_WINDOW_CLONES
#endif

// The wide window: 64 outputs a group held in registers while the taps stream past, cloned for
// x86-64-v3 and the baseline and chosen at load time, as the vectorized CPU backend is.
DTFLOP_WINDOW_CLONES
double window_wide(const float* in, const float* k, std::int64_t taps, std::int64_t n, float* out) {
  constexpr int G = kWindowWideGroup;
  for (std::int64_t x = 0; x < n; x += G) {
    float acc[G] = {};
    for (std::int64_t a = 0; a < taps; ++a) {
      const float c = k[a];
      const float* s = in + x + a;
      for (int j = 0; j < G; ++j) acc[j] += c * s[j];
    }
    for (int j = 0; j < G; ++j) out[x + j] = acc[j];
  }
  return 2.0 * static_cast<double>(n) * static_cast<double>(taps);
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
