// K_CD and K_CW: what a FLOP of a sliding-window correlation costs on this CPU, relative to one at
// the probed FMA rate of one thread, for the two shapes the CPU backends' taps have, and V_CS, the
// rate of a plain sum (cpu_kernels.hpp, docs/model.md 2.4):
//   K_CD  float64, 8 outputs in flight, baseline instruction set: chains of dependent additions,
//         paced by the adder's latency (the float64 reference loops, cpu-seq's taps);
//   K_CW  float32, 64 outputs in flight, AVX2+FMA where the CPU has it: paced by one unaligned
//         vector load per FMA (the vectorized loops, cpu-par's x-pass);
//   K_CA  float32, two rows of 32 outputs, each row loaded once for two FMAs (cpu-par's y-pass);
//   V_CS  one chain of dependent float64 additions over a row (the workloads' host sums), paced by
//         the adder's latency and so by the clock of the core it runs on: timed on several
//         placements of its thread, the median (probes/placements.hpp), like the other one-thread
//         latency probes;
//   K_CW_all, K_CA_all  the two float32 windows and the FMA loop rerun on every usable CPU at once
//         (cpu-par's threads): hyperthreads share a core's FMA units but hide each other's loads.
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

#include "model/stats.hpp"
#include "probes/cpu_kernels.hpp"
#include "probes/measure.hpp"
#include "probes/placements.hpp"
#include "probes/probe.hpp"
#include "probes/team.hpp"

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
using Clock = std::chrono::steady_clock;
double timed(const std::function<double(std::int64_t)>& once, std::int64_t count, double* flops) {
  const auto t0 = Clock::now();
  *flops = once(count);
  return std::chrono::duration<double>(Clock::now() - t0).count();
}
// The count of calls that takes one thread the plan's target time.
std::int64_t calibrate(const std::function<double(std::int64_t)>& once, const Plan& p) {
  double flops = 0;
  std::int64_t count = 1;
  double t = timed(once, count, &flops);
  while (t < p.target_seconds / 10 && count < (std::int64_t{1} << 40)) {
    count *= 4;
    t = timed(once, count, &flops);
  }
  t = std::min(t, timed(once, count, &flops));  // a stalled calibration run must not shrink the timed ones
  return std::max<std::int64_t>(1, static_cast<std::int64_t>(static_cast<double>(count) * p.target_seconds / t));
}
Timed time_count(const std::function<double(std::int64_t)>& once, std::int64_t count, const Plan& p) {
  Timed r;
  for (int i = 0; i < p.reps; ++i) r.seconds.push_back(timed(once, count, &r.flops));
  return r;
}
Timed time_calls(const std::function<double(std::int64_t)>& once, const Plan& p) {
  return time_count(once, calibrate(once, p), p);
}

// A loop's work for `calls` calls (returning its FLOPs), with state of its own: one per worker.
using Calls = std::function<double(std::int64_t)>;
// Times the loop on one thread (threads = 1), or on `threads` workers at once, each running its own
// copy (make() gives a fresh one), as time_calls() does: the FLOPs are all workers' together. The
// count of calls is calibrated on one copy alone, so the team's wake-ups (long on a loaded machine)
// cannot shrink the timed work to a few calls, and the work is handed out in chunks to whichever
// worker is free, so one CPU lost to another process slows the team by its share, not to its pace.
Timed time_on(int threads, const Plan& p, const std::function<Calls()>& make) {
  if (threads <= 1) return time_calls(make(), p);
  // Each worker's share is kChunks chunks of count / kChunks calls, taken by whichever worker is free
  // (Team::run_chunks), as cpu-par's dynamic schedules take its rows.
  constexpr std::int64_t kChunks = 8;
  const std::int64_t per_chunk = std::max<std::int64_t>(1, calibrate(make(), p) / kChunks);
  std::vector<Calls> each;
  for (int w = 0; w < threads; ++w) each.push_back(make());
  Team team(threads);
  std::vector<double> flops(static_cast<std::size_t>(threads));
  return time_count(
      [&](std::int64_t calls) {
        for (double& f : flops) f = 0;
        team.run_chunks(kChunks * threads, [&](int w, std::int64_t) {
          flops[static_cast<std::size_t>(w)] += each[static_cast<std::size_t>(w)](calls);
        });
        double total = 0;
        for (double f : flops) total += f;
        return total;
      },
      per_chunk, p);
}
std::string who(int threads) { return threads <= 1 ? "1 thread" : fmt::format("{} threads", threads); }

// The probe's values go through volatiles so that the compiler cannot fold the taps.
volatile double g_a = -1.0;
volatile double g_b = 3.0;

