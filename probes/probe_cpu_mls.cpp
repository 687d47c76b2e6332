// The rate of moving-least-squares field arithmetic (V_CM, V_CM_all): what a FLOP of the DCT CPU
// backends' MLS fields costs on this machine. Each support dot of a point is reduced into the
// point's triangular factor by six Givens rotations, each of which waits for the one before (a
// square root and a division a rotation); a second pass sums the residual terms; each point ends
// with back substitutions. That code runs far below the FMA rate, and no other probe prices it:
// docs/model.md 2.6.
//
// The probe runs the workload's own loop (kernels::mls_fields, kernels/point_fields.hpp) on a
// jittered grid of dots with a quadratic displacement field, at 1024 points with supports of 12, 30
// and 80 dots (the nearest, as the workload's support by dot count takes them), on one thread
// (V_CM) and on every usable CPU through OpenCV's parallel loop as cpu-par calls it (V_CM_all).
// A repetition evaluates the three tables once; its FLOPs are what the counts give for them (the
// cubic-spline weight, the default). MLS with a quadratic basis reproduces a quadratic field
// exactly, so every point's displacement and strain are checked against the field's own.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "kernels/point_fields.hpp"
#include "probes/measure.hpp"
#include "probes/opencv_threads.hpp"
#include "probes/probe.hpp"
#include "probes/team.hpp"

