// L_atomic: what one of a series of atomic updates of one device address costs (they serialize
// at the memory partition that holds it). The kernel is cuda-resident's end of a block: 256
// threads reduce their values and one adds the block's float64 sum to one word with atomicAdd;
// launched with 4..64 blocks per multiprocessor, L_atomic is the slope of a fit t = L + blocks x
// L_atomic. The same kernel storing each block's sum to its own word instead is timed beside it:
// its slope is what a block costs without the atomic. Every sum is checked.
#include <fmt/format.h>

#include "probes/fit.hpp"
#include "probes/gpu.hpp"
#include "probes/measure.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes {
namespace {

struct Plan {
  std::vector<int> blocks_per_sm;
  int batch, reps;
};

Plan plan(Effort e) {
  switch (e) {
    // smoke: quick's block counts, fewer repetitions (at 2..8 blocks per multiprocessor in batches
    // of 2 the stores' times did not grow with the blocks on an H100 and an H200: the fit failed)
    case Effort::smoke: return {{4, 8, 16, 32, 64}, 4, 3};
    case Effort::quick: return {{4, 8, 16, 32, 64}, 10, 5};
    case Effort::full: return {{4, 8, 16, 32, 64}, 20, 11};
  }
  return {{4, 8, 16, 32, 64}, 10, 5};
}

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  const Plan p = plan(o.effort);
  const gpu::AtomicTiming t = gpu::time_atomics(p.blocks_per_sm, p.batch, p.reps);
  std::vector<TransferPoint> with, without;
  for (std::size_t i = 0; i < t.blocks.size(); ++i) {
    Measurement m = time_measurement(
        fmt::format("atomic_blocks{}", t.blocks[i]), fmt::format("{} blocks, each adding to one address", t.blocks[i]),
        t.atomic[i], std::nullopt, fmt::format("events around a batch of {} launches, median of {}", p.batch, p.reps));
    m.detail = true;
    with.push_back({static_cast<double>(t.blocks[i]), m.stats.median});
    r.measurements.push_back(m);
    Measurement c = time_measurement(
        fmt::format("store_blocks{}", t.blocks[i]), fmt::format("{} blocks, each storing its own word", t.blocks[i]),
        t.stored[i], std::nullopt, fmt::format("events around a batch of {} launches, median of {}", p.batch, p.reps));
    c.detail = true;
    without.push_back({static_cast<double>(t.blocks[i]), c.stats.median});
    r.measurements.push_back(c);
  }
  const PerEventFit a = fit_per_event(with);
  const PerEventFit s = fit_per_event(without);
  Measurement m = per_event_measurement(
      "atomic", "one of a series of atomic adds (float64) to one device address", a, t.atomic.back(), Param::L_atomic,
      fmt::format("slope of a fit t = L + blocks x L_atomic over {}..{} blocks of 256 threads, each reducing and adding "
                  "its sum to one address (rms residual {:.1f}%); the same blocks storing instead: {:.3g} ns a block",
                  t.blocks.front(), t.blocks.back(), 100 * a.rms_rel_residual, s.per_event * 1e9));
  if (!(s.per_event < a.per_event))
    m.note += "; the atomics cost no more than the stores, so they hide behind the blocks' issue and L_atomic is "
              "at most this";
  r.measurements.push_back(m);
  const Measurement c = per_event_measurement("store_block", "a block of the same kernel storing its sum instead (no atomic)",
                                              s, t.stored.back(), std::nullopt,
                                              "slope of a fit t = L + blocks x c over the same block counts");
  r.measurements.push_back(c);
  o.say(fmt::format("  atomics to one address: {:.2f} ns each ({:.2f} ns a block without)", m.value * 1e9,
                    c.value * 1e9));
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_gpu_atomics) {
  registry.add({"gpu-atomics", "serialized atomic adds of thread blocks to one device address (L_atomic)", true, 57,
                dtflop::probes::run});
}
