// Compiled with the project's portable flags (no -march): the AVX2 and AVX-512 versions are
// separate functions with target attributes, chosen at run time by best_isa(). The FMA loop
// is plain C++ (std::fma over an array of accumulators) that GCC vectorises and keeps in
// registers; docs/probe.md shows the disassembly (vfmadd132ps on ymm / zmm registers).
#include "probes/cpu_kernels.hpp"

#include "kernels/host_loops.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include <fmt/format.h>

namespace dtflop::probes::cpu {

namespace {

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define DTFLOP_X86_DISPATCH 1
#define DTFLOP_TARGET_AVX2 __attribute__((target("avx2,fma")))
#define DTFLOP_TARGET_AVX512 __attribute__((target("avx512f,prefer-vector-width=512")))
#endif

// N independent chains; with a fused multiply-add per step where `Fused` (the ISA has FMA).
// std::fma without FMA hardware would be a slow library call, so the generic version does a
// separate multiply and add: the same 2 FLOPs, the same exact result for the probe's values.
template <typename T, int N, bool Fused>
[[gnu::always_inline]] inline void chains_body(std::int64_t iterations, T a, T b, T* acc) {
  T x[N];
  for (int j = 0; j < N; ++j) x[j] = acc[j];
  for (std::int64_t i = 0; i < iterations; ++i) {
    for (int j = 0; j < N; ++j) {
      if constexpr (Fused)
        x[j] = std::fma(x[j], a, b);
      else
        x[j] = x[j] * a + b;
    }
  }
  for (int j = 0; j < N; ++j) acc[j] = x[j];
}

[[gnu::always_inline]] inline void copy_body(double* __restrict a, const double* __restrict b,
                                             std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) a[i] = b[i];
}

[[gnu::always_inline]] inline void triad_body(double* __restrict a, const double* __restrict b,
                                              const double* __restrict c, double s,
                                              std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) a[i] = b[i] + s * c[i];
}

// 16 running sums, so that the additions of one step do not wait on each other and the loop is
// bound by its loads (GCC keeps them in 2-4 vector registers); the sum of small integers is
// exact in any order.
[[gnu::always_inline]] inline double sum_body(const double* __restrict b, std::size_t n) {
  constexpr std::size_t kSums = 16;
  double acc[kSums] = {};
  std::size_t i = 0;
  for (; i + kSums <= n; i += kSums)
    for (std::size_t j = 0; j < kSums; ++j) acc[j] += b[i + j];
  for (; i < n; ++i) acc[0] += b[i];
  double s = 0;
  for (std::size_t j = 0; j < kSums; ++j) s += acc[j];
  return s;
}

// 12 vector registers of chains for each ISA (see fma_chain_count).
constexpr int kRegs = 12;
// SSE2 on x86-64; a 128-bit vector unit is the common baseline elsewhere too.
constexpr int kGenericBytes = 16;

void generic_f32(std::int64_t n, float a, float b, float* acc) {
  chains_body<float, kRegs * kGenericBytes / 4, false>(n, a, b, acc);
}
void generic_f64(std::int64_t n, double a, double b, double* acc) {
  chains_body<double, kRegs * kGenericBytes / 8, false>(n, a, b, acc);
}
void generic_copy(double* a, const double* b, std::size_t n) { copy_body(a, b, n); }
void generic_triad(double* a, const double* b, const double* c, double s, std::size_t n) {
  triad_body(a, b, c, s, n);
}
double generic_sum(const double* b, std::size_t n) { return sum_body(b, n); }

#ifdef DTFLOP_X86_DISPATCH
DTFLOP_TARGET_AVX2 void avx2_f32(std::int64_t n, float a, float b, float* acc) {
  chains_body<float, kRegs * 8, true>(n, a, b, acc);
}
DTFLOP_TARGET_AVX2 void avx2_f64(std::int64_t n, double a, double b, double* acc) {
  chains_body<double, kRegs * 4, true>(n, a, b, acc);
}
DTFLOP_TARGET_AVX2 void avx2_copy(double* a, const double* b, std::size_t n) { copy_body(a, b, n); }
DTFLOP_TARGET_AVX2 void avx2_triad(double* a, const double* b, const double* c, double s,
                                   std::size_t n) {
  triad_body(a, b, c, s, n);
}
DTFLOP_TARGET_AVX2 double avx2_sum(const double* b, std::size_t n) { return sum_body(b, n); }
DTFLOP_TARGET_AVX512 double avx512_sum(const double* b, std::size_t n) { return sum_body(b, n); }
DTFLOP_TARGET_AVX512 void avx512_f32(std::int64_t n, float a, float b, float* acc) {
  chains_body<float, kRegs * 16, true>(n, a, b, acc);
}
DTFLOP_TARGET_AVX512 void avx512_f64(std::int64_t n, double a, double b, double* acc) {
  chains_body<double, kRegs * 8, true>(n, a, b, acc);
}
DTFLOP_TARGET_AVX512 void avx512_copy(double* a, const double* b, std::size_t n) {
  copy_body(a, b, n);
}
DTFLOP_TARGET_AVX512 void avx512_triad(double* a, const double* b, const double* c, double s,
                                       std::size_t n) {
  triad_body(a, b, c, s, n);
}
#endif

