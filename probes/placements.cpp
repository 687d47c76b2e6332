#include "probes/placements.hpp"

#include <chrono>
#include <cstddef>
#include <exception>
#include <stdexcept>
#include <thread>

#include <fmt/format.h>
#include <fmt/ranges.h>

#if defined(__x86_64__)
#include <immintrin.h>
#endif
#if defined(__linux__)
#include <pthread.h>
#include <sched.h>
#endif

#include "model/stats.hpp"
#include "probes/measure.hpp"

namespace dtflop::probes {

namespace {
// The CPUs of this process's affinity mask, ascending; empty where it cannot be read.
std::vector<int> allowed_cpus() {
  std::vector<int> cpus;
#if defined(__linux__)
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) == 0)
    for (int c = 0; c < CPU_SETSIZE; ++c)
      if (CPU_ISSET(c, &set)) cpus.push_back(c);
#endif
  return cpus;
}
}  // namespace

int latency_placements(Effort e) { return e == Effort::full ? 16 : e == Effort::quick ? 8 : 2; }

std::vector<int> placement_cpus(int count) {
  if (count < 1) throw std::invalid_argument(fmt::format("placements: {} asked for, at least 1 needed", count));
  const std::vector<int> cpus = allowed_cpus();
  std::vector<int> out(static_cast<std::size_t>(count), -1);
  if (cpus.empty()) return out;
  const auto n = static_cast<long long>(cpus.size());
  for (int i = 0; i < count; ++i) {
    // Fewer placements than CPUs: every (n / count)-th CPU; more: round and round.
    const long long k = count <= n ? i * n / count : i % n;
    out[static_cast<std::size_t>(i)] = cpus[static_cast<std::size_t>(k)];
  }
  return out;
}

bool run_on_cpu(int cpu, const std::function<void()>& fn) {
  std::exception_ptr error;
  bool bound = false;
  std::thread t([&] {
#if defined(__linux__)
    if (cpu >= 0 && cpu < CPU_SETSIZE) {
      cpu_set_t set;
      CPU_ZERO(&set);
      CPU_SET(cpu, &set);
      // A failure leaves the thread where it was: measured unbound, not lost (see the header).
      bound = pthread_setaffinity_np(pthread_self(), sizeof(set), &set) == 0;
    }
#endif
    try {
      fn();
    } catch (...) {
      error = std::current_exception();
    }
  });
  t.join();
  if (error) std::rethrow_exception(error);
  return bound;
}

double median_seconds_per_step(int reps, std::int64_t steps, const std::function<void(bool warm_up)>& pass) {
  return median_seconds_per_step(reps, steps, pass, [] {});
}

double median_seconds_per_step(int reps, std::int64_t steps, const std::function<void(bool warm_up)>& pass,
                               const std::function<void()>& before) {
  before();
  pass(true);
  std::vector<double> per_step;
  for (int k = 0; k < reps; ++k) {
    before();
    const auto t0 = std::chrono::steady_clock::now();
    pass(false);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    per_step.push_back(s / static_cast<double>(steps));
  }
  return summarize(per_step).median;
}

Measurement step_measurement(const ProbeOptions& o, const Placed& placed, int reps, std::string key, std::string label,
                             Param p, const std::string& what, const std::string& say) {
  Measurement m = time_measurement(std::move(key), std::move(label), placed.values, p,
                                   fmt::format("{}; time / steps, the median over {} of the median of {} each", what,
                                               describe_placements(placed.cpus), reps));
  o.say(fmt::format("  {}: {:.1f} ns (placements {:.1f} .. {:.1f} ns)", say, m.value * 1e9, m.stats.min * 1e9,
                    m.stats.max * 1e9));
  return m;
}

bool evict_from_caches(const void* p, std::size_t bytes) {
  constexpr std::size_t kLine = 64;  // the smallest line of either architecture: no line is missed
  const auto* c = static_cast<const char*>(p);
#if defined(__x86_64__)
  for (std::size_t i = 0; i < bytes; i += kLine) _mm_clflush(c + i);
  if (bytes > 0) _mm_clflush(c + bytes - 1);
  _mm_mfence();
  return true;
#elif defined(__aarch64__)
  for (std::size_t i = 0; i < bytes; i += kLine) asm volatile("dc civac, %0" : : "r"(c + i) : "memory");
  if (bytes > 0) asm volatile("dc civac, %0" : : "r"(c + bytes - 1) : "memory");
  asm volatile("dsb ish" : : : "memory");
  return true;
#else
  (void)c;
  (void)bytes;
  return false;
#endif
}

Placed on_placements(int count, const std::function<double()>& fn) {
  Placed p;
  p.cpus = placement_cpus(count);
  p.values.reserve(p.cpus.size());
  for (int& cpu : p.cpus)
    if (!run_on_cpu(cpu, [&] { p.values.push_back(fn()); })) cpu = -1;
  return p;
}

std::string describe_placements(const std::vector<int>& cpus) {
  bool bound = false;
  for (int c : cpus) bound = bound || c >= 0;
  if (!bound) return fmt::format("{} placements (one thread each, where the scheduler put it)", cpus.size());
  std::vector<std::string> where;
  for (int c : cpus) where.push_back(c >= 0 ? std::to_string(c) : "unbound");
  return fmt::format("{} placements (one thread bound to CPU{} {} in turn)", cpus.size(), cpus.size() > 1 ? "s" : "",
                     fmt::join(where, ", "));
}

}  // namespace dtflop::probes
