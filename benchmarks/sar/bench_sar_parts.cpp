// Tests 1 and 2 of the seed (Figures 5.9-5.12): the time of the prediction, the correction and
// the belief fusion of a step, per backend, against the kernel size (Test 1) and the grid size
// (Test 2, kernel 25). The speedup of a backend is cpu-seq's time (the conventional sequential
// RBE) over its own (benchmarks/sar/summarize_parts.py). One CSV row per backend and size:
//   test,backend,nx,ny,Ix,Iy,steps,predict_s,correct_s,step_s,fusion_s,loglinear_s,wire_s
// predict_s and correct_s are the medians of the backend's host-timed parts (0 where the backend
// fuses them into one device step: cuda-resident); step_s the median total; fusion_s and
// loglinear_s the backend's own belief fusion of 3 platforms (Backend::fuse: the product and the
// log-linear pool of its belief and 2 others' wire beliefs, as they arrive, from the call to its
// return: the others' copies to a device included), wire_s its wire belief (Backend::
// wire_belief: what is sent); medians over --steps fusions, each of the problem's prior (the
// belief is restored, untimed, between them).
//
//   bench_sar_parts --test 1 --grid 500 --kernels 1:101:10 --backends cpu-seq,cpu-par -o test1.csv
//   bench_sar_parts --test 2 --kernel 25 --grids 100:1000:100 --backends cpu-seq,cpu-par -o test2.csv
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "model/errors.hpp"
#include "workloads/rbe/backend.hpp"
#include "workloads/rbe/likelihood.hpp"

