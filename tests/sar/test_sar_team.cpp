// `dtflop sar` as a team of MPI processes, end to end: 3 processes on however many cores there
// are (--oversubscribe), real messages, the lost-rank and bad-team paths. Each run takes about a
// second.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "tests/support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

struct Result {
  int status = -1;
  std::string err;
};

// mpirun (as root too, as CI runs) with `launch`, e.g. "-n 3 DTFLOP sar ..."; DTFLOP is replaced
// by the built executable.
Result mpirun(const fs::path& dir, std::string launch) {
  const std::string exe = std::string(DTFLOP_BINARY_DIR) + "/dtflop";
  for (std::size_t at; (at = launch.find("DTFLOP")) != std::string::npos;) launch.replace(at, 6, exe);
  const std::string cmd = fmt::format(
      "cd '{}' && OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_NUM_THREADS=1 "
      // Under the sanitizers (scripts/test.sh): OpenMPI's own allocations outlive MPI_Finalize, so
      // the leak check is left to the in-process tests (test_sar); everything else stays checked.
      "ASAN_OPTIONS=\"${{ASAN_OPTIONS:-}}:detect_leaks=0\" '{}' --oversubscribe {} "
      ">out.txt 2>err.txt",
      dir.string(), DTFLOP_MPIEXEC, launch);
  const int raw = std::system(cmd.c_str());
  return {WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, slurp(dir / "err.txt")};
}

std::string scenario(int helicopters, int nx, const std::string& rule, int interval = 5, int steps = 30) {
  std::string start;
  for (int i = 0; i < helicopters; ++i) start += fmt::format("    - [{}, -1.2, 1.5708]\n", -1.0 + 0.8 * i);
  return fmt::format(R"(name: ci
area: {{x: [-2, 2], y: [-1.5, 1.5], cells: [{}, 30]}}
time: {{step: 1.0, steps: {}}}
target:
  prior: {{mean: [-1, 0], sigma: [0.3, 0.2]}}
helicopters:
  start:
{}fusion: {{rule: {}, interval: {}}}
backend: cpu-par
)",
                     nx, steps, start, rule, interval);
}

void write(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

// Rows of a CSV as maps column -> text.
std::vector<std::map<std::string, std::string>> csv(const fs::path& p) {
  std::istringstream in(slurp(p));
  std::string line;
  std::getline(in, line);
  std::vector<std::string> head;
  for (std::stringstream h(line); std::getline(h, line, ',');) head.push_back(line);
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    std::map<std::string, std::string> r;
    std::stringstream c(line);
    for (const auto& name : head) std::getline(c, r[name], ',');
    rows.push_back(r);
  }
  return rows;
}

TEST(SarTeam, ThreeProcessesFuseTheirBeliefsOverMpi) {
  const fs::path dir = dtflop::test::fresh_test_dir("sar_team");
  write(dir / "s.yaml", scenario(3, 40, "belief", 5, 30));
  const Result r = mpirun(dir, "-n 3 DTFLOP sar --scenario s.yaml --out out --snapshots 0,30");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto h0 = csv(dir / "out/heli-0.csv"), h1 = csv(dir / "out/heli-1.csv"), h2 = csv(dir / "out/heli-2.csv");
  ASSERT_EQ(h0.size(), 30u);
  ASSERT_EQ(h2.size(), 30u);
  for (std::size_t k = 0; k < h0.size(); ++k) {
    // One raft: every process draws the same one.
    EXPECT_EQ(h0[k].at("raft_x"), h2[k].at("raft_x"));
    // Beliefs travelled: right after a fusion every helicopter holds the same belief.
    const bool fusion_step = (k + 1) % 5 == 0;
    EXPECT_EQ(h0[k].at("fused"), fusion_step ? "1" : "0") << "step " << k + 1;
    if (fusion_step) {
      EXPECT_EQ(h0[k].at("mean_x"), h1[k].at("mean_x")) << "step " << k + 1;
      EXPECT_EQ(h0[k].at("entropy"), h2[k].at("entropy")) << "step " << k + 1;
    }
    // The link's delay (2 beliefs of 40 x 30 float32 cells at 70 Mbit/s, 2 ms each) on fusion steps.
    const double delay = std::stod(h0[k].at("link_delay"));
    EXPECT_NEAR(delay, fusion_step ? 2 * 2e-3 + 8.0 * 2 * 40 * 30 * 4 / 70e6 : 0.0, 1e-9);
  }
  // Between fusions each helicopter has seen something else.
  EXPECT_NE(h0[2].at("mean_x") + h0[2].at("cov_xx"), h1[2].at("mean_x") + h1[2].at("cov_xx"));
  const auto summary = nlohmann::json::parse(slurp(dir / "out/summary.jsonl"));
  EXPECT_EQ(summary["helicopters"], 3);
  EXPECT_EQ(summary["rule"], "belief");
  EXPECT_EQ(summary["per_helicopter"].size(), 3u);
  EXPECT_EQ(summary["per_helicopter"][1]["fusions"], 6);
  EXPECT_EQ(csv(dir / "out/series.csv").size(), 30u);
#ifdef DTFLOP_IMAGE_IO
  EXPECT_TRUE(fs::exists(dir / "out/snapshot-000030.png"));
#endif
}

