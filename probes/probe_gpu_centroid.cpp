// L_GP: one step of the device's per-dot pixel classification, a window pixel of a dot. The DCT
// cuda backend gives each dot a block that stages its window's labels in shared memory, classifies
// every window pixel from its neighbourhood twice (the ring's sums, then the weights') and reduces
// between barriers: work that grows with the window pixels and that the blocks' branches and
// barriers bound, not the bytes (docs/model.md 2.6, lat_GP). The dots' blocks run side by side, as
// the model prices them: L_GP is the slope of a fit t = L + window pixels x L_GP over frames of
// the held-out plans' dot radii (4..24 px) and counts (100..1600 dots).
//
// The probe runs the backend's own block (kernels::centroid_block, kernels/dot_centroid.hpp) in a
// kernel launched as the backend launches its own (one block of 128 threads a dot, 12 KiB of stage)
// on rendered frames (probes/centroid_specimen.hpp); every centroid is checked against the same
// arithmetic in float64 on the host (to 1e-3 px).
#include <algorithm>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "model/stats.hpp"
#include "probes/centroid_specimen.hpp"
#include "probes/fit.hpp"
#include "probes/gpu.hpp"
#include "probes/measure.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes {
namespace {

constexpr int kBlock = 128;  // the DCT cuda backend's default threads a block of its centroid kernel

struct Case {
  double radius;
  int dots;
};
struct Plan {
  std::vector<Case> cases;
  int reps;
};

Plan plan(Effort e) {
  switch (e) {
    case Effort::smoke: return {{{5, 150}, {12, 400}, {20, 150}}, 3};
    case Effort::quick: return {{{4, 200}, {4, 1600}, {8, 400}, {8, 1600}, {14, 200}, {14, 800}, {24, 200}, {24, 800}}, 7};
    case Effort::full:
      return {{{4, 100}, {4, 400}, {4, 1600}, {8, 100}, {8, 400}, {8, 1600}, {14, 100}, {14, 400}, {14, 1600},
               {24, 100}, {24, 400}, {24, 1600}},
              15};
  }
  return {{}, 0};
}

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  const Plan p = plan(o.effort);
  std::vector<centroid::Specimen> specimens;
  std::vector<gpu::CentroidFrame> frames;
  for (std::size_t i = 0; i < p.cases.size(); ++i) {
    specimens.push_back(centroid::make_specimen(p.cases[i].radius, p.cases[i].dots, 1000 + i));
    frames.push_back(specimens.back().frame);
  }
  const gpu::CentroidTiming t = gpu::time_centroids(frames, centroid::kMargin, kBlock, p.reps, 3);
  std::vector<TransferPoint> points;
  for (std::size_t i = 0; i < specimens.size(); ++i) {
    const centroid::Specimen& s = specimens[i];
    centroid::check(s, t.centroids[i], 1e-3, "device's");
    Measurement m = time_measurement(
        fmt::format("centroid_r{:g}_dots{}", s.radius, s.frame.component.size()),
        fmt::format("{} dots of radius {:g} px ({} window pixels)", s.frame.component.size(), s.radius, s.window_pixels),
        t.seconds[i], std::nullopt,
        fmt::format("events around a batch of 5 launches behind an untimed one, median of {}", p.reps));
    m.detail = true;
    points.push_back({static_cast<double>(s.window_pixels), m.stats.median});
    r.measurements.push_back(m);
  }
  const PerEventFit fit = fit_per_event(points);
  const auto [rmin, rmax] = std::minmax_element(p.cases.begin(), p.cases.end(),
                                                [](const Case& a, const Case& b) { return a.radius < b.radius; });
  const auto [dmin, dmax] = std::minmax_element(p.cases.begin(), p.cases.end(),
                                                [](const Case& a, const Case& b) { return a.dots < b.dots; });
  const auto [pmin, pmax] = std::minmax_element(
      points.begin(), points.end(), [](const TransferPoint& a, const TransferPoint& b) { return a.bytes < b.bytes; });
  const Measurement m = per_event_measurement(
      "pixel_class", "one window pixel of a dot classified on the device (the centroid block, blocks side by side)",
      fit, t.seconds.back(), Param::L_GP,
      fmt::format("slope of a fit t = L + window pixels x L_GP over {} frames (dots of radius {:g}..{:g} px, {}..{} of "
                  "them, {}..{} window pixels) of the DCT cuda backend's centroid block (kernels::centroid_block), {} "
                  "threads a dot, every centroid checked against float64 on the host; L {:.3g} us, rms residual {:.1f}%",
                  points.size(), rmin->radius, rmax->radius, dmin->dots, dmax->dots,
                  static_cast<std::int64_t>(pmin->bytes), static_cast<std::int64_t>(pmax->bytes), kBlock,
                  fit.fixed * 1e6, 100 * fit.rms_rel_residual));
  r.measurements.push_back(m);
  o.say(fmt::format("  GPU dot windows: {:.3g} ns a pixel classified (fit over {} frames, rms residual {:.1f}%)",
                    m.value * 1e9, points.size(), 100 * fit.rms_rel_residual));
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_gpu_centroid) {
  registry.add({"gpu-centroid",
                "the device's per-dot pixel classification: the DCT cuda backend's centroid block (L_GP)", true, 59,
                dtflop::probes::run});
}
