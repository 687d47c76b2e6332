// The README's main command end to end, in its quick mode: scripts/characterize.sh probes this
// machine, predicts every workload on every backend it can run and measures one run of each, and
// every file of the report is there and readable. CI runs it, so a broken main job fails CI.
#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "model/json_io.hpp"
#include "tests/cli/run_cli.hpp"
#include "tests/support/temp_dir.hpp"
#include "workloads/workload.hpp"

namespace dtflop {
namespace {

nlohmann::json read_json(const std::filesystem::path& p) {
  EXPECT_TRUE(std::filesystem::exists(p)) << p;
  return nlohmann::json::parse(test::slurp(p));
}

TEST(MainJob, CharacterizeQuickWritesTheWholeReport) {
  const auto dir = test::fresh_test_dir("dtflop_main_job");
  const auto out = dir / "report";
  const std::string cmd = test::source_path("scripts/characterize.sh") + " --quick --no-setup --dtflop " +
                          std::string(DTFLOP_BINARY_DIR) + "/dtflop " + out.string() + " >" +
                          (dir / "log").string() + " 2>&1";
  const int raw = std::system(cmd.c_str());
  ASSERT_EQ(raw, 0) << test::slurp(dir / "log");

  const MachineProfile profile = load_profile(out / "machine.json");
  const bool gpu = profile.has(Param::V_G_fp32);
  int predicted = 0, runs = 0;
  for (const workload::Workload* w : workload::all()) {
    for (const auto& b : w->backends()) {
      const auto stem = fmt::format("predict-{}-{}", w->name(), b->name());
      if (b->needs_gpu() && !gpu) {
        EXPECT_FALSE(std::filesystem::exists(out / (stem + ".json"))) << stem;
        continue;
      }
      const auto j = read_json(out / (stem + ".json"));
      // Every prediction is made, on a profile only probes made (a fallback variant where needed).
      EXPECT_GT(j.at("prediction").at("total").get<double>(), 0) << stem;
      EXPECT_GT(std::filesystem::file_size(out / (stem + ".txt")), 0u) << stem;
      ++predicted;
    }
    const std::string backend = gpu ? (w->name() == "rbe" ? "cuda-resident" : "cuda") : "cpu-par";
    const auto j = read_json(out / fmt::format("run-{}-{}.json", w->name(), backend));
    EXPECT_GT(j.at("measured_per_step").at("total").at("median").get<double>(), 0);
    EXPECT_GT(j.at("prediction_per_repetition").at("total").get<double>(), 0);
    ++runs;
  }
  EXPECT_GE(predicted, 2 * static_cast<int>(workload::all().size()));  // two CPU backends of each at least
  EXPECT_EQ(runs, static_cast<int>(workload::all().size()));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace dtflop
