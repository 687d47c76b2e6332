// The rate of one GPU thread's moving-least-squares field (V_GM). The DCT cuda backend gives each
// interpolation point a thread; a point's support dots are reduced into its triangular factor by
// Givens rotations, each waiting for the one before (a square root and a division a rotation),
// so a thread's field is one long chain of dependent arithmetic and its loads, and the points'
// threads (a few thousand at most, one round on any GPU) run side by side: a field takes one
// point's chain, far from the FLOP rate (docs/model.md 2.6, lat_GM).
//
// The probe runs the backend's own point (kernels::mls_point_device, kernels/point_fields.hpp) in
// a kernel launched as the backend launches its own (one point a thread, 128 threads a block: the
// backend's default), on the specimen cpu-mls runs (probes/mls_specimen.hpp: 1024 points, supports
// of 12, 30 and 80 dots). V_GM is one point's FLOPs summed over the three tables (as the counts
// give them) over the median of a repetition's three kernel times added (each timed behind a
// queued launch, as the backend's kernel runs behind the frame's others). Every point's field is
// checked against the quadratic field it reproduces (float32: to 1e-4 px and 1e-5 strain).
#include <string>
#include <vector>

#include <fmt/format.h>

#include "model/stats.hpp"
#include "probes/gpu.hpp"
#include "probes/measure.hpp"
#include "probes/mls_specimen.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes {
namespace {

constexpr int kBlock = 128;  // the DCT cuda backend's default threads a block of its field kernels

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  const int reps = o.effort == Effort::full ? 51 : o.effort == Effort::quick ? 15 : 3;
  const mls::Specimen s = mls::make_specimen();
  gpu::MlsDots dots;
  for (std::size_t j = 0; j < s.reference.size(); ++j) {
    dots.reference_xy.insert(dots.reference_xy.end(), {s.reference[j].x, s.reference[j].y});
    dots.disp_xy.insert(dots.disp_xy.end(), {static_cast<float>(s.disp[j].x), static_cast<float>(s.disp[j].y)});
  }
  std::vector<gpu::MlsTable> tables;
  for (const mls::Table& t : s.tables) {
    gpu::MlsTable g;
    for (const auto& p : s.points) g.points_xy.insert(g.points_xy.end(), {p.x, p.y});
    for (double rho : t.rho) g.rho.push_back(static_cast<float>(rho));
    g.offsets.assign(t.offsets.begin(), t.offsets.end());
    g.dots.assign(t.dots.begin(), t.dots.end());
    tables.push_back(std::move(g));
  }
  const gpu::MlsTiming timing = gpu::time_mls(dots, tables, kBlock, reps, 3);
  const double points = static_cast<double>(s.points.size());
  double chain_flops = 0;
  std::string each;
  for (std::size_t i = 0; i < s.tables.size(); ++i) {
    mls::check(s, s.tables[i], timing.fields[i], 1e-4, 1e-5, "device's");
    const double flops = s.tables[i].flops / points;  // one point's: its thread's chain
    chain_flops += flops;
    each += fmt::format("{}{} dots {:.3g} us", each.empty() ? "" : ", ", s.tables[i].support,
                        summarize(timing.seconds[i]).median * 1e6);
  }
  // A repetition: one launch of each table; its time, the three launches' times added.
  std::vector<double> seconds(timing.seconds[0].size(), 0.0);
  for (const auto& t : timing.seconds)
    for (std::size_t k = 0; k < seconds.size(); ++k) seconds[k] += t[k];
  r.measurements.push_back(rate_measurement(
      "mls_chain", "one GPU thread's MLS field (a point's chain)", "FLOP/s", chain_flops, seconds, Param::V_GM,
      fmt::format("the DCT cuda backend's MLS point (kernels::mls_point_device, cubic-spline weight), one point a "
                  "thread, {} threads a block, {} points of a jittered {}x{} dot grid with supports of 12, 30 and 80 "
                  "dots ({}), every field checked against the quadratic it reproduces; {:.4g} FLOPs of one point's "
                  "three fields over the median of {} repetitions of the three launches (events around 5 queued "
                  "launches of each)",
                  kBlock, s.points.size(), mls::kGrid, mls::kGrid, each, chain_flops, reps)));
  o.say(fmt::format("  GPU MLS point: {:.3g} GFLOP/s on its thread ({})", r.measurements[0].value * 1e-9, each));
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_gpu_mls) {
  registry.add({"gpu-mls", "one GPU thread's moving-least-squares field: the DCT cuda backend's MLS point", true, 58,
                dtflop::probes::run});
}