TEST(SarTeam, ObservationFusionGivesEveryHelicopterTheSameBeliefEveryStep) {
  const fs::path dir = dtflop::test::fresh_test_dir("sar_team");
  write(dir / "s.yaml", scenario(3, 40, "observation", 1, 20));
  const Result r = mpirun(dir, "-n 3 DTFLOP sar --scenario s.yaml --out out --backend cpu-seq");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto h0 = csv(dir / "out/heli-0.csv"), h2 = csv(dir / "out/heli-2.csv");
  ASSERT_EQ(h0.size(), 20u);
  for (std::size_t k = 0; k < h0.size(); ++k) {
    EXPECT_EQ(h0[k].at("mean_x"), h2[k].at("mean_x")) << "step " << k + 1;
    EXPECT_EQ(h0[k].at("cov_yy"), h2[k].at("cov_yy")) << "step " << k + 1;
    EXPECT_NE(h0[k].at("heli_x"), h2[k].at("heli_x"));
  }
}

TEST(SarTeam, ProcessesThatDisagreeOnTheGridAreRejected) {
  const fs::path dir = dtflop::test::fresh_test_dir("sar_team");
  write(dir / "a.yaml", scenario(3, 40, "belief"));
  write(dir / "b.yaml", scenario(3, 44, "belief"));
  const Result r = mpirun(dir, "-n 1 DTFLOP sar --scenario a.yaml --out out : -n 2 DTFLOP sar --scenario b.yaml --out out");
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("disagree on the scenario: rank 1 has a 44x30 grid, rank 0 a 40x30 grid"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "out/heli-0.csv"));
}

TEST(SarTeam, MoreHelicoptersThanProcessesIsBadInput) {
  const fs::path dir = dtflop::test::fresh_test_dir("sar_team");
  write(dir / "s.yaml", scenario(3, 40, "belief"));
  const Result r = mpirun(dir, "-n 2 DTFLOP sar --scenario s.yaml --out out");
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("has 3 helicopters but 2 processes were started; run `mpirun -n 3"), std::string::npos) << r.err;
}

TEST(SarTeam, ALostRankStopsTheOthersWhoSayWhichAndKeepTheirResults) {
  const fs::path dir = dtflop::test::fresh_test_dir("sar_team");
  write(dir / "s.yaml", scenario(3, 40, "belief", 5, 30));
  const Result r = mpirun(dir, "-n 3 DTFLOP sar --scenario s.yaml --out out --fail-at 2:10 --peer-timeout 20");
  EXPECT_NE(r.status, 0);
  // A survivor names the lost rank: alone when it was the only one missing (the usual case), or
  // among those it waited for when mpirun stopped the other survivor before it sent.
  const bool named = r.err.find("helicopter 2 (rank 2) was lost at step 10") != std::string::npos ||
                     r.err.find("waited for ranks 1, 2") != std::string::npos ||
                     r.err.find("waited for ranks 0, 2") != std::string::npos;
  EXPECT_TRUE(named) << r.err;
  EXPECT_NE(r.err.find("stops here and keeps its results in out/heli-"), std::string::npos) << r.err;
  // The survivors' records up to the loss.
  const auto h0 = csv(dir / "out/heli-0.csv");
  EXPECT_EQ(h0.size(), 9u);
  const auto h2 = csv(dir / "out/heli-2.csv");
  EXPECT_EQ(h2.size(), 9u);  // the lost one wrote what it had done
}

}  // namespace
