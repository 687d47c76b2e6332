// CPU thread synchronization: what it costs all the hardware threads to start a parallel
// region together and to wait for each other (L_sync). Measured with OpenMP, the runtime the
// CPU backends use, back to back as they use it: each repetition runs a batch of parallel
// regions that each hold one barrier, i.e. two syncs per region (the region's fork/join and the
// barrier), and L_sync is the batch time over twice the number of regions.
#include <omp.h>

#include <algorithm>
#include <vector>

#include <fmt/format.h>

#include "probes/measure.hpp"
#include "probes/probe.hpp"
#include "probes/team.hpp"

namespace dtflop::probes {
namespace {

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  const int threads = usable_cpus();
  if (threads < 2) {
    r.skipped = "one usable CPU: threads never wait for each other, so L_sync does not apply";
    return r;
  }
  const int batch = o.effort == Effort::full ? 20000 : o.effort == Effort::quick ? 5000 : 200;
  const int reps = o.effort == Effort::full ? 15 : o.effort == Effort::quick ? 7 : 3;
  // Every thread of every region checks in, and the regions' team sizes are summed: the regions
  // really ran, and on as many threads as asked (OMP_DYNAMIC or OMP_THREAD_LIMIT may grant fewer).
  long entered = 0, team = 0;
  auto regions = [&](int n) {
    for (int i = 0; i < n; ++i) {
#pragma omp parallel num_threads(threads) reduction(+ : entered)
      {
        entered += 1;
#pragma omp barrier
#pragma omp single nowait  // no second barrier: two syncs per region, as counted
        team += omp_get_num_threads();
      }
    }
  };
  regions(batch / 10 + 1);  // start the thread pool and let it spin
  entered = 0;
  team = 0;
  std::vector<double> per_sync;
  for (int k = 0; k < reps; ++k) {
    const double t0 = omp_get_wtime();
    regions(batch);
    per_sync.push_back((omp_get_wtime() - t0) / (2.0 * batch));
  }
  if (entered != team)
    throw ValidationError(fmt::format("{} regions' threads should have checked in {} times, got {}", batch * reps,
                                      team, entered));
  if (team != static_cast<long>(threads) * batch * reps)
    throw ValidationError(fmt::format("OpenMP gave the regions {:.2f} threads on average, not {} (OMP_DYNAMIC or "
                                      "OMP_THREAD_LIMIT?): L_sync would not be that of {} threads",
                                      static_cast<double>(team) / (batch * reps), threads, threads));
  r.measurements.push_back(time_measurement(
      "sync", fmt::format("{} threads, fork/join or barrier", threads), per_sync, Param::L_sync,
      fmt::format("OpenMP: {} back-to-back parallel regions holding one barrier each, on {} threads; "
                  "batch time / (2 x regions), median of {}",
                  batch, threads, reps)));
  o.say(fmt::format("  CPU thread sync, {} threads: {:.2f} us", threads, r.measurements[0].value * 1e6));
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_cpu_sync) {
  registry.add({"cpu-sync", "CPU thread fork/join and barrier cost (OpenMP, all threads)", false, 25,
                dtflop::probes::run});
}
