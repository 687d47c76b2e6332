// The rate of moving-least-squares field arithmetic (V_CM, V_CM_all): what a FLOP of the DCT CPU
// backends' MLS fields costs on this machine. Each support dot of a point is reduced into the
// point's triangular factor by six Givens rotations, each of which waits for the one before (a
// square root and a division a rotation); a second pass sums the residual terms; each point ends
// with back substitutions. That code runs far below the FMA rate, and no other probe prices it:
// docs/model.md 2.6.
//
// The probe runs the workload's own loop (kernels::mls_fields, kernels/point_fields.hpp) on the
// specimen of probes/mls_specimen.hpp (a jittered grid of dots with a quadratic displacement field,
// 1024 points with supports of 12, 30 and 80 dots), on one thread (V_CM: the median over several
// placements of the thread, probes/placements.hpp) and on every usable CPU through OpenCV's
// parallel loop as cpu-par calls it (V_CM_all).
// A repetition evaluates the three tables once; its FLOPs are what the counts give for them (the
// cubic-spline weight, the default). MLS with a quadratic basis reproduces a quadratic field
// exactly, so every point's displacement and strain are checked against the field's own.
#include <algorithm>
#include <chrono>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "kernels/point_fields.hpp"
#include "model/stats.hpp"
#include "probes/measure.hpp"
#include "probes/mls_specimen.hpp"
#include "probes/opencv_threads.hpp"
#include "probes/placements.hpp"
#include "probes/probe.hpp"
#include "probes/team.hpp"

namespace dtflop::probes {
namespace {

using kernels::FieldValue;
using mls::Specimen;
using mls::Table;
using mls::Xy;

// Timed repetitions of the three tables on `threads` threads, after an untimed one.
struct Timed {
  std::vector<double> seconds;                  // a repetition's time (the three tables)
  std::vector<std::vector<double>> per_table;   // each table's times
};

Timed time_reps(const Specimen& s, int reps, int threads) {
  OpenCvThreads scope(threads);
  const kernels::MlsDots<Xy> dots{s.reference.data(), s.disp.data(), s.tracked.data()};
  const kernels::MlsSettings settings{};  // the cubic spline, 6 dots at least, the default pivot ratio
  std::vector<FieldValue<double>> out(s.points.size());
  const int n = static_cast<int>(s.points.size());
  Timed t;
  t.per_table.resize(s.tables.size());
  for (int k = -1; k < reps; ++k) {  // k = -1: warm-up, untimed
    double total = 0;
    for (std::size_t i = 0; i < s.tables.size(); ++i) {
      const Table& tab = s.tables[i];
      const kernels::MlsSupports<Xy> supports{tab.offsets.data(), tab.dots.data(), s.points.data(), tab.rho.data(),
                                              tab.geometry.data()};
      const auto t0 = std::chrono::steady_clock::now();
      if (threads > 1)
        cv::parallel_for_(cv::Range(0, n), [&](const cv::Range& r) {
          kernels::mls_fields(supports, dots, settings, r.start, r.end, out.data());
        });
      else
        kernels::mls_fields(supports, dots, settings, 0, n, out.data());
      const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      // float64 reproduces the quadratic to about 1e-13
      mls::check(s, tab, out, 1e-9, 1e-9, "host");
      total += dt;
      if (k >= 0) t.per_table[i].push_back(dt);
    }
    if (k >= 0) t.seconds.push_back(total);
  }
  return t;
}

// Each table's own rate, so a reader sees whether the per-point share moves it.
std::string table_rates(const Specimen& s, const std::vector<std::vector<double>>& per_table) {
  std::string each;
  for (std::size_t i = 0; i < s.tables.size(); ++i)
    each += fmt::format("{}{} dots {:.3g} GFLOP/s", each.empty() ? "" : ", ", s.tables[i].support,
                        s.tables[i].flops / summarize(per_table[i]).median * 1e-9);
  return each;
}

std::string what(const Specimen& s, const std::string& rates) {
  return fmt::format("the DCT workload's MLS loop (kernels::mls_fields, cubic-spline weight) at {} points of a "
                     "jittered {}x{} dot grid, supports of 12, 30 and 80 dots ({}), every field checked against the "
                     "quadratic it reproduces; {:.4g} FLOPs a repetition",
                     s.points.size(), mls::kGrid, mls::kGrid, rates, s.flops);
}

// V_CM: one thread, the median over placements (probes/placements.hpp) of each one's median.
Measurement measure_one(const Specimen& s, int reps, Effort effort) {
  std::vector<std::vector<double>> per_table(s.tables.size());
  const Placed placed = on_placements(latency_placements(effort), [&] {
    Timed t = time_reps(s, reps, 1);
    for (std::size_t i = 0; i < per_table.size(); ++i)
      per_table[i].insert(per_table[i].end(), t.per_table[i].begin(), t.per_table[i].end());
    return summarize(t.seconds).median;
  });
  return rate_measurement("mls", "MLS field FLOPs (one thread)", "FLOP/s", s.flops, placed.values, Param::V_CM,
                          fmt::format("{} over the median over {} of the median of {} each, on one thread",
                                      what(s, table_rates(s, per_table)), describe_placements(placed.cpus), reps));
}

// V_CM_all: every usable CPU through OpenCV's parallel loop, the median of the repetitions.
Measurement measure_all(const Specimen& s, int reps, int threads) {
  const Timed t = time_reps(s, reps, threads);
  return rate_measurement("mls_all", fmt::format("MLS field FLOPs ({} threads)", threads), "FLOP/s", s.flops,
                          t.seconds, Param::V_CM_all,
                          fmt::format("{} over the median of {} on {} threads", what(s, table_rates(s, t.per_table)),
                                      reps, threads));
}

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  const int reps = o.effort == Effort::full ? 21 : o.effort == Effort::quick ? 7 : 2;
  const Specimen s = mls::make_specimen();
  // One thread: fewer repetitions on each of the several placements.
  r.measurements.push_back(measure_one(s, o.effort == Effort::full ? 7 : o.effort == Effort::quick ? 3 : 1, o.effort));
  const Stats one = r.measurements[0].stats;  // of the times (a copy: the next push_back may move it)
  std::string all;
  if (const int threads = usable_cpus(); threads > 1) {
    r.measurements.push_back(measure_all(s, reps, threads));
    all = fmt::format(", {:.3g} GFLOP/s on {} threads", r.measurements.back().value * 1e-9, threads);
  }
  o.say(fmt::format("  MLS fields: {:.3g} GFLOP/s on one thread (placements {:.3g} .. {:.3g}){}",
                    r.measurements[0].value * 1e-9, s.flops / one.max * 1e-9, s.flops / one.min * 1e-9, all));
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_cpu_mls) {
  registry.add({"cpu-mls",
                "host moving-least-squares field arithmetic: the DCT workload's MLS loop (one thread and all)", false,
                29, dtflop::probes::run});
}
