// One thread's latency-bound work timed on several placements.
//
// Host work that waits on itself (a k-d tree's dependent loads, pixel-by-pixel branches, chains
// of square roots and divisions) runs at a speed that depends on where and when its thread runs.
// On the lent GPU machine's 16-vCPU host, at any moment two to four vCPUs ran such code 20-25%
// faster than the rest, and which ones changed from minute to minute (docs/probe.md, "Placements").
// One thread timed where the scheduler happened to put it is one draw of that: a quick probe
// landed in the fast group one time in five and priced the DCT CPU backends 28-36% too fast.
//
// So the one-thread latency probes (cpu-tree, cpu-pixel, cpu-mls) time their work on a thread
// bound to each of several CPUs in turn: the figure is the median over the placements, and the
// spread of the placements' figures is the parameter's spread, which the prediction intervals
// carry (model/uncertainty.hpp).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "probes/probe.hpp"

namespace dtflop::probes {

// How many placements a one-thread latency probe takes: 16 (full), 8 (quick), 2 (smoke). Eight
// put the median in the common group while up to three of them land in a faster one.
int latency_placements(Effort e);

// The CPUs `count` placements are bound to: spread evenly over the CPUs this process may run on
// (its affinity mask), in order, cycling where there are fewer CPUs than placements. -1 entries
// (every one) where this system cannot bind a thread: those placements run where the scheduler
// puts them. Throws std::invalid_argument for count < 1.
std::vector<int> placement_cpus(int count);

// Runs fn on a new thread bound to `cpu` (unbound for cpu < 0) and waits for it; an exception
// fn throws is rethrown here. Returns whether the thread was bound. Binding a thread to a CPU of
// the process's own mask does not fail on Linux; if it does (the mask changed under the
// process), fn runs unbound rather than not at all.
bool run_on_cpu(int cpu, const std::function<void()>& fn);

// The results of one measurement taken on several placements.
struct Placed {
  std::vector<int> cpus;       // where each ran (-1: unbound, or binding failed)
  std::vector<double> values;  // fn's result on each, in the same order
};

// fn() once on each of `count` placements (placement_cpus(count)), one after another.
Placed on_placements(int count, const std::function<double()>& fn);

// One placement of a one-thread step probe: pass(true) once untimed (a warm-up, where the probe
// checks its result), then pass(false) `reps` times, each timed; the median time over `steps`.
double median_seconds_per_step(int reps, std::int64_t steps, const std::function<void(bool warm_up)>& pass);
// The same with before() run, untimed, ahead of every pass (the warm-up's too).
double median_seconds_per_step(int reps, std::int64_t steps, const std::function<void(bool warm_up)>& pass,
                               const std::function<void()>& before);

// Writes back and drops the lines of [p, p + bytes) from every level of this CPU's caches, as data a
// device has just copied into host memory is not in them. False where the architecture gives no
// way to (then nothing is done): x86-64 (clflush) and AArch64 (dc civac) do.
bool evict_from_caches(const void* p, std::size_t bytes);

// A one-thread step probe's measurement from its placements (each the median of `reps` passes):
// the median over them, whose spread is the parameter's; its note `what` was timed, then how; and
// the progress line "  <say>: X ns (placements A .. B ns)".
Measurement step_measurement(const ProbeOptions& o, const Placed& placed, int reps, std::string key, std::string label,
                             Param p, const std::string& what, const std::string& say);

// "8 placements (one thread bound to CPUs 0, 2, 4, 6, 8, 10, 12, 14 in turn)", for notes.
std::string describe_placements(const std::vector<int>& cpus);

}  // namespace dtflop::probes
