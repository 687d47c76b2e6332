// `dtflop sar --check` and `dtflop predict sar` through the executable (no MPI needed).
#include <gtest/gtest.h>

#include <fstream>

#include <nlohmann/json.hpp>

#include "tests/cli/run_cli.hpp"
#include "tests/support/temp_dir.hpp"

namespace {

using dtflop::test::run_dtflop;
using dtflop::test::source_path;

const std::string kScenario = source_path("sar/scenarios/table-5.5.yaml");

TEST(SarCli, CheckNamesTheTeamAndItsTraffic) {
  const auto r = run_dtflop("sar --scenario '" + kScenario + "' --rule belief --interval 4 --check");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("3 helicopters, grid 180x80"), std::string::npos) << r.out;
  // 2 beliefs of 180 x 80 float32 cells every 4 steps.
  EXPECT_NE(r.out.find("0.5 messages, 2.88e+04 bytes"), std::string::npos) << r.out;
}

TEST(SarCli, ABadScenarioIsOneLineWithTheFieldAndExitTwo) {
  const auto dir = dtflop::test::fresh_test_dir("sar_cli");
  std::ifstream in(kScenario);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto at = text.find("speed: 0.12");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 11, "speed: 0");
  std::ofstream(dir / "bad.yaml") << text;
  const auto r = run_dtflop("sar --scenario '" + (dir / "bad.yaml").string() + "' --check");
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(dtflop::test::count_lines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("field helicopters.speed is 0; expected a finite number > 0"), std::string::npos) << r.err;
  EXPECT_EQ(run_dtflop("sar --scenario '" + kScenario + "' --cells 0x5 --check").status, 2);
  EXPECT_EQ(run_dtflop("sar --scenario '" + kScenario + "' --rule average --check").status, 2);
  EXPECT_EQ(run_dtflop("sar --scenario '" + kScenario + "' --seeds 5..2 --check").status, 2);
  EXPECT_EQ(run_dtflop("sar --scenario /nonexistent.yaml --check").status, 2);
}

TEST(SarCli, PredictSarCountsATeamStepAndPricesItsMessages) {
  auto r = run_dtflop("predict sar --scenario '" + kScenario + "' --rule observation --json");
  ASSERT_EQ(r.status, 0) << r.err;
  auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["steps_per_period"], 1);
  EXPECT_EQ(j["counts_per_period"]["net"]["net_messages"], 2);
  EXPECT_EQ(j["counts_per_period"]["net"]["net_bytes"], 96);
  // 2 messages of 48 bytes at 70 Mbit/s, 2 ms each.
  EXPECT_NEAR(j["link_delay_per_step"].get<double>(), 2 * 2e-3 + 8.0 * 96 / 70e6, 1e-12);
  // A profile without the ping-pong's figures prices the rest and says what it lacks.
  r = run_dtflop("predict sar --scenario '" + kScenario + "' --rule belief --interval 5 --machine '" +
                 source_path("docs/examples/h200.json") + "' --json");
  ASSERT_EQ(r.status, 0) << r.err;
  j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(j["prediction_per_step"]["net"].contains("missing")) << j.dump();
  EXPECT_GT(j["total_per_step"].get<double>(), 0);
}

}  // namespace
