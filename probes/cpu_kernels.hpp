// CPU kernels of the probes: FMA chains and STREAM-style copy/triad, each compiled for
// several instruction sets (target attributes) and chosen at run time, so one binary uses
// AVX-512 or AVX2+FMA where the CPU has them and still runs on any x86-64 (and elsewhere).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace dtflop::probes::cpu {

enum class Isa {
  generic,  // what the baseline target gives (SSE2 on x86-64): separate multiply and add
  avx2,     // AVX2 + FMA: 256-bit vfmadd
  avx512,   // AVX-512F: 512-bit vfmadd
};

std::string_view to_string(Isa isa);
// The widest instruction set this CPU and this build both support.
Isa best_isa();
// Values of type float (double) that one vector register of `isa` holds.
int lanes(Isa isa, bool fp64);
// True when the kernels of `isa` use fused multiply-add instructions.
bool has_fma(Isa isa);

// Independent accumulator chains one call of fma_chains() advances: 12 vector registers'
// worth, enough to cover FMA latency x FMA units on current x86 cores (4 cycles x 2 units).
int fma_chain_count(Isa isa, bool fp64);

// Runs `iterations` steps of acc[j] = acc[j] * a + b on every chain j < fma_chain_count(),
// with fused multiply-adds where the ISA has them: 2 * chains * iterations FLOPs. `acc` holds
// the chains' start values on entry and their end values on return (the caller checks them,
// so the work cannot be optimised away). Throws std::invalid_argument when `isa` is not
// supported by this CPU.
void fma_chains(Isa isa, std::int64_t iterations, float a, float b, float* acc);
void fma_chains(Isa isa, std::int64_t iterations, double a, double b, double* acc);

// STREAM kernels over n doubles. copy: a[i] = b[i] (16 bytes per element read + written);
// triad: a[i] = b[i] + s * c[i] (24 bytes per element read + written). Write-allocate
// traffic is not counted, as in STREAM.
void stream_copy(Isa isa, double* a, const double* b, std::size_t n);
void stream_triad(Isa isa, double* a, const double* b, const double* c, double s, std::size_t n);
// Read: the sum of b[0..n) (8 bytes per element read), in 16 running sums so that the loads,
// not the additions, set the pace: the cache ladder of cpu-memory.
double stream_sum(Isa isa, const double* b, std::size_t n);

// Sliding-window correlations along one row (n a multiple of the group; `in` holds n + taps - 1
// values), the two shapes the CPU backends' taps have (docs/probe.md, cpu-window):
//   window_chained: out[x] = sum_a k[a] in[x + taps - 1 - a]; the RBE reference's own loop
//     (kernels::correlate_chained): float64, 8 outputs in flight (one accumulator each), the
//     baseline instruction set: every tap's addition waits for the previous tap's, so the loop
//     runs at the adder's latency, not at the FMA units' rate.
//   window_wide: out[x] = sum_a k[a] in[x + a]; float32, 64 outputs in flight (eight AVX vectors), compiled for x86-64-v3
//     (AVX2+FMA) where the CPU has it, like the vectorized loops: enough independent chains for
//     the FMA units, so the loads (one unaligned vector load per FMA) set the pace.
//   window_aligned: cpu-par's y-pass block over a strip of `n` rows (n even) of kWindowStrip
//     floats: out[y][x] = sum_a k[a] in[y + a][x] for two rows y at a time, each row loaded once
//     feeding two FMAs (aligned loads); `in` holds n + taps rows. 2 n kWindowStrip taps FLOPs.
// Each returns the FLOPs it did: 2 n taps (window_aligned: 2 n kWindowStrip taps).
inline constexpr int kWindowChainedGroup = 8;
inline constexpr int kWindowWideGroup = 64;
inline constexpr int kWindowStrip = 32;
double window_chained(const double* in, const double* k, std::int64_t taps, std::int64_t n, double* out);
double window_wide(const float* in, const float* k, std::int64_t taps, std::int64_t n, float* out);
double window_aligned(const float* in, const float* k, std::int64_t taps, std::int64_t n, float* out);
// The plain float64 sum of in[0..n), one addition after another (kernels::serial_sum, the RBE
// reference's sum). Returns n FLOPs and the sum in *sum.
double serial_sum(const double* in, std::int64_t n, double* sum);
// The instruction set window_wide runs with on this CPU: "x86-64-v3 (AVX2+FMA)" or "baseline".
std::string_view window_wide_isa();

}  // namespace dtflop::probes::cpu
