// Kernel launch overhead: back-to-back launches of an empty kernel (events around a batch,
// L_launch: what the host's launches cost where the host keeps the device waiting), a single
// launch + synchronize round trip (host clock, L_wait), the empty kernels of a CUDA graph (events
// around the graph's launch: reported, a floor of the fitted L_graph); and the fixed cost of one
// round of thread blocks (L_wave, gpu::time_waves: kernels of a graph, so that the host's launch
// interval does not hide it).
#include <exception>

#include <fmt/format.h>

#include "probes/gpu.hpp"
#include "probes/measure.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes {
namespace {

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  const int batch = o.effort == Effort::full ? 2000 : o.effort == Effort::quick ? 1000 : 100;
  const int reps = o.effort == Effort::full ? 15 : o.effort == Effort::quick ? 7 : 3;
  const auto t = gpu::time_launches(batch, reps);
  r.measurements.push_back(time_measurement(
      "launch", "empty kernel, back-to-back launches", t.per_launch, Param::L_launch,
      fmt::format("events around {} launches of an empty kernel on one stream, per launch, "
                  "median of {}",
                  batch, reps)));
  r.measurements.push_back(time_measurement(
      "launch_sync", "empty kernel, launch + cudaStreamSynchronize", t.round_trip, Param::L_wait,
      fmt::format("host clock around one launch and its synchronize, median of {}", t.round_trip.size())));
  o.say(fmt::format("  launch: {:.2f} us back to back, {:.2f} us with synchronize",
                    r.measurements[0].value * 1e6, r.measurements[1].value * 1e6));
  // L_graph is fitted, not probed: a workload's graph kernels cost more than empty ones (cuda-resident's
  // 2.0 us on the H100 and on the H200, against 0.98 and 0.68 us here), and alike on both, where
  // a factor relative to this figure would carry the difference from one to the other. Reported.
  const auto g = gpu::time_graph_launches(batch, reps);
  Measurement gm = time_measurement(
      "graph_launch", "empty kernel, one of a CUDA graph's", g, std::nullopt,
      fmt::format("events around the launch of a CUDA graph of {} empty kernels on one stream, per kernel, median of "
                  "{}; a floor for L_graph, which calibrate fits",
                  batch, reps));
  gm.detail = true;
  r.measurements.push_back(gm);
  o.say(fmt::format("  graph: {:.2f} us a kernel", r.measurements.back().value * 1e6));
  gpu::WaveTiming w;
  try {
    w = gpu::time_waves(o.effort == Effort::smoke ? 5 : 50, reps);
  } catch (const std::exception& e) {  // L_launch and L_wait stand; only L_wave is missing
    o.say(fmt::format("  rounds of thread blocks: not measured ({})", e.what()));
    return r;
  }
  Measurement m;
  m.key = "wave";
  m.label = "one round of thread blocks (one block per SM)";
  m.unit = "s";
  m.value = w.per_wave;
  m.param = Param::L_wave;
  std::string points;
  for (std::size_t i = 0; i < w.waves.size(); ++i)
    points += fmt::format("{}{} rounds {:.2f} us", i ? ", " : "", w.waves[i], w.seconds[i] * 1e6);
  m.note = fmt::format("slope of kernel time (kernels of a CUDA graph) against rounds of blocks that each fill a multiprocessor ({} per "
                       "SM), a shared-memory fill and a barrier per block: {}",
                       w.blocks_per_sm, points);
  if (!(m.value > 0)) {  // noise larger than the effect: report it, fill no parameter
    m.param.reset();
    m.note += "; the slope is not positive, so L_wave is left unmeasured";
  }
  r.measurements.push_back(m);
  o.say(fmt::format("  one round of thread blocks: {:.2f} us", m.value * 1e6));
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_gpu_launch) {
  registry.add({"gpu-launch", "kernel launch overhead (empty kernel from the host, L_launch; in a CUDA graph, reported) and the fixed cost of a round of blocks", true, 60,
                dtflop::probes::run});
}
