// Google Benchmark suite of the RBE backends: every backend over grid and kernel sizes, and
// cuda-resident over block layouts. The reported time is the median time of one step (manual
// time from the backend's own per-step timing: host clocks on the CPU, CUDA events inside the
// graph on the GPU). Counters: the floor (bytes / 4.2 TB/s vs FLOPs / 55 TFLOP/s, for device
// backends) and the measured time over it, achieved GFLOP/s of the algorithmic FLOPs.
//
//   bench_rbe                                   # everything this machine can run
//   bench_rbe --benchmark_filter='cuda-resident/1000x1000/k33/'
#include <benchmark/benchmark.h>

#include <fmt/format.h>

#include <string>
#include <vector>

#include "benchmarks/rbe/floors.hpp"
#include "workloads/rbe/backend.hpp"

namespace dtflop::rbe::bench {
namespace {

void run_case(benchmark::State& state, const std::string& backend, const Shape& s, const BackendOptions& o,
              std::int64_t steps) {
  auto b = make_backend(backend, o);
  if (b->needs_gpu()) {
    if (const auto why = cuda_unavailable_reason(); !why.empty()) {
      state.SkipWithError(why.c_str());
      return;
    }
  }
  try {
    b->init(synthetic_problem(s, 42));
    b->run(std::min<std::int64_t>(steps, 100));  // warm-up (and graph capture)
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  double last = 0;
  for (auto _ : state) {
    const RunResult r = b->run(steps);
    last = r.median().total;
    state.SetIterationTime(last);
  }
  const Floor f = floor_of(s);
  state.counters["GFLOP/s"] = benchmark::Counter(f.flops / last / 1e9);
  if (b->needs_gpu()) {
    const double fl = f.seconds(kH200Bandwidth, kH200Flops);
    state.counters["floor_us"] = benchmark::Counter(fl * 1e6);
    state.counters["x_floor"] = benchmark::Counter(last / fl);
  }
  state.counters["step_us"] = benchmark::Counter(last * 1e6);
}

void add(const std::string& backend, const Shape& s, const BackendOptions& o, std::int64_t steps,
         int iterations, const std::string& suffix = "") {
  const std::string name = fmt::format("rbe/{}/{}x{}/k{}/{}", backend, s.nx, s.ny, s.Ix, suffix);
  benchmark::RegisterBenchmark(name.c_str(),
                               [=](benchmark::State& st) { run_case(st, backend, s, o, steps); })
      ->UseManualTime()
      ->Iterations(iterations)
      ->Unit(benchmark::kMicrosecond);
}

void register_all() {
  const BackendOptions defaults;
  // CPU backends: grids and kernels the 2-core CI machine finishes in seconds.
  for (std::int64_t n : {250, 500, 1000})
    for (std::int64_t k : {9, 33, 101}) {
      add("cpu-par", {n, n, k, k}, defaults, n >= 1000 ? 5 : 20, 3);
      if (n <= 500 || k <= 33) add("cpu-seq", {n, n, k, k}, defaults, n >= 1000 ? 2 : 5, 2);
    }
  // GPU backends.
  for (std::int64_t n : {1000, 2000, 4000})
    for (std::int64_t k : {9, 33, 101, 201}) add("cuda-resident", {n, n, k, k}, defaults, 1000, 5, to_string(defaults.layout));
  for (auto mem : {HostMemory::pageable, HostMemory::pinned})
    for (std::int64_t n : {1000, 4000})
      for (std::int64_t k : {33, 201}) {
        BackendOptions o;
        o.host_memory = mem;
        add("cuda-seed", {n, n, k, k}, o, 20, 3, std::string(to_string(mem)));
      }
  // cuda-resident's layouts at the three target configurations (the tuner's search space).
  for (const Shape s : {Shape{1000, 1000, 33, 33}, Shape{1000, 1000, 201, 201}, Shape{4000, 4000, 33, 33}})
    for (const char* l : {"32x8x4", "32x8x8", "32x8x16", "32x16x8", "32x4x16", "64x4x8", "64x4x16", "64x8x8",
                          "32x16x4", "128x2x8", "32x12x16", "48x8x16", "64x6x16", "32x8x8:split",
                          "32x8x16:split", "32x16x8:split", "64x4x8:split"}) {
      BackendOptions o;
      o.layout = parse_layout(l);
      add("cuda-resident", s, o, 1000, 5, std::string("layout-") + l);
    }
  // Kernel by kernel (no graph), for the launch overhead the graph removes.
  BackendOptions nograph;
  nograph.graph = false;
  add("cuda-resident", {1000, 1000, 33, 33}, nograph, 500, 3, "no-graph");
}

}  // namespace
}  // namespace dtflop::rbe::bench

int main(int argc, char** argv) {
  dtflop::rbe::bench::register_all();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