namespace {

using namespace dtflop;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n == 0 ? 0.0 : n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::vector<std::int64_t> range(const std::string& spec) {  // A:B:S
  std::vector<std::int64_t> out;
  std::int64_t a = 0, b = 0, s = 1;
  char c1 = 0, c2 = 0;
  std::istringstream in(spec);
  if (!(in >> a >> c1 >> b >> c2 >> s) || c1 != ':' || c2 != ':' || a < 1 || b < a || s < 1 || b > 100000)
    throw InputError(fmt::format("'{}': give FIRST:LAST:STEP, e.g. 1:101:10", spec));
  for (std::int64_t v = a; v <= b; v += s) out.push_back(v);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Tests 1-2 of the seed: prediction, correction and belief fusion time per backend (CSV)"};
  int test = 1, steps = 5, threads = 0;
  std::int64_t grid = 500, kernel = 25;
  std::string kernels = "1:101:10", grids = "100:1000:100", backends = "cpu-seq,cpu-par", out;
  app.add_option("--test", test, "1: kernel sizes on one grid; 2: grid sizes with one kernel")->check(CLI::IsMember({1, 2}));
  app.add_option("--grid", grid, "Test 1: the grid n x n")->check(CLI::Range(1, 65536))->capture_default_str();
  app.add_option("--kernels", kernels, "Test 1: kernel sizes FIRST:LAST:STEP")->capture_default_str();
  app.add_option("--kernel", kernel, "Test 2: the kernel size")->check(CLI::Range(1, 4096))->capture_default_str();
  app.add_option("--grids", grids, "Test 2: grid sizes FIRST:LAST:STEP")->capture_default_str();
  app.add_option("--backends", backends, "Backends, comma-separated")->capture_default_str();
  app.add_option("--steps", steps, "Timed steps (and fusions) per size")->check(CLI::Range(1, 10000))->capture_default_str();
  app.add_option("--threads", threads, "cpu-par's threads (0: every hardware thread)")->check(CLI::Range(0, 4096))->capture_default_str();
  app.add_option("-o,--out", out, "CSV file (default: stdout)");
  CLI11_PARSE(app, argc, argv);
  try {
    std::vector<std::string> names;
    {
      std::stringstream s(backends);
      for (std::string n; std::getline(s, n, ',');) names.push_back(n);
    }
    std::vector<rbe::Shape> shapes;
    if (test == 1)
      for (auto k : range(kernels)) shapes.push_back({grid, grid, std::min(k, grid), std::min(k, grid)});
    else
      for (auto n : range(grids)) shapes.push_back({n, n, std::min(kernel, n), std::min(kernel, n)});
    std::string csv = "test,backend,nx,ny,Ix,Iy,steps,predict_s,correct_s,step_s,fusion_s,loglinear_s,wire_s\n";
    for (const auto& shape : shapes) {
      const rbe::Problem p = rbe::synthetic_problem(shape, 20261124);
      // Two other platforms' wire beliefs (other priors), as they arrive over the link.
      std::vector<std::vector<float>> wires;
      for (std::uint64_t seed : {20261125u, 20261126u}) {
        auto other = rbe::make_backend("cpu-seq");
        other->init(rbe::synthetic_problem(shape, seed));
        wires.push_back(other->wire_belief());
      }
      const std::vector<std::span<const float>> others(wires.begin(), wires.end());
      for (const auto& name : names) {
        rbe::BackendOptions options;
        options.threads = threads;
        auto b = rbe::make_backend(name, options);
        const std::string why = b->needs_gpu() ? rbe::cuda_unavailable_reason() : std::string();
        if (!why.empty()) {
          std::fprintf(stderr, "bench_sar_parts: %s skipped: %s\n", name.c_str(), why.c_str());
          continue;
        }
        b->init(p);
        (void)b->run(2);  // warm-up
        const rbe::RunResult r = b->run(steps);
        std::vector<double> pr, co, to;
        for (const auto& s : r.samples) {
          pr.push_back(s.part(rbe::StepPart::predict));
          co.push_back(s.part(rbe::StepPart::correct) + s.part(rbe::StepPart::normalize) + s.part(rbe::StepPart::host_sum));
          to.push_back(s.total);
        }
        // Fusion: each timed call on the prior (init() untimed before it), the first discarded.
        auto fusion_time = [&](auto&& fn) {
          std::vector<double> t;
          for (int rep = -1; rep < steps; ++rep) {
            b->init(p);
            const auto t0 = std::chrono::steady_clock::now();
            fn();
            const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            if (rep >= 0) t.push_back(sec);
          }
          return median(t);
        };
        const double fusion = fusion_time([&] { b->fuse(rbe::FusionRule::product, others, 0); });
        const double pool = fusion_time([&] { b->fuse(rbe::FusionRule::loglinear, others, 0); });
        const double wire = fusion_time([&] { (void)b->wire_belief(); });
        // A part the backend does not time apart (cuda-resident: prediction and correction in one
        // fused kernel, StepPart::device_step) is left empty, not written as a time of 0.
        const auto measured = r.components();
        auto has = [&](std::initializer_list<rbe::StepPart> parts) {
          for (rbe::StepPart c : parts)
            if (std::find(measured.begin(), measured.end(), c) != measured.end()) return true;
          return false;
        };
        auto field = [](bool present, double v) { return present ? fmt::format("{:.9g}", v) : std::string(); };
        const std::string predict = field(has({rbe::StepPart::predict}), median(pr));
        const std::string correct =
            field(has({rbe::StepPart::correct, rbe::StepPart::normalize, rbe::StepPart::host_sum}), median(co));
        csv += fmt::format("{},{},{},{},{},{},{},{},{},{:.9g},{:.9g},{:.9g},{:.9g}\n", test, name, shape.nx, shape.ny,
                           shape.Ix, shape.Iy, steps, predict, correct, median(to), fusion, pool, wire);
        std::fprintf(stderr, "bench_sar_parts: test %d %s %lldx%lld k%lld: step %.3g s, fusion %.3g s\n", test,
                     name.c_str(), static_cast<long long>(shape.nx), static_cast<long long>(shape.ny),
                     static_cast<long long>(shape.Ix), median(to), fusion);
      }
    }
    if (out.empty()) {
      std::fputs(csv.c_str(), stdout);
    } else {
      std::ofstream(out) << csv;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_sar_parts: %s\n", e.what());
    return 2;
  }
  return 0;
}