template <typename T>
Measurement peak(const Plan& p, int threads = 1) {
  constexpr bool fp64 = sizeof(T) == 8;
  const cpu::Isa isa = cpu::best_isa();
  const int chains = cpu::fma_chain_count(isa, fp64);
  const T a = static_cast<T>(g_a), b = static_cast<T>(g_b);
  const auto make = [&]() -> Calls {
    return [chains, isa, a, b, acc = std::vector<T>(static_cast<std::size_t>(chains))](std::int64_t steps) mutable {
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
  };
  const Timed t = time_on(threads, p, make);
  const char* prec = fp64 ? "fp64" : "fp32";
  return rate_measurement(fmt::format("{}_reference{}", prec, threads > 1 ? "_all" : ""),
                          fmt::format("CPU {} FMA, {} (reference)", fp64 ? "FP64" : "FP32", who(threads)), "FLOP/s", t.flops,
                          t.seconds, std::nullopt,
                          fmt::format("the cpu-fma probe's kernel ({} chains, {}), rerun so the ratio is of one run",
                                      chains, cpu::to_string(isa)));
}

// One window: times `calls` correlations of the row, checks every output against its exact
// value (small integers: every partial sum is exact in float32 and float64).
template <typename T>
Measurement window(const Plan& p, int group, bool reversed, std::string key, std::string label, std::string how,
                   double (*kernel)(const T*, const T*, std::int64_t, std::int64_t, T*), int threads = 1) {
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
  const auto make = [&]() -> Calls {
    return [&p, &k, &expect, &label, kernel, in, out](std::int64_t calls) mutable {
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
  };
  const Timed t = time_on(threads, p, make);
  return rate_measurement(std::move(key), std::move(label), "FLOP/s", t.flops, t.seconds, std::nullopt,
                          fmt::format("{}; a row of {} outputs, {} taps, median of {}", how, p.n, p.taps, p.reps));
}

// cpu-par's y-pass block over a strip of 64 rows of 32 floats (in the first-level cache), every
// output checked against its exact value.
Measurement aligned(const Plan& p, int threads = 1) {
  constexpr std::int64_t B = cpu::kWindowStrip;
  const std::int64_t rows = 64;
  std::vector<float> in(static_cast<std::size_t>((rows + p.taps) * B)), k(static_cast<std::size_t>(p.taps));
  std::vector<float> out(static_cast<std::size_t>(rows * B));
  for (std::size_t i = 0; i < in.size(); ++i) in[i] = static_cast<float>((i * 5 + 2) % 9);
  for (std::size_t a = 0; a < k.size(); ++a) k[a] = static_cast<float>(1 + a % 4);
  std::vector<double> expect(out.size());
  for (std::int64_t y = 0; y < rows; ++y)
    for (std::int64_t x = 0; x < B; ++x) {
      double s = 0;
      for (std::int64_t a = 0; a < p.taps; ++a)
        s += static_cast<double>(k[static_cast<std::size_t>(a)]) *
             static_cast<double>(in[static_cast<std::size_t>((y + a) * B + x)]);
      expect[static_cast<std::size_t>(y * B + x)] = s;
    }
  const auto make = [&]() -> Calls {
    return [&p, &k, &expect, in, out](std::int64_t calls) mutable {
      double flops = 0;
      for (std::int64_t c = 0; c < calls; ++c) {
        in[0] = static_cast<float>(c % 2 ? 1 : 2);
        flops += cpu::window_aligned(in.data(), k.data(), p.taps, rows, out.data());
      }
      in[0] = 2;
      cpu::window_aligned(in.data(), k.data(), p.taps, rows, out.data());
      for (std::int64_t y = 0; y < rows; ++y)
        for (std::int64_t x = 0; x < B; ++x)
          if (static_cast<double>(out[static_cast<std::size_t>(y * B + x)]) !=
              expect[static_cast<std::size_t>(y * B + x)])
            throw ValidationError(fmt::format("CPU FP32 aligned window: output ({}, {}) is {}, expected {}", y, x,
                                              out[static_cast<std::size_t>(y * B + x)],
                                              expect[static_cast<std::size_t>(y * B + x)]));
      return flops;
    };
  };
  const Timed t = time_on(threads, p, make);
  return rate_measurement(threads > 1 ? "aligned_fp32_all" : "aligned_fp32",
                          fmt::format("CPU FP32 aligned window, {}", who(threads)), "FLOP/s", t.flops, t.seconds,
                          std::nullopt,
                          fmt::format("cpu-par's y-pass block: {} rows of {} floats, {} taps, each row loaded once for "
                                      "two FMAs, {}, median of {}",
                                      rows, B, p.taps, cpu::window_wide_isa(), p.reps));
}

// The serial chain: a float64 sum of the row (small integers: exact), `calls` times, on several
// placements of the thread (the count of calls found once, here): the median over the placements
// of each one's median. One placement read 0.77 to 1.41 GFLOP/s on the lent H100s' and H200s'
// hosts from lend to lend, where cuda-seed's host sum ran at 1.1-1.26 on both (docs/PERFORMANCE.md).
Measurement serial(const Plan& p, Effort effort) {
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
  const std::int64_t count = calibrate(once, p);
  double flops = 0;
  const Placed placed = on_placements(latency_placements(effort), [&] {
    const Timed t = time_count(once, count, p);
    flops = t.flops;
    return summarize(t.seconds).median;
  });
  return rate_measurement("serial_fp64", "CPU serial chain of float64 additions, 1 thread", "FLOP/s", flops,
                          placed.values, Param::V_CS,
                          fmt::format("a plain sum of {} values, each addition waiting for the last: the median over "
                                      "{} of the median of {} each",
                                      n, describe_placements(placed.cpus), p.reps));
}

// `rate`: the profile's parameter of the reference rate (V_C1_fp64, V_C1_fp32 or V_C_fp32).
Measurement ratio(const Measurement& reference, const Measurement& loop, Param param, Param rate, std::string label) {
  Measurement k;
  k.key = std::string(info(param).name);
  k.label = std::move(label);
  k.unit = "x";
  k.value = reference.value / loop.value;
  k.stats = loop.stats;  // the ratio is proportional to the loop's time: its spread is the loop's
  k.param = param;
  k.note = fmt::format("{:.4g} FLOP/s in the loop against {:.4g} FLOP/s at the FMA rate", loop.value, reference.value);
  k.reference_param = rate;
  k.reference = reference.value;
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
  const Measurement k_cd = ratio(fp64, chained, Param::K_CD, Param::V_C1_fp64, "cost of a chained sliding-window FLOP / one at the FMA rate");
  const Measurement k_cw = ratio(fp32, wide, Param::K_CW, Param::V_C1_fp32, "cost of a sliding-window FLOP / one at the FMA rate");
  const Measurement al = aligned(p);
  const Measurement k_ca = ratio(fp32, al, Param::K_CA, Param::V_C1_fp32, "cost of an aligned-window FLOP / one at the FMA rate");
  o.say(fmt::format("  CPU aligned window (fp32): {:.1f} GFLOP/s, K_CA {:.2f}", al.value / 1e9, k_ca.value));
  o.say(fmt::format("  CPU chained window (fp64): {:.2f} GFLOP/s, K_CD {:.2f}; wide window (fp32): {:.1f} GFLOP/s, "
                    "K_CW {:.2f}",
                    chained.value / 1e9, k_cd.value, wide.value / 1e9, k_cw.value));
  // With every hardware thread at work (cpu-par's default): two hyperthreads of a core share its FMA
  // units but hide each other's load latency, so a load-bound window gains more than the peak does.
  // A window does its FLOPs as FMAs, so it cannot run faster than the FMA loop: a ratio well under 1
  // says another process took the CPUs during one of the runs (all-thread runs on a small, shared
  // machine are easily disturbed; docs/PERFORMANCE.md). Such runs are repeated, and where they stay
  // disturbed the one-thread ratios stand in, marked so, rather than a figure no CPU can have.
  constexpr double kFloor = 0.9;
  const auto stand_in = [&](const std::string& why) {
    std::vector<Measurement> out;
    for (auto [from, to] : {std::pair{k_cw, Param::K_CW_all}, std::pair{k_ca, Param::K_CA_all}}) {
      Measurement m = from;
      m.param = to;
      m.key = std::string(info(to).name);
      m.note += fmt::format(" (the one-thread ratio: {})", why);
      out.push_back(m);
    }
    return out;
  };
  std::vector<Measurement> all;
  if (const int threads = usable_cpus(); threads > 1) {
    for (int attempt = 1; attempt <= 3 && all.empty(); ++attempt) {
      const Measurement fp32_all = peak<float>(p, threads);
      const Measurement wide_all = window<float>(
          p, cpu::kWindowWideGroup, false, "wide_fp32_all", fmt::format("CPU FP32 sliding window, {}", who(threads)),
          fmt::format("64 outputs in flight, {}", cpu::window_wide_isa()), cpu::window_wide, threads);
      const Measurement al_all = aligned(p, threads);
      const Measurement k_cw_all = ratio(fp32_all, wide_all, Param::K_CW_all, Param::V_C_fp32, "K_CW with every thread at work");
      const Measurement k_ca_all = ratio(fp32_all, al_all, Param::K_CA_all, Param::V_C_fp32, "K_CA with every thread at work");
      if (k_cw_all.value >= kFloor && k_ca_all.value >= kFloor) {
        all = {fp32_all, wide_all, k_cw_all, al_all, k_ca_all};
        o.say(fmt::format("  CPU windows on {}: K_CW {:.2f}, K_CA {:.2f}", who(threads), k_cw_all.value, k_ca_all.value));
      } else if (attempt == 3) {
        const std::string why = fmt::format(
            "three runs on {} gave windows faster than the FMA loop (last K_CW {:.3g}, K_CA {:.3g}): other load on "
            "this machine; rerun the probe when it is quiet",
            who(threads), k_cw_all.value, k_ca_all.value);
        o.say(fmt::format("  warning: {}", why));
        all = stand_in(why);
      }
    }
  } else {
    all = stand_in("only one CPU is available to this process");
  }
  const Measurement chain = serial(p, o.effort);
  o.say(fmt::format("  CPU serial chain (fp64 sum): {:.2f} GFLOP/s", chain.value / 1e9));
  for (const Measurement* m : {&fp64, &chained, &k_cd, &fp32, &wide, &k_cw, &al, &k_ca, &chain})
    r.measurements.push_back(*m);
  r.measurements.insert(r.measurements.end(), all.begin(), all.end());
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
