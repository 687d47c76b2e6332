// Host memory bandwidth: STREAM copy and triad over arrays several times the last-level
// cache, one thread and all threads (each thread streams its own slice, first touched by
// itself). Bytes counted are those read plus written (write-allocate traffic not counted,
// as in STREAM). B_host_1 / B_host are the triad figures. Then the same over arrays that fit
// the last-level cache together (an eighth of it each, when its size is known): B_llc_1 /
// B_llc, the bandwidth CPU work sees while its working set stays in that cache.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>

#if defined(__unix__) || defined(__APPLE__)
#include <unistd.h>
#endif

#include <fmt/format.h>

#include "probes/cpu_kernels.hpp"
#include "probes/identity.hpp"
#include "probes/measure.hpp"
#include "probes/probe.hpp"
#include "probes/team.hpp"

namespace dtflop::probes {
namespace {

struct Plan {
  std::int64_t array_bytes;
  int reps;
  int warmup;
};

Plan plan(Effort e, std::optional<std::int64_t> llc) {
  const std::int64_t mib = 1 << 20;
  const std::int64_t cache = llc.value_or(32 * mib);
  switch (e) {
    case Effort::smoke: return {4 * mib, 3, 1};
    case Effort::quick: return {std::clamp(2 * cache, 64 * mib, 256 * mib), 8, 1};
    case Effort::full: return {std::clamp(4 * cache, 256 * mib, 1024 * mib), 20, 2};
  }
  return {64 * mib, 5, 1};
}

// Value at index i of the input arrays: small integers and halves, so b + s*c is exact.
double b_value(std::size_t i) { return static_cast<double>(i % 1024); }
double c_value(std::size_t i) { return 0.5 * static_cast<double>(i % 256); }
constexpr double kScalar = 3.0;

// Which figures a run of the kernels measures: over memory (`tag` "") or within the
// last-level cache ("llc_").
struct Target {
  const char* tag;
  const char* where;
  Param one, all;
};
constexpr Target kMemory{"", "host memory", Param::B_host_1, Param::B_host};
constexpr Target kCache{"llc_", "last-level cache", Param::B_llc_1, Param::B_llc};

std::vector<Measurement> stream(int threads, const Plan& p, cpu::Isa isa, const ProbeOptions& o, const Target& g) {
  const std::size_t n = static_cast<std::size_t>(p.array_bytes) / sizeof(double);
  // Not value-initialised: every page is first touched by the thread that streams it.
  std::unique_ptr<double[]> a(new double[n]), b(new double[n]), c(new double[n]);
  Team team(threads);
  auto slice = [&](int w) {
    const std::size_t per = (n + static_cast<std::size_t>(threads) - 1) / static_cast<std::size_t>(threads);
    const std::size_t lo = std::min(n, per * static_cast<std::size_t>(w));
    return std::pair<std::size_t, std::size_t>(lo, std::min(n, lo + per));
  };
  team.run([&](int w) {
    const auto [lo, hi] = slice(w);
    for (std::size_t i = lo; i < hi; ++i) {
      a[i] = 0;
      b[i] = b_value(i);
      c[i] = c_value(i);
    }
  });
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto poison = [&] {
    team.run([&](int w) {
      const auto [lo, hi] = slice(w);
      std::fill(a.get() + lo, a.get() + hi, nan);
    });
  };

  const std::string who = threads == 1 ? "1 thread" : fmt::format("{} threads", threads);
  const std::string what = fmt::format("arrays of {}, {}, {} kernels, median of {} runs",
                                       size_label(p.array_bytes), who, cpu::to_string(isa), p.reps);
  std::vector<Measurement> out;

  // Copy: a = b.
  auto copy = [&](int w) {
    const auto [lo, hi] = slice(w);
    cpu::stream_copy(isa, a.get() + lo, b.get() + lo, hi - lo);
  };
  for (int i = 0; i < p.warmup; ++i) team.run(copy);
  poison();
  std::vector<double> t;
  for (int i = 0; i < p.reps; ++i) t.push_back(team.run(copy));
  for (std::size_t i = 0; i < n; ++i)
    if (a[i] != b[i])
      throw ValidationError(fmt::format("host copy ({}): element {} is {}, expected {}", who, i,
                                        a[i], b[i]));
  const std::string k = threads == 1 ? "1" : "all";
  out.push_back(rate_measurement(fmt::format("{}copy_{}", g.tag, k), fmt::format("STREAM copy, {}, {}", g.where, who),
                                 "B/s", 16.0 * static_cast<double>(n), t, std::nullopt,
                                 fmt::format("a[i] = b[i], 16 B/element; {}", what)));

  // Triad: a = b + s * c.
  auto triad = [&](int w) {
    const auto [lo, hi] = slice(w);
    cpu::stream_triad(isa, a.get() + lo, b.get() + lo, c.get() + lo, kScalar, hi - lo);
  };
  for (int i = 0; i < p.warmup; ++i) team.run(triad);
  poison();
  t.clear();
  for (int i = 0; i < p.reps; ++i) t.push_back(team.run(triad));
  for (std::size_t i = 0; i < n; ++i) {
    const double expect = b_value(i) + kScalar * c_value(i);
    if (a[i] != expect)
      throw ValidationError(fmt::format("host triad ({}): element {} is {}, expected {}", who, i,
                                        a[i], expect));
  }
  out.push_back(rate_measurement(
      fmt::format("{}triad_{}", g.tag, k), fmt::format("STREAM triad, {}, {}", g.where, who), "B/s",
      24.0 * static_cast<double>(n), t, threads == 1 ? g.one : g.all,
      fmt::format("triad a[i] = b[i] + s*c[i], 24 B/element read+written; {}", what)));
  o.say(fmt::format("  {}, {}: copy {:.1f} GB/s, triad {:.1f} GB/s", g.where, who,
                    out[0].value / 1e9, out[1].value / 1e9));
  return out;
}

// Physical memory, when the system says (Linux, macOS).
std::optional<std::int64_t> physical_memory() {
#if defined(_SC_PHYS_PAGES) && defined(_SC_PAGESIZE)
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  if (pages > 0 && page > 0) return static_cast<std::int64_t>(pages) * page;
#endif
  return std::nullopt;
}

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  const CpuInfo ci = cpu_info();
  Plan p = plan(o.effort, ci.llc_bytes);
  // Three arrays: keep them within a quarter of the machine's memory.
  if (const auto mem = physical_memory())
    p.array_bytes = std::max<std::int64_t>(std::min(p.array_bytes, *mem / 12), 1 << 20);
  const cpu::Isa isa = cpu::best_isa();
  auto measure = [&](const Plan& plan, const Target& g) {
    auto one = stream(1, plan, isa, o, g);
    r.measurements.insert(r.measurements.end(), one.begin(), one.end());
    if (ci.threads > 1) {
      auto all = stream(ci.threads, plan, isa, o, g);
      r.measurements.insert(r.measurements.end(), all.begin(), all.end());
    } else {
      // One CPU: the all-threads figure is the one-thread figure.
      Measurement all = r.measurements.back();
      all.key = fmt::format("{}triad_all", g.tag);
      all.param = g.all;
      all.note += " (only one CPU is available to this process)";
      r.measurements.push_back(all);
    }
  };
  measure(p, kMemory);
  if (ci.llc_bytes && *ci.llc_bytes >= (1 << 20)) {
    // Three arrays of an eighth of the cache each, so that they stay in it; many repetitions
    // of these short runs.
    const Plan in_cache{*ci.llc_bytes / 8, o.effort == Effort::full ? 200 : o.effort == Effort::quick ? 50 : 5, 2};
    measure(in_cache, kCache);
  }
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_cpu_memory) {
  registry.add({"cpu-memory",
                "host memory bandwidth: STREAM copy and triad, one thread and all threads", false,
                10, dtflop::probes::run});
}