bool supported(Isa isa) {
  switch (isa) {
    case Isa::generic: return true;
#ifdef DTFLOP_X86_DISPATCH
    case Isa::avx2: return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    case Isa::avx512: return __builtin_cpu_supports("avx512f");
#else
    case Isa::avx2:
    case Isa::avx512: return false;
#endif
  }
  return false;
}

void require(Isa isa) {
  if (!supported(isa))
    throw std::invalid_argument(
        fmt::format("this CPU (or this build) does not support the {} kernels", to_string(isa)));
}

}  // namespace

std::string_view to_string(Isa isa) {
  switch (isa) {
    case Isa::generic: return "generic (no FMA)";
    case Isa::avx2: return "AVX2+FMA";
    case Isa::avx512: return "AVX-512F";
  }
  return "?";
}

Isa best_isa() {
  if (supported(Isa::avx512)) return Isa::avx512;
  if (supported(Isa::avx2)) return Isa::avx2;
  return Isa::generic;
}

int lanes(Isa isa, bool fp64) {
  const int bytes = isa == Isa::avx512 ? 64 : isa == Isa::avx2 ? 32 : kGenericBytes;
  return bytes / (fp64 ? 8 : 4);
}

bool has_fma(Isa isa) { return isa != Isa::generic; }

int fma_chain_count(Isa isa, bool fp64) { return kRegs * lanes(isa, fp64); }

void fma_chains(Isa isa, std::int64_t iterations, float a, float b, float* acc) {
  require(isa);
  switch (isa) {
#ifdef DTFLOP_X86_DISPATCH
    case Isa::avx512: return avx512_f32(iterations, a, b, acc);
    case Isa::avx2: return avx2_f32(iterations, a, b, acc);
#endif
    default: return generic_f32(iterations, a, b, acc);
  }
}

void fma_chains(Isa isa, std::int64_t iterations, double a, double b, double* acc) {
  require(isa);
  switch (isa) {
#ifdef DTFLOP_X86_DISPATCH
    case Isa::avx512: return avx512_f64(iterations, a, b, acc);
    case Isa::avx2: return avx2_f64(iterations, a, b, acc);
#endif
    default: return generic_f64(iterations, a, b, acc);
  }
}

void stream_copy(Isa isa, double* a, const double* b, std::size_t n) {
  require(isa);
  switch (isa) {
#ifdef DTFLOP_X86_DISPATCH
    case Isa::avx512: return avx512_copy(a, b, n);
    case Isa::avx2: return avx2_copy(a, b, n);
#endif
    default: return generic_copy(a, b, n);
  }
}

void stream_triad(Isa isa, double* a, const double* b, const double* c, double s, std::size_t n) {
  require(isa);
  switch (isa) {
#ifdef DTFLOP_X86_DISPATCH
    case Isa::avx512: return avx512_triad(a, b, c, s, n);
    case Isa::avx2: return avx2_triad(a, b, c, s, n);
#endif
    default: return generic_triad(a, b, c, s, n);
  }
}

double stream_sum(Isa isa, const double* b, std::size_t n) {
  require(isa);
  switch (isa) {
#ifdef DTFLOP_X86_DISPATCH
    case Isa::avx512: return avx512_sum(b, n);
    case Isa::avx2: return avx2_sum(b, n);
#endif
    default: return generic_sum(b, n);
  }
}

// The chained window and the serial sum are the workloads' own loops (kernels/host_loops.hpp).
double window_chained(const double* in, const double* k, std::int64_t taps, std::int64_t n, double* out) {
  kernels::correlate_chained(in + (taps - 1), n, k, taps, out);
  const std::int64_t groups = (n + kWindowChainedGroup - 1) / kWindowChainedGroup;
  return 2.0 * static_cast<double>(groups * kWindowChainedGroup) * static_cast<double>(taps);
}

double serial_sum(const double* in, std::int64_t n, double* sum) {
  *sum = kernels::serial_sum(n, in);
  return static_cast<double>(n);
}

}  // namespace dtflop::probes::cpu
