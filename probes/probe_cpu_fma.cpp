// CPU floating-point rate: independent FMA chains (12 vector registers' worth) per thread,
// FP32 and FP64, one thread and all threads, with the widest vector instructions the CPU has
// (AVX-512F, AVX2+FMA, else SSE2 multiply + add). Every chain's end value is checked against
// its exact value. The figures are compared with cores x clock x lanes x 2 when the clock is
// known.
#include <algorithm>
#include <chrono>
#include <vector>

#include <fmt/format.h>

#include "probes/cpu_kernels.hpp"
#include "probes/identity.hpp"
#include "probes/measure.hpp"
#include "probes/probe.hpp"
#include "probes/team.hpp"

namespace dtflop::probes {
namespace {

struct Plan {
  double target_seconds;  // per repetition
  int reps;
};

Plan plan(Effort e) {
  switch (e) {
    case Effort::smoke: return {0.002, 2};
    case Effort::quick: return {0.05, 7};
    case Effort::full: return {0.2, 10};
  }
  return {0.05, 5};
}

// a = -1 and b = 3 go through volatiles into a function of another file: the compiler cannot
// know them, so each step is a real FMA, and the exact result alternates between the start
// value x0 and b - x0 (small integers: no rounding at all).
volatile double g_a = -1.0;
volatile double g_b = 3.0;

template <typename T>
std::vector<Measurement> rate(int threads, cpu::Isa isa, const Plan& p, const CpuInfo& ci,
                              const ProbeOptions& o) {
  constexpr bool fp64 = sizeof(T) == 8;
  const char* prec = fp64 ? "FP64" : "FP32";
  const int chains = cpu::fma_chain_count(isa, fp64);
  const T a = static_cast<T>(g_a), b = static_cast<T>(g_b);
  Team team(threads);
  std::vector<std::vector<T>> acc(static_cast<std::size_t>(threads),
                                  std::vector<T>(static_cast<std::size_t>(chains)));
  auto start_value = [](int w, int j) { return static_cast<T>(w * 37 + j); };
  // The work is kChunks chunks of `n` steps a thread, taken by whichever worker is free
  // (Team::run_chunks): the rate is the team's throughput as cpu-par's dynamic schedules see it,
  // not the pace of the slowest CPU. Each chunk's chains are checked when it ends.
  constexpr std::int64_t kChunks = 8;
  const std::int64_t chunks = kChunks * threads;
  std::int64_t iters = 1 << 12;
  auto once = [&](std::int64_t n) {
    return team.run_chunks(chunks, [&](int w, std::int64_t) {
      auto& x = acc[static_cast<std::size_t>(w)];
      for (int j = 0; j < chains; ++j) x[static_cast<std::size_t>(j)] = start_value(w, j);
      cpu::fma_chains(isa, n, a, b, x.data());
      for (int j = 0; j < chains; ++j) {
        const T x0 = start_value(w, j);
        const T expect = n % 2 ? b - x0 : x0;
        const T got = x[static_cast<std::size_t>(j)];
        if (got != expect)
          throw ValidationError(fmt::format("CPU {} FMA chain {} of thread {} ended on {}, expected {}", prec, j, w,
                                            got, expect));
      }
    });
  };
  // Calibrate: grow until a run takes a tenth of the target, then scale to the target. The
  // size it stopped at is timed again and the faster time kept: on a shared machine one of
  // these short runs can lose the CPU for a scheduler tick (milliseconds, against a 2 ms smoke
  // target), and scaling by that stalled time would shrink the timed runs to a few steps,
  // whose time is then the team's wake-up and not the FMAs.
  double t = once(iters);
  while (t < p.target_seconds / 10 && iters < (std::int64_t{1} << 40)) {
    iters *= 4;
    t = once(iters);
  }
  t = std::min(t, once(iters));
  iters = std::max<std::int64_t>(1, static_cast<std::int64_t>(static_cast<double>(iters) * p.target_seconds / t));

  std::vector<double> times;
  for (int r = 0; r < p.reps; ++r) times.push_back(once(iters));
  const double flops = 2.0 * chains * static_cast<double>(iters) * static_cast<double>(chunks);
  const std::string who = threads == 1 ? "1 thread" : fmt::format("{} threads", threads);
  const std::string k = fmt::format("{}_{}", fp64 ? "fp64" : "fp32", threads == 1 ? "1" : "all");
  const Param param = fp64 ? (threads == 1 ? Param::V_C1_fp64 : Param::V_C_fp64)
                           : (threads == 1 ? Param::V_C1_fp32 : Param::V_C_fp32);
  std::vector<Measurement> out;
  out.push_back(rate_measurement(
      k, fmt::format("{} FMA, {}", prec, who), "FLOP/s", flops, times, param,
      fmt::format("{} independent chains x = fma(x, a, b) per thread, {}, {} chunks of {} steps taken by whichever "
                  "thread is free, median of {}",
                  chains, cpu::to_string(isa), chunks, iters, p.reps)));
  const double value = out.back().value;
  // Against the simple peak: cores x clock x lanes x 2 FLOP (one FMA per cycle per core).
  if (ci.clock_ghz) {
    const int cores = threads == 1 ? 1 : std::min(threads, ci.cores);
    const int lanes = cpu::lanes(isa, fp64);
    const double peak1 = cores * *ci.clock_ghz * 1e9 * lanes * 2.0;
    Measurement m;
    m.key = fmt::format("{}_peak_ratio", k);
    m.label = fmt::format("{} {} / ({} core{} x {:.3g} GHz x {} lanes x 2)", prec, who, cores,
                          cores == 1 ? "" : "s", *ci.clock_ghz, lanes);
    m.unit = std::string("x");
    m.value = value / peak1;
    m.note = fmt::format(
        "clock from {}; a core with two FMA units (AMD Zen 2-5, Intel Xeon Gold/Platinum) "
        "peaks at 2x this denominator, and boost clocks above the nominal one raise the ratio",
        ci.clock_source);
    out.push_back(m);
  }
  o.say(fmt::format("  CPU {} FMA, {}: {:.1f} GFLOP/s", prec, who, value / 1e9));
  return out;
}

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  const CpuInfo ci = cpu_info();
  const cpu::Isa isa = cpu::best_isa();
  const Plan p = plan(o.effort);
  auto add = [&r](std::vector<Measurement> m) {
    r.measurements.insert(r.measurements.end(), m.begin(), m.end());
  };
  add(rate<float>(1, isa, p, ci, o));
  add(rate<double>(1, isa, p, ci, o));
  if (ci.threads > 1) {
    add(rate<float>(ci.threads, isa, p, ci, o));
    add(rate<double>(ci.threads, isa, p, ci, o));
  } else {
    for (Param from : {Param::V_C1_fp32, Param::V_C1_fp64}) {
      auto it = std::find_if(r.measurements.begin(), r.measurements.end(),
                             [from](const Measurement& m) { return m.param == from; });
      Measurement all = *it;
      all.param = from == Param::V_C1_fp32 ? Param::V_C_fp32 : Param::V_C_fp64;
      all.key = from == Param::V_C1_fp32 ? "fp32_all" : "fp64_all";
      all.note += " (only one CPU is available to this process)";
      r.measurements.push_back(all);
    }
  }
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_cpu_fma) {
  registry.add({"cpu-fma",
                "CPU FP32/FP64 rate: vectorised FMA chains, one thread and all threads", false, 20,
                dtflop::probes::run});
}
