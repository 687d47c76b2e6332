// Host<->device transfers: cudaMemcpyAsync timed with events over a size sweep (4 KiB to
// 1 GiB), both directions, pinned and pageable host memory, fitted to t = L + bytes / B.
// Fills B_{CG,GC}_{pinned,pageable} and L_{CG,GC}_{pinned,pageable}.
#include <algorithm>
#include <optional>
#include <vector>

#include <fmt/format.h>

#include "probes/fit.hpp"
#include "probes/gpu.hpp"
#include "probes/measure.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes {
namespace {

struct Plan {
  std::vector<std::int64_t> sizes;
  std::vector<int> reps;
  int warmup;
};

Plan plan(Effort e) {
  const std::int64_t kib = 1024, mib = kib * kib, gib = mib * kib;
  Plan p;
  // full: every power of two; quick: every power of four; smoke: a few small sizes.
  const std::int64_t top = e == Effort::full ? gib : e == Effort::quick ? 256 * mib : 4 * mib;
  const int step = e == Effort::full ? 2 : 4;
  for (std::int64_t s = 4 * kib; s <= top; s *= step) p.sizes.push_back(s);
  for (auto s : p.sizes) {
    int r = 0;
    if (e == Effort::smoke) r = 3;
    else if (s <= mib) r = e == Effort::full ? 50 : 20;
    else if (s <= 64 * mib) r = e == Effort::full ? 15 : 7;
    else if (s <= 256 * mib) r = e == Effort::full ? 7 : 3;
    else r = 5;
    p.reps.push_back(r);
  }
  p.warmup = e == Effort::smoke ? 1 : 2;
  return p;
}

struct Series {
  gpu::Direction dir;
  HostMemory mem;
  const char* key;    // "h2d_pinned"
  const char* label;  // "host->device, pinned"
  Param bandwidth;
  Param latency;
};

const Series kSeries[] = {
    {gpu::Direction::host_to_device, HostMemory::pinned, "h2d_pinned", "host->device, pinned",
     Param::B_CG_pinned, Param::L_CG_pinned},
    {gpu::Direction::device_to_host, HostMemory::pinned, "d2h_pinned", "device->host, pinned",
     Param::B_GC_pinned, Param::L_GC_pinned},
    {gpu::Direction::host_to_device, HostMemory::pageable, "h2d_pageable",
     "host->device, pageable", Param::B_CG_pageable, Param::L_CG_pageable},
    {gpu::Direction::device_to_host, HostMemory::pageable, "d2h_pageable",
     "device->host, pageable", Param::B_GC_pageable, Param::L_GC_pageable},
};

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  const Plan p = plan(o.effort);
  constexpr std::int64_t k16MiB = 16 << 20;
  for (const Series& s : kSeries) {
    o.say(fmt::format("  {}: {} sizes, {} .. {}", s.label, p.sizes.size(), size_label(p.sizes.front()),
                      size_label(p.sizes.back())));
    const auto timings = gpu::time_transfers(s.dir, s.mem, p.sizes, p.reps, p.warmup);
    std::vector<TransferPoint> points;
    std::vector<Measurement> per_size;
    for (const auto& t : timings) {
      per_size.push_back(rate_measurement(
          fmt::format("{}_{}", s.key, size_key(t.bytes)), fmt::format("{}, {}", s.label, size_label(t.bytes)),
          "B/s", static_cast<double>(t.bytes), t.seconds, std::nullopt,
          fmt::format("cudaMemcpyAsync timed with events, median of {}", t.seconds.size())));
      per_size.back().detail = true;
      points.push_back({static_cast<double>(t.bytes), per_size.back().stats.median});
    }
    const LatencyBandwidthFit f = fit_latency_bandwidth(points);
    const std::string fit_note = fmt::format(
        "fit t = L + bytes/B over {} sizes {}..{} (relative least squares), rms residual {:.1f}%, "
        "max {:.1f}%",
        f.points, size_label(p.sizes.front()), size_label(p.sizes.back()),
        100 * f.rms_rel_residual, 100 * f.max_rel_residual);

    // B: spread of the largest copies' times; L: spread of the smallest copies' times.
    Measurement b;
    b.key = fmt::format("{}_bandwidth", s.key);
    b.label = fmt::format("{}, bandwidth B (fit)", s.label);
    b.unit = std::string("B/s");
    b.value = f.bandwidth;
    b.uncertainty = f.bandwidth_hw95;
    b.stats = per_size.back().stats;
    b.param = s.bandwidth;
    b.note = fit_note;
    r.measurements.push_back(b);
    if (!f.latency_clamped && f.latency > 0) {
      Measurement l;
      l.key = fmt::format("{}_latency", s.key);
      l.label = fmt::format("{}, latency L (fit)", s.label);
      l.unit = std::string("s");
      l.value = f.latency;
      l.uncertainty = f.latency_hw95;
      l.stats = per_size.front().stats;
      l.param = s.latency;
      l.note = fit_note;
      r.measurements.push_back(l);
    } else {
      o.say(fmt::format("  {}: the fit put the latency below zero; {} is left out",
                        s.label, info(s.latency).name));
    }
    // The figures the targets speak of: the slowest size at >= 16 MiB, the smallest copy.
    std::optional<std::size_t> slowest;
    for (std::size_t i = 0; i < per_size.size(); ++i)
      if (p.sizes[i] >= k16MiB && (!slowest || per_size[i].value < per_size[*slowest].value))
        slowest = i;
    if (slowest) {
      Measurement m = per_size[*slowest];
      m.detail = false;
      m.key = fmt::format("{}_min_ge16MiB", s.key);
      m.label = fmt::format("{}, slowest size >= 16 MiB ({})", s.label, size_label(p.sizes[*slowest]));
      r.measurements.push_back(m);
    }
    Measurement small = time_measurement(
        fmt::format("{}_time_{}", s.key, size_key(p.sizes.front())),
        fmt::format("{}, time of one {} copy", s.label, size_label(p.sizes.front())),
        timings.front().seconds, std::nullopt, "median, events around one cudaMemcpyAsync");
    r.measurements.push_back(small);
    o.say(fmt::format("    B = {:.2f} GB/s, L = {:.2f} us, {} copy {:.2f} us", f.bandwidth / 1e9,
                      f.latency * 1e6, size_label(p.sizes.front()), small.value * 1e6));
    for (auto& m : per_size) r.measurements.push_back(std::move(m));
  }
  // What a program that copies and waits pays for a small copy (host clock, blocking call).
  const std::int64_t small = p.sizes.front();
  const int sync_reps = o.effort == Effort::smoke ? 5 : 200;
  for (auto dir : {gpu::Direction::host_to_device, gpu::Direction::device_to_host}) {
    const bool h2d = dir == gpu::Direction::host_to_device;
    r.measurements.push_back(time_measurement(
        fmt::format("{}_pinned_blocking_{}", h2d ? "h2d" : "d2h", size_key(small)),
        fmt::format("{}, pinned, one blocking cudaMemcpy of {}", h2d ? "host->device" : "device->host",
                    size_label(small)),
        gpu::time_blocking_copies(dir, small, sync_reps), std::nullopt,
        fmt::format("host clock around cudaMemcpy (call, copy and wait), median of {}", sync_reps)));
  }
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_gpu_transfers) {
  registry.add({"gpu-transfers",
                "host<->device copies, pinned and pageable, 4 KiB..1 GiB, fitted to L + bytes/B",
                true, 30, dtflop::probes::run});
}
