// K_CD and K_CW: what a FLOP of a sliding-window correlation costs on this CPU, relative to one at
// the probed FMA rate of one thread, for the two shapes the CPU backends' taps have, and V_CS, the
// rate of a plain sum (cpu_kernels.hpp, docs/model.md 2.4):
//   K_CD  float64, 8 outputs in flight, baseline instruction set: chains of dependent additions,
//         paced by the adder's latency (the float64 reference loops, cpu-seq's taps);
//   K_CW  float32, 64 outputs in flight, AVX2+FMA where the CPU has it: paced by one unaligned
//         vector load per FMA (the vectorized loops, cpu-par's x-pass);
//   K_CA  float32, two rows of 32 outputs, each row loaded once for two FMAs (cpu-par's y-pass);
//   V_CS  one chain of dependent float64 additions over a row (the workloads' host sums).
// A row of 2048 outputs and 33 taps stays in the first-level cache, so memory plays no part: the
// ratio is the loop's own. The FMA rates are rerun here (the cpu-fma probe's kernel) so that each
// ratio is of one run. Every output of every timed call is checked against its exact value.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>

#include "probes/cpu_kernels.hpp"
#include "probes/measure.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes {
namespace {

struct Plan {
  double target_seconds;  // per repetition
  int reps;
  std::int64_t n;         // outputs of the row (a multiple of both groups)
  std::int64_t taps;
};

Plan plan(Effort e) {
  switch (e) {
    case Effort::smoke: return {0.002, 3, 256, 9};
    case Effort::quick: return {0.04, 7, 2048, 97};
    case Effort::full: return {0.15, 9, 2048, 97};
  }
  return {0.04, 7, 2048, 97};
}

// Times `once(count)` (which does `count` calls' work and returns its FLOPs): the count grows
// until a call takes a tenth of the target, is scaled to the target, and is then timed `reps`
// times. Returns the FLOPs of one repetition and the repetitions' seconds.
struct Timed {
  double flops = 0;
  std::vector<double> seconds;
};
Timed time_calls(const std::function<double(std::int64_t)>& once, const Plan& p) {
  using clock = std::chrono::steady_clock;
  auto timed = [&](std::int64_t count, double* flops) {
    const auto t0 = clock::now();
    *flops = once(count);
    return std::chrono::duration<double>(clock::now() - t0).count();
  };
  double flops = 0;
  std::int64_t count = 1;
  double t = timed(count, &flops);
  while (t < p.target_seconds / 10 && count < (std::int64_t{1} << 40)) {
    count *= 4;
    t = timed(count, &flops);
  }
  t = std::min(t, timed(count, &flops));  // a stalled calibration run must not shrink the timed ones
  count = std::max<std::int64_t>(1, static_cast<std::int64_t>(static_cast<double>(count) * p.target_seconds / t));
  Timed r;
  for (int i = 0; i < p.reps; ++i) r.seconds.push_back(timed(count, &r.flops));
  return r;
}

// The probe's values go through volatiles so that the compiler cannot fold the taps.
volatile double g_a = -1.0;
volatile double g_b = 3.0;

template <typename T>
Measurement peak(const Plan& p) {
  constexpr bool fp64 = sizeof(T) == 8;
  const cpu::Isa isa = cpu::best_isa();
  const int chains = cpu::fma_chain_count(isa, fp64);
  std::vector<T> acc(static_cast<std::size_t>(chains));
  const T a = static_cast<T>(g_a), b = static_cast<T>(g_b);
  auto once = [&](std::int64_t steps) {
    for (int j = 0; j < chains; ++j) acc[static_cast<std::size_t>(j)] = static_cast<T>(j);
    cpu::fma_chains(isa, steps, a, b, acc.data());
    for (int j = 0; j < chains; ++j) {
      const T expect = steps % 2 ? b - static_cast<T>(j) : static_cast<T>(j);
      if (acc[static_cast<std::size_t>(j)] != expect)
        throw ValidationError(fmt::format("CPU {} FMA chain {} ended on {}, expected {}", fp64 ? "FP64" : "FP32", j,
                                          acc[static_cast<std::size_t>(j)], expect));
    }
    return 2.0 * chains * static_cast<double>(steps);
  };
  const Timed t = time_calls(once, p);
  const char* prec = fp64 ? "fp64" : "fp32";
  return rate_measurement(fmt::format("{}_reference", prec),
                          fmt::format("CPU {} FMA, 1 thread (reference)", fp64 ? "FP64" : "FP32"), "FLOP/s", t.flops,
                          t.seconds, std::nullopt,
                          fmt::format("the cpu-fma probe's kernel ({} chains, {}), rerun so the ratio is of one run",
                                      chains, cpu::to_string(isa)));
}

// One window: times `calls` correlations of the row, checks every output against its exact
// value (small integers: every partial sum is exact in float32 and float64).
template <typename T>
Measurement window(const Plan& p, int group, bool reversed, std::string key, std::string label, std::string how,
                   double (*kernel)(const T*, const T*, std::int64_t, std::int64_t, T*)) {
  if (p.n % group != 0) throw std::logic_error("cpu-window: the row is not a whole number of groups");
  std::vector<T> in(static_cast<std::size_t>(p.n + p.taps - 1)), k(static_cast<std::size_t>(p.taps));
  std::vector<T> out(static_cast<std::size_t>(p.n));
  for (std::size_t i = 0; i < in.size(); ++i) in[i] = static_cast<T>((i * 7 + 3) % 11);
  for (std::size_t a = 0; a < k.size(); ++a) k[a] = static_cast<T>(1 + a % 3);
  std::vector<double> expect(out.size());
  for (std::int64_t x = 0; x < p.n; ++x) {
    double s = 0;
    for (std::int64_t a = 0; a < p.taps; ++a)
      s += static_cast<double>(k[static_cast<std::size_t>(a)]) *
           static_cast<double>(in[static_cast<std::size_t>(reversed ? x + p.taps - 1 - a : x + a)]);
    expect[static_cast<std::size_t>(x)] = s;
  }
  auto once = [&](std::int64_t calls) {
    double flops = 0;
    for (std::int64_t c = 0; c < calls; ++c) {
      // The first input changes from call to call (and back), so no call can be skipped.
      in[0] = static_cast<T>(c % 2 ? 1 : 3);
      flops += kernel(in.data(), k.data(), p.taps, p.n, out.data());
    }
    in[0] = static_cast<T>(3);  // the value `expect` was computed with
    kernel(in.data(), k.data(), p.taps, p.n, out.data());
    for (std::size_t x = 0; x < out.size(); ++x)
      if (static_cast<double>(out[x]) != expect[x])
        throw ValidationError(fmt::format("{}: output {} is {}, expected {}", label, x, out[x], expect[x]));
    return flops;
  };
  const Timed t = time_calls(once, p);
  return rate_measurement(std::move(key), std::move(label), "FLOP/s", t.flops, t.seconds, std::nullopt,
                          fmt::format("{}; a row of {} outputs, {} taps, median of {}", how, p.n, p.taps, p.reps));
}

// cpu-par's y-pass block over a strip of 64 rows of 32 floats (in the first-level cache), every
// output checked against its exact value.
Measurement aligned(const Plan& p) {
  constexpr std::int64_t B = cpu::kWindowStrip;
  const std::int64_t rows = 64;
  std::vector<float> in(static_cast<std::size_t>((rows + p.taps) * B)), k(static_cast<std::size_t>(p.taps));
  std::vector<float> out(static_cast<std::size_t>(rows * B));
  for (std::size_t i = 0; i < in.size(); ++i) in[i] = static_cast<float>((i * 5 + 2) % 9);
  for (std::size_t a = 0; a < k.size(); ++a) k[a] = static_cast<float>(1 + a % 4);
  auto expect = [&](std::int64_t y, std::int64_t x) {
    double s = 0;
    for (std::int64_t a = 0; a < p.taps; ++a)
      s += static_cast<double>(k[static_cast<std::size_t>(a)]) * static_cast<double>(in[static_cast<std::size_t>((y + a) * B + x)]);
    return s;
  };
  auto once = [&](std::int64_t calls) {
    double flops = 0;
    for (std::int64_t c = 0; c < calls; ++c) {
      in[0] = static_cast<float>(c % 2 ? 1 : 2);
      flops += cpu::window_aligned(in.data(), k.data(), p.taps, rows, out.data());
    }
    in[0] = 2;
    cpu::window_aligned(in.data(), k.data(), p.taps, rows, out.data());
    for (std::int64_t y = 0; y < rows; ++y)
      for (std::int64_t x = 0; x < B; ++x)
        if (static_cast<double>(out[static_cast<std::size_t>(y * B + x)]) != expect(y, x))
          throw ValidationError(fmt::format("CPU FP32 aligned window: output ({}, {}) is {}, expected {}", y, x,
                                            out[static_cast<std::size_t>(y * B + x)], expect(y, x)));
    return flops;
  };
  const Timed t = time_calls(once, p);
  return rate_measurement("aligned_fp32", "CPU FP32 aligned window, 1 thread", "FLOP/s", t.flops, t.seconds,
                          std::nullopt,
                          fmt::format("cpu-par's y-pass block: {} rows of {} floats, {} taps, each row loaded once for "
                                      "two FMAs, {}, median of {}",
                                      rows, B, p.taps, cpu::window_wide_isa(), p.reps));
}

// The serial chain: a float64 sum of the row (small integers: exact), `calls` times.
Measurement serial(const Plan& p) {
  const std::int64_t n = 4096;  // 32 KiB: in the first-level cache, so the chain and not memory sets the pace
  std::vector<double> in(static_cast<std::size_t>(n));
  for (std::size_t i = 0; i < in.size(); ++i) in[i] = static_cast<double>((i * 7 + 3) % 11);
  double exact = 0;
  for (double v : in) exact += v;
  auto once = [&](std::int64_t calls) {
    double flops = 0, sum = 0;
    for (std::int64_t c = 0; c < calls; ++c) {
      in[0] = static_cast<double>(c % 2 ? 1 : 3);  // every call sums different values
      flops += cpu::serial_sum(in.data(), n, &sum);
      if (sum != exact + in[0] - 3) throw ValidationError(fmt::format("CPU serial sum is {}, expected {}", sum, exact + in[0] - 3));
    }
    in[0] = 3;
    return flops;
  };
  const Timed t = time_calls(once, p);
  return rate_measurement("serial_fp64", "CPU serial chain of float64 additions, 1 thread", "FLOP/s", t.flops,
                          t.seconds, Param::V_CS,
                          fmt::format("a plain sum of {} values, each addition waiting for the last, median of {}", n,
                                      p.reps));
}

Measurement ratio(const Measurement& reference, const Measurement& loop, Param param, std::string label) {
  Measurement k;
  k.key = std::string(info(param).name);
  k.label = std::move(label);
  k.unit = "x";
  k.value = reference.value / loop.value;
  k.stats = loop.stats;  // the ratio is proportional to the loop's time: its spread is the loop's
  k.param = param;
  k.note = fmt::format("{:.4g} FLOP/s in the loop against {:.4g} FLOP/s at the FMA rate", loop.value, reference.value);
  return k;
}

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  const Plan p = plan(o.effort);
  const Measurement fp64 = peak<double>(p);
  const Measurement chained = window<double>(
      p, cpu::kWindowChainedGroup, true, "chained_fp64", "CPU FP64 chained sliding window, 1 thread",
      "the RBE reference's loop: 8 outputs in flight, baseline instruction set", cpu::window_chained);
  const Measurement fp32 = peak<float>(p);
  const Measurement wide = window<float>(
      p, cpu::kWindowWideGroup, false, "wide_fp32", "CPU FP32 sliding window, 1 thread",
      fmt::format("64 outputs in flight, {}", cpu::window_wide_isa()), cpu::window_wide);
  const Measurement k_cd = ratio(fp64, chained, Param::K_CD, "cost of a chained sliding-window FLOP / one at the FMA rate");
  const Measurement k_cw = ratio(fp32, wide, Param::K_CW, "cost of a sliding-window FLOP / one at the FMA rate");
  const Measurement al = aligned(p);
  const Measurement k_ca = ratio(fp32, al, Param::K_CA, "cost of an aligned-window FLOP / one at the FMA rate");
  o.say(fmt::format("  CPU aligned window (fp32): {:.1f} GFLOP/s, K_CA {:.2f}", al.value / 1e9, k_ca.value));
  o.say(fmt::format("  CPU chained window (fp64): {:.2f} GFLOP/s, K_CD {:.2f}; wide window (fp32): {:.1f} GFLOP/s, "
                    "K_CW {:.2f}",
                    chained.value / 1e9, k_cd.value, wide.value / 1e9, k_cw.value));
  const Measurement chain = serial(p);
  o.say(fmt::format("  CPU serial chain (fp64 sum): {:.2f} GFLOP/s", chain.value / 1e9));
  for (const Measurement* m : {&fp64, &chained, &k_cd, &fp32, &wide, &k_cw, &al, &k_ca, &chain})
    r.measurements.push_back(*m);
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_cpu_window) {
  registry.add({"cpu-window",
                "CPU sliding-window correlations against the FMA rate (K_CD: chained float64 taps, K_CW: vectorized "
                "float32 taps, K_CA: aligned float32 rows) and the rate of a plain sum (V_CS)",
                false, 22, dtflop::probes::run});
}
