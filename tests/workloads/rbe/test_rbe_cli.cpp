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
  const auto r = test::run_dtflop("run rbe --backend cpu-seq --grid 40x30 --kernel 5x3 --steps 20 --json");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["backend"], "cpu-seq");
  EXPECT_EQ(j["steps"], 20);
  EXPECT_GT(j["measured"]["step_median"].get<double>(), 0);
  EXPECT_GT(j["measured"]["components_median"]["predict"].get<double>(), 0);
  EXPECT_EQ(j["counts"]["N_C"].get<std::int64_t>(),
            rbe::cpu_seq_counts({40, 30, 5, 3}, rbe::Prediction::separable).N_C);
}

TEST(RbeCli, TablesForCpuPar) {
  const auto r = test::run_dtflop("run rbe -b cpu-par --grid 64 --kernel 9 --steps 10 --threads 1");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("Measured per step"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("on 1 thread"), std::string::npos) << r.out;
}

TEST(RbeCli, BadInputIsOneLineAndExitStatus2) {
  struct Case {
    const char* args;
    const char* says;
  };
  for (const Case c : {Case{"run rbe --backend gpu-x", "unknown RBE backend 'gpu-x'"},
                       Case{"run rbe -b cpu-seq --grid 10x10 --kernel 11", "larger than the grid"},
                       Case{"run rbe -b cpu-seq --grid 0x10", "--grid"},
                       Case{"run rbe -b cuda-resident --layout 33x8", "multiple of 8"},
                       Case{"run rbe -b cpu-seq --layout 32x8", "cuda-resident only"},
                       Case{"run rbe -b cpu-seq --steps 0", "at least 1"}}) {
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