namespace dtflop::probes {
namespace {

using kernels::FieldValue;
using kernels::PointStatus;

struct Xy {
  double x = 0, y = 0;
};

constexpr int kGrid = 64;          // dots a side: 4096 dots
constexpr double kPitch = 16;      // px between dots
constexpr double kJitter = 3;      // px, either way
constexpr int kPointsSide = 32;    // 1024 points
constexpr std::array<int, 3> kSupports = {12, 30, 80};  // dots a support (the workload's 10..100)

// The displacement field, px: a quadratic, which MLS with its quadratic basis reproduces exactly.
Xy displacement(double x, double y) {
  return {1e-3 * x + 4e-4 * y + 2e-7 * x * x - 1e-7 * x * y + 3e-7 * y * y,
          -5e-4 * x + 2e-3 * y + 1e-7 * x * x + 2e-7 * x * y - 1e-7 * y * y};
}
// Its gradient (du_x/dx, du_x/dy, du_y/dx, du_y/dy).
std::array<double, 4> gradient(double x, double y) {
  return {1e-3 + 4e-7 * x - 1e-7 * y, 4e-4 - 1e-7 * x + 6e-7 * y, -5e-4 + 2e-7 * x + 2e-7 * y,
          2e-3 + 2e-7 * x - 2e-7 * y};
}

struct Table {
  int support = 0;
  std::vector<std::int32_t> offsets, dots;
  std::vector<double> rho;
  std::vector<PointStatus> geometry;
};

struct Specimen {
  std::vector<Xy> reference, disp, points;
  std::vector<std::uint8_t> tracked;
  std::vector<Table> tables;
  double flops = 0;  // of one evaluation of every table
};

Specimen make_specimen() {
  Specimen s;
  std::mt19937_64 rng(20261127);
  std::uniform_real_distribution<double> jitter(-kJitter, kJitter);
  for (int j = 0; j < kGrid; ++j)  // raster order, as the labelling numbers a frame's dots
    for (int i = 0; i < kGrid; ++i) {
      const Xy p{(i + 0.5) * kPitch + jitter(rng), (j + 0.5) * kPitch + jitter(rng)};
      s.reference.push_back(p);
      s.disp.push_back(displacement(p.x, p.y));
    }
  s.tracked.assign(s.reference.size(), 1);
  // Points over the middle half, so that every support lies within the dots.
  const double lo = 0.25 * kGrid * kPitch, hi = 0.75 * kGrid * kPitch;
  for (int j = 0; j < kPointsSide; ++j)
    for (int i = 0; i < kPointsSide; ++i)
      s.points.push_back({lo + (hi - lo) * i / (kPointsSide - 1), lo + (hi - lo) * j / (kPointsSide - 1)});
  const int most = *std::max_element(kSupports.begin(), kSupports.end());
  std::vector<std::vector<std::pair<double, std::int32_t>>> nearest(s.points.size());
  std::vector<std::pair<double, std::int32_t>> d(s.reference.size());
  for (std::size_t m = 0; m < s.points.size(); ++m) {
    for (std::size_t k = 0; k < s.reference.size(); ++k) {
      const double dx = s.reference[k].x - s.points[m].x, dy = s.reference[k].y - s.points[m].y;
      d[k] = {dx * dx + dy * dy, static_cast<std::int32_t>(k)};
    }
    std::partial_sort(d.begin(), d.begin() + most + 1, d.end());
    nearest[m].assign(d.begin(), d.begin() + most + 1);
  }
  for (int n : kSupports) {
    Table t;
    t.support = n;
    t.offsets.push_back(0);
    for (const auto& near : nearest) {
      for (int k = 0; k < n; ++k) t.dots.push_back(near[static_cast<std::size_t>(k)].second);
      t.offsets.push_back(static_cast<std::int32_t>(t.dots.size()));
      // Midway between the n-th and the (n + 1)-th dot, as the workload's support by dot count.
      t.rho.push_back(0.5 * (std::sqrt(near[static_cast<std::size_t>(n) - 1].first) +
                             std::sqrt(near[static_cast<std::size_t>(n)].first)));
      t.geometry.push_back(PointStatus::ok);
    }
    s.flops += static_cast<double>(kernels::flops_per_support_dot(kernels::Weight::cubic_spline)) *
                   static_cast<double>(t.dots.size()) +
               static_cast<double>(kernels::kFlopsPerPoint) * static_cast<double>(s.points.size());
    s.tables.push_back(std::move(t));
  }
  return s;
}

// Every point of every table: status ok, the whole support used, the field's own displacement
// and strain (to 1e-9 px and 1e-9: float64 reproduces the quadratic to about 1e-13).
void check(const Specimen& s, const Table& t, const std::vector<FieldValue<double>>& out) {
  for (std::size_t m = 0; m < s.points.size(); ++m) {
    const FieldValue<double>& f = out[m];
    const Xy u = displacement(s.points[m].x, s.points[m].y);
    const auto g = gradient(s.points[m].x, s.points[m].y);
    FieldValue<double> want;
    kernels::strain_from_gradient(g[0], g[1], g[2], g[3], want);
    const double du = std::max(std::abs(f.ux - u.x), std::abs(f.uy - u.y));
    const double de = std::max({std::abs(f.exx - want.exx), std::abs(f.eyy - want.eyy), std::abs(f.exy - want.exy)});
    if (f.status != PointStatus::ok || f.support != t.support || !(du <= 1e-9) || !(de <= 1e-9))
      throw ValidationError(fmt::format(
          "the MLS field at point {} of the {}-dot supports is off: status {}, {} of {} dots, displacement {:.3g} px "
          "and strain {:.3g} from the quadratic field's",
          m, t.support, static_cast<int>(f.status), f.support, t.support, du, de));
  }
}

// V_CM (threads = 1) or V_CM_all: the FLOPs of a repetition over its median time.
Measurement measure(const Specimen& s, int reps, int threads) {
  OpenCvThreads scope(threads);
  const kernels::MlsDots<Xy> dots{s.reference.data(), s.disp.data(), s.tracked.data()};
  const kernels::MlsSettings settings{};  // the cubic spline, 6 dots at least, the default pivot ratio
  std::vector<FieldValue<double>> out(s.points.size());
  const int n = static_cast<int>(s.points.size());
  std::vector<double> seconds;
  std::vector<std::vector<double>> per_table(s.tables.size());
  for (int k = -1; k < reps; ++k) {  // k = -1: warm-up, untimed
    double total = 0;
    for (std::size_t i = 0; i < s.tables.size(); ++i) {
      const Table& t = s.tables[i];
      const kernels::MlsSupports<Xy> supports{t.offsets.data(), t.dots.data(), s.points.data(), t.rho.data(),
                                              t.geometry.data()};
      const auto t0 = std::chrono::steady_clock::now();
      if (threads > 1)
        cv::parallel_for_(cv::Range(0, n), [&](const cv::Range& r) {
          kernels::mls_fields(supports, dots, settings, r.start, r.end, out.data());
        });
      else
        kernels::mls_fields(supports, dots, settings, 0, n, out.data());
      const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      check(s, t, out);
      total += dt;
      if (k >= 0) per_table[i].push_back(dt);
    }
    if (k >= 0) seconds.push_back(total);
  }
  // Each table's own rate, so a reader sees whether the per-point share moves it.
  std::string each;
  for (std::size_t i = 0; i < s.tables.size(); ++i) {
    std::vector<double> v = per_table[i];
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    const double flops = static_cast<double>(kernels::flops_per_support_dot(kernels::Weight::cubic_spline)) *
                             static_cast<double>(s.tables[i].dots.size()) +
                         static_cast<double>(kernels::kFlopsPerPoint) * n;
    each += fmt::format("{}{} dots {:.3g} GFLOP/s", each.empty() ? "" : ", ", s.tables[i].support,
                        flops / v[v.size() / 2] * 1e-9);
  }
  const bool all = threads > 1;
  const std::string who = all ? fmt::format("{} threads", threads) : "one thread";
  return rate_measurement(
      all ? "mls_all" : "mls", fmt::format("MLS field FLOPs ({})", who), "FLOP/s", s.flops, seconds,
      all ? Param::V_CM_all : Param::V_CM,
      fmt::format("the DCT workload's MLS loop (kernels::mls_fields, cubic-spline weight) at {} points of a jittered "
                  "{}x{} dot grid, supports of 12, 30 and 80 dots ({}), every field checked against the quadratic it "
                  "reproduces; {:.4g} FLOPs a repetition over the median of {} on {}",
                  n, kGrid, kGrid, each, s.flops, reps, who));
}

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  const int reps = o.effort == Effort::full ? 21 : o.effort == Effort::quick ? 7 : 2;
  const Specimen s = make_specimen();
  r.measurements.push_back(measure(s, reps, 1));
  std::string all;
  if (const int threads = usable_cpus(); threads > 1) {
    r.measurements.push_back(measure(s, reps, threads));
    all = fmt::format(", {:.3g} GFLOP/s on {} threads", r.measurements.back().value * 1e-9, threads);
  }
  o.say(fmt::format("  MLS fields: {:.3g} GFLOP/s on one thread{}", r.measurements[0].value * 1e-9, all));
  return r;
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_cpu_mls) {
  registry.add({"cpu-mls",
                "host moving-least-squares field arithmetic: the DCT workload's MLS loop (one thread and all)", false,
                29, dtflop::probes::run});
}
