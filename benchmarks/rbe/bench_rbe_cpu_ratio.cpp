// cpu-par's prediction against OpenCV's cv::sepFilter2D on the same grid, kernel and number
// of threads, measured in one run, interleaved in rounds so that both see the same machine
// state. Prints both medians and the ratio cpu-par / OpenCV (<= 1: cpu-par is no slower).
//
//   bench_rbe_cpu_ratio [--grid 1000x1000] [--kernel 33x33] [--threads N] [--reps 30] [--rounds 5]
#include <algorithm>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "model/errors.hpp"
#include "model/units.hpp"
#include "workloads/rbe/backend.hpp"
#include "workloads/rbe/detail.hpp"

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace dtflop;
  CLI::App app{"cpu-par's prediction against cv::sepFilter2D, same grid, kernel and threads"};
  std::string grid = "1000x1000", kernel = "33x33";
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  int reps = 30, rounds = 5;
  app.add_option("--grid", grid)->capture_default_str();
  app.add_option("--kernel", kernel)->capture_default_str();
  app.add_option("--threads", threads)->capture_default_str()->check(CLI::Range(1, 4096));
  app.add_option("--reps", reps, "steps per round and backend")->capture_default_str()->check(CLI::Range(1, 100000));
  app.add_option("--rounds", rounds)->capture_default_str()->check(CLI::Range(1, 1000));
  CLI11_PARSE(app, argc, argv);
  try {
    const auto g = parse_size2(grid, "--grid", 65536);
    const auto k = parse_size2(kernel, "--kernel", 65536);
    const rbe::Shape s{g.x, g.y, k.x, k.y};
    const rbe::Problem p = rbe::synthetic_problem(s, 7);

    rbe::BackendOptions o;
    o.threads = threads;
    auto par = rbe::make_backend("cpu-par", o);
    par->init(p);

    cv::setNumThreads(threads);
    cv::Mat src(int(s.ny), int(s.nx), CV_32F), dst(int(s.ny), int(s.nx), CV_32F);
    for (std::int64_t i = 0; i < s.cells(); ++i) src.at<float>(int(i / s.nx), int(i % s.nx)) = float(p.prior[std::size_t(i)]);
    cv::Mat kx(1, int(s.Ix), CV_32F), ky(int(s.Iy), 1, CV_32F);
    for (std::int64_t a = 0; a < s.Ix; ++a) kx.at<float>(0, int(a)) = float(p.kernel.kx()[std::size_t(a)]);
    for (std::int64_t b = 0; b < s.Iy; ++b) ky.at<float>(int(b), 0) = float(p.kernel.ky()[std::size_t(b)]);
    auto opencv = [&] {
      cv::sepFilter2D(src, dst, CV_32F, kx, ky, cv::Point(-1, -1), 0, cv::BORDER_CONSTANT);
    };

    par->run(3);  // warm-up
    for (int i = 0; i < 3; ++i) opencv();
    std::vector<double> t_par, t_cv;
    for (int r = 0; r < rounds; ++r) {
      const auto run = par->run(reps);
      for (const auto& st : run.samples) t_par.push_back(st.part(rbe::StepPart::predict));
      for (int i = 0; i < reps; ++i) {
        const double t0 = rbe::detail::seconds_now();
        opencv();
        t_cv.push_back(rbe::detail::seconds_now() - t0);
      }
    }
    const double mp = median(t_par), mc = median(t_cv);
    const double flops = 2.0 * double(s.cells()) * double(s.Ix + s.Iy);
    fmt::print("prediction, grid {}x{}, kernel {}x{}, {} threads (OpenCV: {}), {} rounds x {} steps\n", s.nx, s.ny,
               s.Ix, s.Iy, threads, cv::getNumThreads(), rounds, reps);
    fmt::print("  {:<22} {:>10}  {:>8.1f} GFLOP/s\n", "cpu-par", format_duration(mp), flops / mp / 1e9);
    fmt::print("  {:<22} {:>10}  {:>8.1f} GFLOP/s\n", "cv::sepFilter2D", format_duration(mc), flops / mc / 1e9);
    fmt::print("  ratio cpu-par / OpenCV: {:.3f} ({})\n", mp / mc, mp <= mc ? "cpu-par no slower" : "cpu-par slower");
    return 0;
  } catch (const InputError& e) {
    fmt::print(stderr, "bench_rbe_cpu_ratio: error: {}\n", e.what());
    return 2;
  }
}
