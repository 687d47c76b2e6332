// B_GS: what cuda-resident's tile fills cost, device memory (an L2-resident grid) -> shared memory,
// on every multiprocessor. The kernel fills tiles of cuda-resident's fused kernel (its default
// layout, a 33 x 33 kernel: 72 columns, halo rows shared with the next tile) as cuda-resident does
// (the tensor memory accelerator where there is one, else 16-byte cp.async pieces), with three
// blocks on a multiprocessor as there, and sums every tile (checked). B_GS is the slope of a fit
// t = L + bytes / B_GS over tile heights 48..224 rows, the bytes being every tile every block
// filled: the rate at which the multiprocessors fill tiles; L takes the launch and the fixed costs
// of the rounds, which other terms price. The model counts one tile per multiprocessor per round
// of the blocks it runs at once (N_GS, backend_counts.hpp): in the workload the other blocks of a
// round fill while one computes, so one fill a round is what a step waits for. (The same fit on
// the bytes as N_GS counts them, a third of these here, is reported beside it: the rate if no
// fill hid under another block's work.)
#include <exception>

#include <fmt/format.h>

#include "probes/fit.hpp"
#include "probes/gpu.hpp"
#include "probes/measure.hpp"
#include "probes/probe.hpp"
#include "probes/tile_fill.hpp"

namespace dtflop::probes {
namespace {

struct Plan {
  int rounds, batch, reps;
};

Plan plan(Effort e) {
  switch (e) {
    // smoke: the quick rounds, fewer repetitions (with 2 rounds and batches of 2 the times of
    // the heights were all launch cost, and on an H200 did not grow with the height)
    case Effort::smoke: return {8, 4, 3};
    case Effort::quick: return {8, 10, 5};
    case Effort::full: return {8, 20, 11};
  }
  return {8, 10, 5};
}

// The figures of one way of filling: each height's rate (details), the fit, the rate of the bytes
// really filled at the tallest tile. `param` is set on the fit's figure when given.
void report(const gpu::FillTiming& t, const char* key, const char* how, std::optional<Param> param,
            ProbeReport& r, const ProbeOptions& o) {
  std::vector<TransferPoint> points, counted;
  for (const auto& p : t.points) {
    Measurement m = rate_measurement(
        fmt::format("{}_rows{}", key, p.rows),
        fmt::format("tile fills by {}, {} x {} tiles, every byte filled", how, p.rows, tiles::kCols), "B/s",
        static_cast<double>(p.filled_bytes), p.seconds, std::nullopt,
        fmt::format("{} blocks of {} threads, {} at once per multiprocessor; events around a batch of launches, "
                    "median of {}",
                    t.blocks, tiles::kThreads, t.occ, p.seconds.size()));
    m.detail = true;
    points.push_back({static_cast<double>(p.filled_bytes), m.stats.median});
    counted.push_back({static_cast<double>(p.counted_bytes), m.stats.median});
    r.measurements.push_back(m);
  }
  const LatencyBandwidthFit f = fit_latency_bandwidth(points);
  const LatencyBandwidthFit fc = fit_latency_bandwidth(counted);
  Measurement b;
  b.key = key;
  b.label = fmt::format("shared-memory tile fills by {}, all multiprocessors (fit)", how);
  b.unit = "B/s";
  b.value = f.bandwidth;
  b.uncertainty = f.bandwidth_hw95;
  b.stats = summarize(t.points.back().seconds);
  b.param = param;
  b.note = fmt::format(
      "fit t = L + bytes/B over {} tile heights {}..{} rows, {} blocks a launch, {} at once per multiprocessor "
      "(bytes: every tile filled), rms residual {:.1f}%; L {:.2f} us",
      f.points, t.points.front().rows, t.points.back().rows, t.blocks, t.occ, 100 * f.rms_rel_residual,
      f.latency * 1e6);
  r.measurements.push_back(b);
  Measurement bc = b;
  bc.key = fmt::format("{}_counted", key);
  bc.label = fmt::format("tile fills by {}, bytes as N_GS counts them (one tile per multiprocessor a round; fit)", how);
  bc.value = fc.bandwidth;
  bc.uncertainty = fc.bandwidth_hw95;
  bc.param = std::nullopt;
  bc.note = fmt::format("the same times over one tile per multiprocessor per round of {} blocks: the rate if no "
                        "fill hid under another block's work; rms residual {:.1f}%",
                        t.occ, 100 * fc.rms_rel_residual);
  r.measurements.push_back(bc);
  const auto& tall = t.points.back();
  Measurement all = rate_measurement(fmt::format("{}_filled", key),
                                     fmt::format("tile fills by {}, every byte filled, {}-row tiles", how, tall.rows),
                                     "B/s", static_cast<double>(tall.filled_bytes), tall.seconds, std::nullopt,
                                     "all the blocks' tiles over the launch's time (launch and reductions included)");
  r.measurements.push_back(all);
  o.say(fmt::format("  tile fills by {}: {:.2f} TB/s (fit over every byte filled), {:.2f} TB/s as N_GS counts", how,
                    b.value / 1e12, bc.value / 1e12));
}

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  const Plan p = plan(o.effort);
  // cuda-resident fills by the accelerator where it can (workloads/rbe/cuda_resident.cu): that
  // way gives B_GS, the other is reported beside it.
  const bool tma = gpu::tma_available();
  report(gpu::time_tile_fills(false, p.rounds, p.batch, p.reps), "fill_cp_async", "cp.async",
         tma ? std::nullopt : std::optional<Param>(Param::B_GS), r, o);
  if (tma)
    report(gpu::time_tile_fills(true, p.rounds, p.batch, p.reps), "fill_tma", "the tensor memory accelerator",
           Param::B_GS, r, o);
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_gpu_tiles) {
  registry.add({"gpu-tiles",
                "shared-memory tile fills of cuda-resident's tiles with their halos, all multiprocessors (B_GS)", true,
                56, dtflop::probes::run});
}
