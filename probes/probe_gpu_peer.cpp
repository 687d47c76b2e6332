// Messages between GPUs (L_peer, B_peer, L_allreduce, B_allreduce): NCCL point-to-point
// messages between GPUs 0 and 1 (half a round trip 0 -> 1 -> 0) and all-reduces over both, over
// sizes from 4 B to 64 MiB, each series fitted to t = L + bytes / B (docs/model.md 2.9; the
// terms dt_peer and dt_allreduce that cuda-bands' counts are priced by). Where this process sees
// fewer than two GPUs, or dtflop was built without NCCL, it says so and measures nothing.
#include <vector>

#include <fmt/format.h>

#include "probes/fit.hpp"
#include "probes/gpu_peer.hpp"
#include "probes/measure.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes {
namespace {

struct Series {
  const char* key;
  const char* label;
  Param latency, bandwidth;
  std::vector<double> gpu::PeerTimes::*times;
  const char* how;
};
const Series kSeries[] = {
    {"send", "GPU 0 <-> 1 message (NCCL send/recv, one way)", Param::L_peer, Param::B_peer, &gpu::PeerTimes::send,
     "half a round trip 0 -> 1 -> 0"},
    {"allreduce", "all-reduce over GPUs 0 and 1 (NCCL, bytes per GPU)", Param::L_allreduce, Param::B_allreduce,
     &gpu::PeerTimes::allreduce, "one float sum over both GPUs"},
};

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  r.probe = "gpu-peer";
#ifndef DTFLOP_HAVE_NCCL
  r.skipped = "dtflop was built without NCCL (not found, or DTFLOP_WITH_NCCL=OFF): no messages between GPUs to time";
  (void)o;
  return r;
#else
  if (const std::string why = gpu::peer_unavailable_reason(); !why.empty()) {
    r.skipped = why;
    return r;
  }
  // full: every power of two from 4 B to 64 MiB; quick: every power of four; smoke: 4 B .. 64 KiB.
  const std::int64_t top = o.effort == Effort::smoke ? 64 << 10 : 64 << 20;
  const int step = o.effort == Effort::full ? 2 : 4;
  std::vector<std::int64_t> sizes;
  std::vector<int> reps, batch;
  for (std::int64_t s = 4; s <= top; s *= step) {
    sizes.push_back(s);
    reps.push_back(o.effort == Effort::full ? 15 : o.effort == Effort::quick ? 7 : 3);
    batch.push_back(s <= (1 << 20) ? 20 : 4);
  }
  o.say(fmt::format("  NCCL between GPUs 0 and 1: {} sizes, {} .. {}", sizes.size(), size_label(sizes.front()),
                    size_label(sizes.back())));
  const auto times = gpu::time_peer(sizes, reps, batch, o.effort == Effort::smoke ? 1 : 3);
  for (const Series& s : kSeries) {
    std::vector<TransferPoint> points;
    std::vector<Measurement> per_size;
    for (const auto& t : times) {
      per_size.push_back(rate_measurement(fmt::format("{}_{}", s.key, size_key(t.bytes)),
                                          fmt::format("{}, {}", s.label, size_label(t.bytes)), "B/s",
                                          static_cast<double>(t.bytes), t.*s.times, std::nullopt,
                                          fmt::format("{}, events on GPU 0, median of {}", s.how, (t.*s.times).size())));
      per_size.back().detail = true;
      points.push_back({static_cast<double>(t.bytes), per_size.back().stats.median});
    }
    const LatencyBandwidthFit f = fit_latency_bandwidth(points);
    const std::string note = fmt::format(
        "fit t = L + bytes/B over {} sizes {}..{} (relative least squares), rms residual {:.1f}%, max {:.1f}%",
        f.points, size_label(sizes.front()), size_label(sizes.back()), 100 * f.rms_rel_residual,
        100 * f.max_rel_residual);
    Measurement b;
    b.key = fmt::format("{}_bandwidth", s.key);
    b.label = fmt::format("{}, bandwidth (fit)", s.label);
    b.unit = "B/s";
    b.value = f.bandwidth;
    b.uncertainty = f.bandwidth_hw95;
    b.stats = per_size.back().stats;
    b.param = s.bandwidth;
    b.note = note;
    r.measurements.push_back(b);
    if (!f.latency_clamped && f.latency > 0) {
      Measurement l;
      l.key = fmt::format("{}_latency", s.key);
      l.label = fmt::format("{}, latency (fit)", s.label);
      l.unit = "s";
      l.value = f.latency;
      l.uncertainty = f.latency_hw95;
      l.stats = per_size.front().stats;
      l.param = s.latency;
      l.note = note;
      r.measurements.push_back(l);
    } else {
      o.say(fmt::format("  {}: the fit put the latency below zero; {} is left out", s.label, info(s.latency).name));
    }
    o.say(fmt::format("  {}: {:.2f} us + bytes / {:.1f} GB/s", s.label, f.latency * 1e6, f.bandwidth / 1e9));
    for (auto& m : per_size) r.measurements.push_back(std::move(m));
  }
  return r;
#endif
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_gpu_peer) {
  registry.add({"gpu-peer",
                "messages between GPUs 0 and 1: NCCL send/recv and all-reduce latency and bandwidth (needs two GPUs)",
                true, 45, dtflop::probes::run});
}
