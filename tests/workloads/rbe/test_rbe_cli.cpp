// `dtflop run rbe` end to end: the real executable on a CPU backend, and bad input (one line,
// exit status 2).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/cli/run_cli.hpp"
#include "workloads/rbe/backend.hpp"
#include "workloads/rbe/backend_counts.hpp"

namespace dtflop {
namespace {

TEST(RbeCli, RunsCpuSeqAndReportsTimesAndExactCounts) {
  const auto r = test::run_dtflop("run rbe --backend cpu-seq --grid 40x30 --kernel 5x3 --steps 20 --reps 3 --json");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["backend"], "cpu-seq");
  EXPECT_EQ(j["steps"], 20);
  EXPECT_EQ(j["repetitions"], 3);
  EXPECT_GT(j["measured_per_step"]["total"]["median"].get<double>(), 0);
  EXPECT_GT(j["measured_per_step"]["C"]["median"].get<double>(), 0);
  // A CPU step is all CPU work: the component cannot exceed the total.
  EXPECT_LE(j["measured_per_step"]["C"]["median"].get<double>(), j["measured_per_step"]["total"]["median"].get<double>());
  const auto step = rbe::cpu_seq_counts({40, 30, 5, 3}, rbe::Convolution::separable);
  EXPECT_EQ(j["counts_per_step"]["N_C"].get<std::int64_t>(), step.N_C);
  EXPECT_EQ(j["counts_per_repetition"]["N_C"].get<std::int64_t>(), 20 * step.N_C);
}

TEST(RbeCli, TablesForCpuParWithPredictionBesideEachComponent) {
  const auto r = test::run_dtflop("run rbe -b cpu-par --grid 64 --kernel 9 --steps 10 --threads 1 --machine " +
                                  test::source_path("docs/examples/h200.json"));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("Measured per step"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("on 1 thread"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("pred/meas"), std::string::npos) << r.out;
}

TEST(RbeCli, BadInputIsOneLineAndExitStatus2) {
  struct Case {
    const char* args;
    const char* says;
  };
  for (const Case c : {Case{"run rbe --backend gpu-x", "no backend 'gpu-x'"},
                       Case{"run rbe -b cpu-seq --grid 10x10 --kernel 11", "larger than the grid"},
                       Case{"run rbe -b cpu-seq --grid 0x10", "--grid"},
                       Case{"run rbe -b cuda-resident --layout 33x8", "multiple of 8"},
                       Case{"run rbe -b cpu-seq --layout 32x8", "cuda-resident, cuda-bands only"},
                       Case{"run rbe -b cpu-seq --steps 0", "--steps"},
                       Case{"run rbe -b cpu-seq --reps 1", "--reps"},
                       Case{"run rbe -b cpu-seq --machine /nonexistent/m.json", "m.json"},
                       Case{"run rbe -b cpu-seq --grid 64 --kernel 9 --timeline t.json", "runs on the CPU"},
                       Case{"run rbe -b cuda-seed --grid 64 --kernel 9 --no-cupti --timeline t.json",
                            "--timeline"}}) {
    SCOPED_TRACE(c.args);
    const auto r = test::run_dtflop(c.args);
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(test::count_lines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find(c.says), std::string::npos) << r.err;
  }
  if (!rbe::cuda_unavailable_reason().empty()) {
    const auto r = test::run_dtflop("run rbe -b cuda-resident --grid 100 --kernel 5 --steps 5");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(test::count_lines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find("cuda-resident: "), std::string::npos) << r.err;
  }
}

}  // namespace
}  // namespace dtflop
