// Google Benchmark suite for the probes' kernels. CPU: STREAM triad and FMA chains, one
// thread and all threads; k-d tree steps, fresh trees against one tree repeated. GPU (skipped with the reason when no device is usable): pinned and
// pageable transfers by size, device-to-device copies, FMA kernels with 4/8/16 chains,
// launch overhead.
//
// GPU cases time with CUDA events inside the probe functions and hand each repetition's time
// to the framework (UseManualTime), so the reported times are device times; the counter
// `median_GBps` / `median_TFLOPs` is the median over the repetitions, the figure dtflop probe
// reports. Example (what docs/PERFORMANCE.md records):
//   bench_probes --benchmark_filter='Transfer|D2D|CopyKernel|GpuFma|Launch'
//                --benchmark_out_format=json --benchmark_out=bench.json
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <fmt/format.h>
#include <nanoflann.hpp>

#include <random>

#include "model/cost_counts.hpp"
#include "probes/cpu_kernels.hpp"
#include "probes/gpu.hpp"
#include "model/stats.hpp"
#include "probes/team.hpp"

namespace dtflop::probes {
namespace {

// ---- CPU -------------------------------------------------------------------------------

// Triad over arrays of range(0) bytes each, split among the benchmark's threads.
void BM_CpuTriad(benchmark::State& st) {
  const auto total = static_cast<std::size_t>(st.range(0)) / sizeof(double);
  const std::size_t n = total / static_cast<std::size_t>(st.threads());
  std::unique_ptr<double[]> a(new double[n]), b(new double[n]), c(new double[n]);
  for (std::size_t i = 0; i < n; ++i) {
    a[i] = 0;
    b[i] = static_cast<double>(i % 1024);
    c[i] = 0.5;
  }
  const cpu::Isa isa = cpu::best_isa();
  for (auto _ : st) {
    cpu::stream_triad(isa, a.get(), b.get(), c.get(), 3.0, n);
    benchmark::ClobberMemory();
  }
  if (a[n - 1] != b[n - 1] + 1.5) st.SkipWithError("triad result is wrong");
  st.SetBytesProcessed(static_cast<std::int64_t>(st.iterations()) * static_cast<std::int64_t>(24 * n));
}
BENCHMARK(BM_CpuTriad)->Arg(256 << 20)->ThreadRange(1, 1)->UseRealTime();
BENCHMARK(BM_CpuTriad)->Arg(256 << 20)->Threads(usable_cpus())->UseRealTime();

template <typename T>
void BM_CpuFma(benchmark::State& st) {
  const cpu::Isa isa = cpu::best_isa();
  const int chains = cpu::fma_chain_count(isa, sizeof(T) == 8);
  std::vector<T> acc(static_cast<std::size_t>(chains));
  for (int j = 0; j < chains; ++j) acc[static_cast<std::size_t>(j)] = static_cast<T>(j);
  const std::int64_t steps = 1 << 16;  // even: every chain ends where it started
  for (auto _ : st) {
    cpu::fma_chains(isa, steps, T(-1), T(3), acc.data());
    benchmark::DoNotOptimize(acc.data());
  }
  for (int j = 0; j < chains; ++j)
    if (acc[static_cast<std::size_t>(j)] != static_cast<T>(j)) st.SkipWithError("FMA chain is wrong");
  st.counters["FLOP/s"] = benchmark::Counter(
      2.0 * chains * static_cast<double>(steps) * static_cast<double>(st.iterations()),
      benchmark::Counter::kIsRate);
  st.SetLabel(std::string(cpu::to_string(isa)));
}
BENCHMARK(BM_CpuFma<float>)->Name("BM_CpuFma/fp32")->Threads(1)->UseRealTime();
BENCHMARK(BM_CpuFma<float>)->Name("BM_CpuFma/fp32")->Threads(usable_cpus())->UseRealTime();
BENCHMARK(BM_CpuFma<double>)->Name("BM_CpuFma/fp64")->Threads(1)->UseRealTime();
BENCHMARK(BM_CpuFma<double>)->Name("BM_CpuFma/fp64")->Threads(usable_cpus())->UseRealTime();

// k-d tree steps (the cpu-tree probe's work, L_tree): a nanoflann tree over range(0) random points
// and a 2-nearest search around each, `trees` = range(1) different point sets built and searched in
// turn. One set (trees = 1) is the same tree over and over, whose searches the branch predictor
// learns; 64 sets are fresh trees each time. Counter per_step: the time over the steps the
// workloads count (tree_build_steps + n tree_search_steps). docs/model.md 2.6 quotes it:
//   bench_probes --benchmark_filter=TreeSteps
struct TreeCloud {
  const std::vector<double>* xy = nullptr;
  std::size_t kdtree_get_point_count() const { return xy->size() / 2; }
  double kdtree_get_pt(std::size_t i, std::size_t dim) const { return (*xy)[2 * i + dim]; }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const { return false; }
};
void BM_TreeSteps(benchmark::State& st) {
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, TreeCloud>, TreeCloud, 2,
                                                   std::uint32_t>;
  const std::int64_t n = st.range(0), trees = st.range(1);
  std::mt19937_64 rng(20261128);
  std::uniform_real_distribution<double> u(0, 90.0 * std::sqrt(static_cast<double>(n))), jitter(-0.5, 0.5);
  std::vector<std::vector<double>> pts(static_cast<std::size_t>(trees)), queries(pts.size());
  for (std::size_t k = 0; k < pts.size(); ++k) {
    pts[k].resize(static_cast<std::size_t>(2 * n));
    queries[k].resize(pts[k].size());
    for (auto& v : pts[k]) v = u(rng);
    for (std::size_t i = 0; i < pts[k].size(); ++i) queries[k][i] = pts[k][i] + jitter(rng);
  }
  std::int64_t uses = 0, found = 0;
  for (auto _ : st) {
    const auto k = static_cast<std::size_t>(uses++ % trees);
    TreeCloud cloud{&pts[k]};
    Tree tree(2, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(kKdTreeLeaf));
    std::uint32_t idx[2];
    double d2[2];
    for (std::int64_t i = 0; i < n; ++i) {
      const double at[2] = {queries[k][static_cast<std::size_t>(2 * i)], queries[k][static_cast<std::size_t>(2 * i + 1)]};
      found += static_cast<std::int64_t>(tree.knnSearch(at, 2, idx, d2));
    }
  }
  if (found != 2 * n * uses) st.SkipWithError("a search found fewer than 2 points");
  const double steps = static_cast<double>(tree_build_steps(n) + n * tree_search_steps(n, 2));
  // Steps an iteration as a rate, inverted: seconds a step.
  st.counters["per_step"] =
      benchmark::Counter(steps, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_TreeSteps)
    ->ArgsProduct({{128, 512, 1024, 1536, 2048, 4096}, {1, 64}})
    ->ArgNames({"points", "trees"})
    ->MinTime(0.2);

// ---- GPU -------------------------------------------------------------------------------

bool need_gpu(benchmark::State& st) {
  static const gpu::DeviceInfo d = gpu::device_info();
  if (!d.usable) st.SkipWithError(fmt::format("no usable CUDA device: {}", d.reason).c_str());
  return d.usable;
}

// Hands measured per-repetition times to the framework, one per iteration.
void report(benchmark::State& st, const std::vector<double>& seconds, double amount,
            const char* counter, double scale) {
  std::size_t i = 0;
  for (auto _ : st) st.SetIterationTime(seconds[i++ % seconds.size()]);
  st.counters[counter] = amount / summarize(seconds).median / scale;
}

// range(0): bytes; range(1): 0 host->device, 1 device->host; range(2): 0 pinned, 1 pageable.
void BM_Transfer(benchmark::State& st) {
  if (!need_gpu(st)) return;
  const std::vector<std::int64_t> size = {st.range(0)};
  const std::vector<int> reps = {static_cast<int>(st.max_iterations)};
  const auto dir = st.range(1) == 0 ? gpu::Direction::host_to_device : gpu::Direction::device_to_host;
  const auto mem = st.range(2) == 0 ? HostMemory::pinned : HostMemory::pageable;
  const auto t = gpu::time_transfers(dir, mem, size, reps, 2);
  report(st, t[0].seconds, static_cast<double>(st.range(0)), "median_GBps", 1e9);
  st.SetBytesProcessed(static_cast<std::int64_t>(st.iterations()) * st.range(0));
}
void transfer_args(benchmark::internal::Benchmark* b) {
  for (int dir : {0, 1}) {
    for (std::int64_t s : {std::int64_t{4} << 10, std::int64_t{64} << 10, std::int64_t{1} << 20,
                           std::int64_t{16} << 20, std::int64_t{64} << 20, std::int64_t{256} << 20,
                           std::int64_t{1} << 30})
      b->Args({s, dir, 0});
    for (std::int64_t s : {std::int64_t{16} << 20, std::int64_t{1} << 30}) b->Args({s, dir, 1});
  }
  b->ArgNames({"bytes", "d2h", "pageable"});
}
BENCHMARK(BM_Transfer)->Apply(transfer_args)->Iterations(20)->UseManualTime();

void BM_D2D(benchmark::State& st) {
  if (!need_gpu(st)) return;
  const std::int64_t bytes = gpu::fit_device_buffer(st.range(0), 2);
  const auto t = gpu::time_d2d_memcpy(bytes, static_cast<int>(st.max_iterations), 3);
  report(st, t, 2.0 * static_cast<double>(bytes), "median_TBps", 1e12);
  st.SetBytesProcessed(static_cast<std::int64_t>(st.iterations()) * 2 * bytes);
}
BENCHMARK(BM_D2D)->Arg(std::int64_t{2} << 30)->ArgName("bytes")->Iterations(30)->UseManualTime();

void BM_CopyKernel(benchmark::State& st) {
  if (!need_gpu(st)) return;
  const std::int64_t bytes = gpu::fit_device_buffer(st.range(0), 2);
  const auto t = gpu::time_copy_kernel(bytes, static_cast<int>(st.max_iterations), 3);
  report(st, t, 2.0 * static_cast<double>(bytes), "median_TBps", 1e12);
  st.SetBytesProcessed(static_cast<std::int64_t>(st.iterations()) * 2 * bytes);
}
BENCHMARK(BM_CopyKernel)->Arg(std::int64_t{2} << 30)->ArgName("bytes")->Iterations(30)->UseManualTime();

// range(0): 0 fp32, 1 fp64; range(1): chains per thread.
void BM_GpuFma(benchmark::State& st) {
  if (!need_gpu(st)) return;
  const auto t = gpu::time_fma(st.range(0) == 1, 0.05, static_cast<int>(st.max_iterations),
                               static_cast<int>(st.range(1)));
  report(st, t.seconds, t.flops, "median_TFLOPs", 1e12);
}
BENCHMARK(BM_GpuFma)
    ->ArgsProduct({{0, 1}, {4, 8, 16}})
    ->ArgNames({"fp64", "chains"})
    ->Iterations(10)
    ->UseManualTime();

void BM_Launch(benchmark::State& st) {
  if (!need_gpu(st)) return;
  const auto t = gpu::time_launches(static_cast<int>(st.range(0)), static_cast<int>(st.max_iterations));
  std::size_t i = 0;
  for (auto _ : st) st.SetIterationTime(t.per_launch[i++ % t.per_launch.size()]);
  st.counters["median_us"] = summarize(t.per_launch).median * 1e6;
  st.counters["sync_round_trip_us"] = summarize(t.round_trip).median * 1e6;
}
BENCHMARK(BM_Launch)->Arg(2000)->ArgName("batch")->Iterations(15)->UseManualTime();

}  // namespace
}  // namespace dtflop::probes

BENCHMARK_MAIN();
