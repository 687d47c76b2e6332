// First the cache a process really gets: read bandwidth on one thread over a ladder of working
// sets from above the core's own caches to several times the size the system reports, and the
// knee where it falls from the cache's plateau to the memory's (probes/cache_ladder.hpp): the
// effective last-level cache, which the profile's identity carries beside the system's figure.
// Then host memory bandwidth: STREAM copy and triad over arrays several times the last-level
// cache, one thread and all threads (each thread streams its own slice, first touched by
// itself). Bytes counted are those read plus written (write-allocate traffic not counted,
// as in STREAM). B_host_1 / B_host are the triad figures. Then the triad over arrays that fit
// the measured cache together (an eighth of it each): B_llc_1 / B_llc, the bandwidth CPU work
// sees while its working set stays in the cache.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#if defined(__unix__) || defined(__APPLE__)
#include <time.h>
#include <unistd.h>
#endif

#include <fmt/format.h>

#include "probes/cache_ladder.hpp"
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

// ---- The cache ladder ----------------------------------------------------------------------

// CPU time of the calling thread, so that a repetition the scheduler interrupts (another
// process on a shared machine) is not counted as slow memory: the knee is about capacity, and a
// working set's lines that another tenant evicted meanwhile still cost their misses. Wall time
// where the system has no thread clock.
double thread_seconds() {
#if defined(CLOCK_THREAD_CPUTIME_ID)
  timespec ts{};
  if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts) == 0)
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
#endif
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// Sum of b_value(i) over [0, m): whole periods of 1024 plus the start of one.
double b_prefix_sum(std::size_t m) {
  const std::size_t whole = m / 1024, rest = m % 1024;
  return static_cast<double>(whole) * (1023.0 * 1024.0 / 2.0) + static_cast<double>(rest) * (static_cast<double>(rest) - 1.0) / 2.0;
}

struct LadderPlan {
  std::int64_t first, last;
  int steps_per_octave;
  int reps;
  std::int64_t min_bytes_per_rep;  // a repetition reads the working set this often at least
};

LadderPlan ladder_plan(Effort e, const CpuInfo& ci, std::optional<std::int64_t> memory) {
  const std::int64_t mib = 1 << 20;
  // From twice the core's own caches (their data would read faster than the shared cache's) ...
  const std::int64_t first = std::max<std::int64_t>(2 * mib, 2 * ci.private_cache_bytes.value_or(2 * mib));
  // ... to several times what the system reports (2x quick, 4x full; 128 MiB at least), within an
  // eighth of the memory.
  const std::int64_t llc = ci.llc_bytes.value_or(32 * mib);
  std::int64_t last = std::max<std::int64_t>(128 * mib, (e == Effort::full ? 4 : 2) * llc);
  last = std::min<std::int64_t>(last, 4096 * mib);
  if (memory) last = std::min(last, *memory / 8);
  switch (e) {
    case Effort::smoke: return {first, std::max(first, std::min<std::int64_t>(last, 4 * first)), 1, 3, 8 * mib};
    case Effort::quick: return {first, std::max(first, last), 2, 5, 64 * mib};
    case Effort::full: return {first, std::max(first, last), 4, 5, 64 * mib};
  }
  return {first, std::max(first, last), 2, 5, 64 * mib};
}

struct Ladder {
  std::vector<Measurement> points;  // one per size (detail)
  std::optional<Measurement> knee;  // llc_effective (found) or llc_no_knee (the system's figure stands)
  std::string ladder_text;          // "bytes:B/s ..." (every size's median) for the profile's metadata
};

