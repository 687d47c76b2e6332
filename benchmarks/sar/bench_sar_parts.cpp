// Tests 1 and 2 of the seed (Figures 5.9-5.12): the time of the prediction, the correction and
// the belief fusion of a step, per backend, against the kernel size (Test 1) and the grid size
// (Test 2, kernel 25). The speedup of a backend is cpu-seq's time (the conventional sequential
// RBE) over its own (benchmarks/sar/summarize_parts.py). One CSV row per backend and size:
//   test,backend,nx,ny,Ix,Iy,steps,predict_s,correct_s,step_s,fusion_s,loglinear_s
// predict_s and correct_s are the medians of the backend's host-timed parts (0 where the backend
// fuses them into one device step: cuda-resident); step_s the median total; fusion_s and
// loglinear_s the belief fusion of 3 platforms' beliefs on the host (float64, one thread: the
// same code for every backend, so measured once per size, on the cpu-seq row).
//
//   bench_sar_parts --test 1 --grid 500 --kernels 1:101:10 --backends cpu-seq,cpu-par -o test1.csv
//   bench_sar_parts --test 2 --kernel 25 --grids 100:1000:100 --backends cpu-seq,cpu-par -o test2.csv
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "model/errors.hpp"
#include "sar/fusion.hpp"
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

double seconds_of(auto&& fn, int reps) {
  std::vector<double> t;
  for (int r = -1; r < reps; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    fn();
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (r >= 0) t.push_back(s);
  }
  return median(t);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Tests 1-2 of the seed: prediction, correction and belief fusion time per backend (CSV)"};
  int test = 1, steps = 5;
  std::int64_t grid = 500, kernel = 25;
  std::string kernels = "1:101:10", grids = "100:1000:100", backends = "cpu-seq,cpu-par", out;
  app.add_option("--test", test, "1: kernel sizes on one grid; 2: grid sizes with one kernel")->check(CLI::IsMember({1, 2}));
  app.add_option("--grid", grid, "Test 1: the grid n x n")->check(CLI::Range(1, 65536))->capture_default_str();
  app.add_option("--kernels", kernels, "Test 1: kernel sizes FIRST:LAST:STEP")->capture_default_str();
  app.add_option("--kernel", kernel, "Test 2: the kernel size")->check(CLI::Range(1, 4096))->capture_default_str();
  app.add_option("--grids", grids, "Test 2: grid sizes FIRST:LAST:STEP")->capture_default_str();
  app.add_option("--backends", backends, "Backends, comma-separated")->capture_default_str();
  app.add_option("--steps", steps, "Timed steps per size")->check(CLI::Range(1, 10000))->capture_default_str();
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
    std::string csv = "test,backend,nx,ny,Ix,Iy,steps,predict_s,correct_s,step_s,fusion_s,loglinear_s\n";
    for (const auto& shape : shapes) {
      const rbe::Problem p = rbe::synthetic_problem(shape, 20261124);
      double fusion = 0, pool = 0;
      {
        std::vector<std::vector<double>> beliefs(3, p.prior);
        double z = 0;
        for (double v : p.prior) z += v * p.grid.cell_area();
        for (auto& b : beliefs)
          for (double& v : b) v /= z;
        const int reps = std::max(3, steps);
        fusion = seconds_of([&] { (void)rbe::fuse_beliefs(p.grid, beliefs); }, reps);
        pool = seconds_of([&] { (void)sar::loglinear_pool(p.grid, beliefs); }, reps);
      }
      for (const auto& name : names) {
        auto b = rbe::make_backend(name);
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
        const bool first = name == names.front();
        csv += fmt::format("{},{},{},{},{},{},{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n", test, name, shape.nx, shape.ny,
                           shape.Ix, shape.Iy, steps, median(pr), median(co), median(to), first ? fusion : 0.0,
                           first ? pool : 0.0);
        std::fprintf(stderr, "bench_sar_parts: test %d %s %lldx%lld k%lld: step %.3g s\n", test, name.c_str(),
                     static_cast<long long>(shape.nx), static_cast<long long>(shape.ny),
                     static_cast<long long>(shape.Ix), median(to));
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
