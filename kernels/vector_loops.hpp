// The vectorized CPU backend's inner blocks (cpu-par, workloads/rbe/cpu_par.cpp), which the
// cpu-window probe also times (probes/cpu_window_wide.cpp) for K_CW and K_CA. They are forced inline
// so that each caller's target clone (x86-64-v3 and the baseline) compiles them for its own
// instruction set; both callers are built with -ffp-contract=fast, so a*b+c is one FMA. Header
// only; it depends on nothing.
#pragma once

#include <cstdint>

#if defined(__GNUC__)
#define DTFLOP_INLINE [[gnu::always_inline]] inline
#else
#define DTFLOP_INLINE inline
#endif

namespace dtflop::kernels {

// Outputs per block of the x-pass and columns per strip of the y-pass.
inline constexpr int kWideBlock = 64;
inline constexpr int kWideStrip = 32;

// out[x] = sum_a k[a] in[x + a] for 2 x kWideStrip consecutive x: the accumulators stay in
// registers while the taps stream past (64 = eight AVX vectors, enough independent FMA chains to
// keep both FMA pipes busy). The first kWideStrip outputs go to out0, the others to out1: the two
// y-pass strips the block covers.
DTFLOP_INLINE void correlate_block(const float* __restrict in, const float* __restrict k, std::int64_t I,
                                   float* __restrict out0, float* __restrict out1) {
  static_assert(kWideBlock == 2 * kWideStrip, "an x-pass block fills two y-pass strips");
  float acc[kWideBlock] = {};
  for (std::int64_t a = 0; a < I; ++a) {
    const float c = k[a];
    const float* s = in + a;
    for (int j = 0; j < kWideBlock; ++j) acc[j] += c * s[j];
  }
  for (int j = 0; j < kWideStrip; ++j) out0[j] = acc[j];
  for (int j = 0; j < kWideStrip; ++j) out1[j] = acc[kWideStrip + j];
}

// The y-pass for kWideStrip columns of two neighbouring output rows: out0[x] = sum_b k[b] in[b p + x]
// and out1[x] = sum_b k[b] in[(b + 1) p + x], p = kWideStrip (one strip of u). The two outputs share
// I - 1 of their input rows, so each row segment loaded feeds two FMAs (2 x 32 accumulators in
// registers). Taps are summed in the same order as for one row at a time. Without out1, one row.
DTFLOP_INLINE void combine_block(const float* __restrict in, const float* __restrict k, std::int64_t I,
                                 float* __restrict out0, float* __restrict out1) {
  constexpr int B = kWideStrip;
  float a0[B] = {};
  if (out1 == nullptr) {
    for (std::int64_t b = 0; b < I; ++b) {
      const float c = k[b];
      const float* s = in + b * B;
      for (int j = 0; j < B; ++j) a0[j] += c * s[j];
    }
    for (int j = 0; j < B; ++j) out0[j] = a0[j];
    return;
  }
  float a1[B] = {};
  for (int j = 0; j < B; ++j) a0[j] += k[0] * in[j];
  for (std::int64_t b = 1; b < I; ++b) {
    const float c0 = k[b], c1 = k[b - 1];
    const float* s = in + b * B;
    for (int j = 0; j < B; ++j) {
      a0[j] += c0 * s[j];
      a1[j] += c1 * s[j];
    }
  }
  const float* s = in + I * B;
  for (int j = 0; j < B; ++j) a1[j] += k[I - 1] * s[j];
  for (int j = 0; j < B; ++j) {
    out0[j] = a0[j];
    out1[j] = a1[j];
  }
}

}  // namespace dtflop::kernels