Ladder cache_ladder(const LadderPlan& p, cpu::Isa isa, const CpuInfo& ci, const ProbeOptions& o) {
  const std::vector<std::int64_t> sizes = ladder_sizes(p.first, p.last, p.steps_per_octave);
  const std::size_t n = static_cast<std::size_t>(sizes.back()) / sizeof(double);
  std::unique_ptr<double[]> b(new double[n]);
  for (std::size_t i = 0; i < n; ++i) b[i] = b_value(i);
  Ladder out;
  std::vector<LadderPoint> pts;
  double worst_spread = 0;
  for (const std::int64_t bytes : sizes) {
    const std::size_t m = static_cast<std::size_t>(bytes) / sizeof(double);
    const int passes = static_cast<int>(std::max<std::int64_t>(1, (p.min_bytes_per_rep + bytes - 1) / bytes));
    const double expect = b_prefix_sum(m);
    double got = cpu::stream_sum(isa, b.get(), m);  // warm-up: brings what fits into the caches
    std::vector<double> t;
    for (int r = 0; r < p.reps; ++r) {
      const double t0 = thread_seconds();
      for (int k = 0; k < passes; ++k) {
        got = cpu::stream_sum(isa, b.get(), m);
        if (got != expect)
          throw ValidationError(fmt::format("cache ladder, {}: the sum of the working set is {}, expected {}",
                                            size_label(bytes), got, expect));
      }
      t.push_back(thread_seconds() - t0);
    }
    Measurement pt = rate_measurement(
        fmt::format("llc_read_{}", size_key(bytes)),
        fmt::format("read, 1 thread, {:.1f} MiB working set", static_cast<double>(bytes) / (1 << 20)), "B/s",
        static_cast<double>(bytes) * passes, t, std::nullopt,
        fmt::format("sum of {:.1f} MiB, {} pass(es) a repetition, {} kernels, thread CPU time, median of {}",
                    static_cast<double>(bytes) / (1 << 20), passes, cpu::to_string(isa), p.reps));
    pt.detail = true;
    worst_spread = std::max(worst_spread, pt.stats.spread());
    pts.push_back({bytes, pt.value});
    out.ladder_text += fmt::format("{}{}:{:.4g}", out.ladder_text.empty() ? "" : " ", bytes, pt.value);
    out.points.push_back(std::move(pt));
  }
  const CacheKnee k = find_cache_knee(pts);
  auto index_of = [&pts](std::int64_t bytes) {
    std::size_t i = 0;
    while (i + 1 < pts.size() && pts[i].bytes != bytes) ++i;
    return i;
  };
  auto gb = [](double v) { return v / 1e9; };
  auto mb = [](std::int64_t v) { return static_cast<double>(v) / (1 << 20); };
  const std::string ladder = fmt::format("read ladder of {} sizes, {:.1f}..{:.1f} MiB, one thread; largest spread of a size {:.1f}%",
                                         sizes.size(), mb(sizes.front()), mb(sizes.back()), 100 * worst_spread);
  Measurement km;
  km.unit = "B";
  if (k.bytes) {
    km.key = "llc_effective";
    km.label = "last-level cache this process gets (knee of the read ladder)";
    km.value = static_cast<double>(*k.bytes);
    km.note = fmt::format(
        "{}: cache plateau {:.3g} GB/s, memory plateau {:.3g} GB/s, threshold (their geometric mean) {:.3g} GB/s, "
        "crossed at {:.1f} MiB between the ladder's {:.1f} MiB ({:.3g} GB/s) and {:.1f} MiB ({:.3g} GB/s); the system reports {}",
        ladder, gb(k.cache_plateau), gb(k.memory_plateau), gb(k.threshold), mb(*k.bytes), mb(k.above),
        gb(pts[index_of(k.above)].bandwidth), mb(k.below), gb(pts[index_of(k.below)].bandwidth),
        ci.llc_bytes ? fmt::format("{:.1f} MiB", mb(*ci.llc_bytes)) : std::string("no size"));
    o.say(fmt::format("  cache ladder: {:.1f} MiB effective last-level cache (read {:.3g} GB/s -> {:.3g} GB/s; the system reports {})",
                      mb(*k.bytes), gb(k.cache_plateau), gb(k.memory_plateau),
                      ci.llc_bytes ? fmt::format("{:.1f} MiB", mb(*ci.llc_bytes)) : std::string("no size")));
  } else {
    km.key = "llc_no_knee";
    km.label = "last-level cache: no knee in the read ladder, the system's figure stands";
    km.value = static_cast<double>(ci.llc_bytes.value_or(0));
    km.note = fmt::format("{}: no knee ({}); the model uses the system's figure ({})", ladder, k.why,
                          ci.llc_bytes ? fmt::format("{:.1f} MiB", mb(*ci.llc_bytes)) : std::string("none: no cache term"));
    o.say(fmt::format("  cache ladder: no knee ({}); the system's figure stands", k.why));
  }
  out.knee = std::move(km);
  return out;
}

