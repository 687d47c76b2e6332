// Host loops that a workload runs and a probe times: the one source of each, so that the probe
// measures the machine code the workload executes (a loop written twice can compile to different
// instructions: the float64 correlation below ran at 7 GFLOP/s as the RBE reference wrote it and
// at 12 GFLOP/s written with its taps in the other order, on the same Xeon).
//
// Each is a template (the RBE reference also runs them with an operation-counting scalar in its
// tests) and is never inlined: every caller of one instantiation calls the same function, which
// the compiler builds once, out of any caller's context. Header only; it depends on nothing.
#pragma once

#include <cstdint>

namespace dtflop::kernels {

// A chained sliding-window correlation of one line: out[x] = sum_{a < I} k[a] src[x - a] for
// x < n, where src[x - a] is readable for every x < kChainGroup ceil(n / kChainGroup) and a < I
// (a zero-padded line). Outputs are taken kChainGroup at a time, each with one accumulator that
// adds its taps in order, so kChainGroup chains of dependent additions run side by side; the last
// group is computed whole and its outputs past n dropped. 2 I kChainGroup ceil(n / kChainGroup)
// FLOPs. (The RBE reference's passes, docs/rbe.md; the cpu-window probe's K_CD.)
inline constexpr std::int64_t kChainGroup = 8;
template <class T>
[[gnu::noinline]] void correlate_chained(const T* src, std::int64_t n, const T* k, std::int64_t I, T* out) {
  for (std::int64_t ix = 0; ix < n; ix += kChainGroup) {
    T acc[kChainGroup];
    for (std::int64_t j = 0; j < kChainGroup; ++j) acc[j] = T(0);
    for (std::int64_t a = 0; a < I; ++a) {
      const T w = k[a];
      for (std::int64_t j = 0; j < kChainGroup; ++j) acc[j] = acc[j] + w * src[ix + j - a];
    }
    for (std::int64_t j = 0; j < kChainGroup && ix + j < n; ++j) out[ix + j] = acc[j];
  }
}

// A plain sum, one addition after another: a serial chain of n dependent additions.
// (The RBE reference's correction; the cpu-window probe's V_CS.)
template <class T>
[[gnu::noinline]] T serial_sum(std::int64_t n, const T* q) {
  T s = T(0);
  for (std::int64_t i = 0; i < n; ++i) s = s + q[i];
  return s;
}

}  // namespace dtflop::kernels