Measurement* find_param(ProbeReport& r, Param p) {
  for (auto& m : r.measurements)
    if (m.param == p) return &m;
  return nullptr;
}

// The cache is never slower than memory: an in-cache triad below the memory one was timed while
// something else held the cache or the cores (once in six quick probes of a lent H100's host, the
// first after the machine started: 53 GB/s on 16 threads against 87 GB/s from memory, where the
// others read 139-205 GB/s). Such a figure is measured again, twice at most, and the fastest
// attempt kept; one still below memory says so in its note.
void recheck_cache(ProbeReport& r, const Plan& in_cache, cpu::Isa isa, const ProbeOptions& o, int cpus) {
  for (const bool all : {false, true}) {
    if (all && cpus <= 1) continue;  // the all-thread figure is the one-thread figure
    Measurement* llc = find_param(r, all ? kCache.all : kCache.one);
    const Measurement* mem = find_param(r, all ? kMemory.all : kMemory.one);
    if (!llc || !mem) continue;
    for (int attempt = 0; attempt < 2 && llc->value < mem->value; ++attempt) {
      o.say(fmt::format("  last-level cache, {}: triad {:.1f} GB/s, below the memory's {:.1f} GB/s; measuring again",
                        all ? "all threads" : "1 thread", llc->value / 1e9, mem->value / 1e9));
      const auto again = stream(all ? cpus : 1, in_cache, isa, o, kCache);
      if (again[1].value <= llc->value) continue;
      for (const Measurement& m : again)
        for (auto& old : r.measurements)
          if (old.key == m.key) old = m;
      llc = find_param(r, all ? kCache.all : kCache.one);
    }
    if (llc->value < mem->value)
      llc->note += fmt::format(" (below the memory's {:.3g} GB/s after three attempts: something else held the cache "
                               "or the cores; probe again on a quiet machine)",
                               mem->value / 1e9);
  }
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
  // The ladder first, on pages no other part of the probe used (see docs/probe.md).
  const Ladder ladder = cache_ladder(ladder_plan(o.effort, ci, physical_memory()), isa, ci, o);
  measure(p, kMemory);
  r.measurements.insert(r.measurements.end(), ladder.points.begin(), ladder.points.end());
  // (No knee and no system figure: nothing to show but the metadata's note.)
  if (ladder.knee->value >= 1) r.measurements.push_back(*ladder.knee);
  r.metadata["cpu_llc_ladder"] = ladder.ladder_text;
  r.metadata["cpu_llc_effective"] = (ladder.knee->key == "llc_effective" ? "" : "none: ") + ladder.knee->note;
  // The cache the model prices working sets against: the knee, else the system's figure.
  std::optional<std::int64_t> cache = ci.llc_bytes;
  if (ladder.knee->key == "llc_effective") cache = static_cast<std::int64_t>(ladder.knee->value);
  if (cache && *cache >= (1 << 20)) {
    // Three arrays of an eighth of the cache each, so that they stay in it; many repetitions
    // of these short runs.
    const Plan in_cache{*cache / 8, o.effort == Effort::full ? 200 : o.effort == Effort::quick ? 50 : 5, 2};
    measure(in_cache, kCache);
    recheck_cache(r, in_cache, isa, o, ci.threads);
  }
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_cpu_memory) {
  registry.add({"cpu-memory",
                "host memory bandwidth (STREAM copy and triad, one thread and all threads) and the last-level cache a process gets", false,
                10, dtflop::probes::run});
}
