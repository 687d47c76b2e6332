// The README's main command end to end, in its quick mode: scripts/characterize.sh (which runs
// `dtflop characterize`) probes this machine, sweeps every workload on every backend it can run,
// fits, validates on held-out samples and writes the reports; every file is there and readable,
// the headline names them, and a second run resumes: it measures nothing again. CI runs it, so a
// broken main job fails CI.
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

namespace fs = std::filesystem;

nlohmann::json read_json(const fs::path& p) {
  EXPECT_TRUE(fs::exists(p)) << p;
  return nlohmann::json::parse(test::slurp(p));
}

int run_main_job(const fs::path& out, const fs::path& log, const fs::path& err) {
  const std::string cmd = test::source_path("scripts/characterize.sh") + " --quick --no-setup --dtflop " +
                          std::string(DTFLOP_BINARY_DIR) + "/dtflop " + out.string() + " >" + log.string() + " 2>" +
                          err.string();
  return std::system(cmd.c_str());
}

TEST(MainJob, CharacterizeQuickWritesTheReportsAndResumes) {
  const auto dir = test::fresh_test_dir("dtflop_main_job");
  const auto out = dir / "report";
  ASSERT_EQ(run_main_job(out, dir / "log", dir / "err"), 0) << test::slurp(dir / "err");
  const std::string log = test::slurp(dir / "log");

  const MachineProfile profile = load_profile(out / "machine.json");
  const bool gpu = profile.has(Param::V_G_fp32);
  EXPECT_TRUE(fs::exists(out / "machine-report" / "report.html"));
  EXPECT_NE(log.find("Machine report: " + (out / "machine-report" / "report.html").string()), std::string::npos) << log;
  int jobs = 0;
  for (const workload::Workload* w : workload::all()) {
    for (const auto& b : w->backends()) {
      const fs::path d = out / fmt::format("{}-{}", w->name(), b->name());
      // Not characterized: GPU backends without a GPU, and a backend the in-process protocol cannot
      // run (sar-net's mpi: an MPI team measures it).
      if ((b->needs_gpu() && !gpu) || (!b->needs_gpu() && !b->unavailable().empty())) {
        EXPECT_FALSE(fs::exists(d)) << d;
        continue;
      }
      ++jobs;
      // Fitted, validated on the held-out store, reported; the headline names the report.
      const MachineProfile fitted = load_profile(d / "fitted.json");
      EXPECT_TRUE(fitted.metadata.count("model_variant")) << d;
      const auto v = read_json(d / "validate.json");
      const auto& total = v.at("groups").at("all").at("total");
      EXPECT_GT(total.at("n").get<int>(), 0) << d;
      EXPECT_GE(total.at("max_rel").get<double>(), total.at("mean_rel").get<double>()) << d;
      EXPECT_TRUE(fs::exists(d / "report" / "report.html")) << d;
      EXPECT_NE(log.find((d / "report" / "report.html").string()), std::string::npos) << log;
      EXPECT_GT(test::count_lines(test::slurp(d / "held.jsonl")), 0) << d;
    }
  }
  EXPECT_GE(jobs, 2 * static_cast<int>(workload::all().size() - 1));  // two CPU backends of rbe and dct at least

  // Rerun: every store is complete, so nothing is measured again, and every done step is kept.
  std::vector<std::pair<fs::path, std::uintmax_t>> stores;
  for (const auto& e : fs::recursive_directory_iterator(out))
    if (e.path().extension() == ".jsonl") stores.emplace_back(e.path(), fs::file_size(e.path()));
  ASSERT_FALSE(stores.empty());
  ASSERT_EQ(run_main_job(out, dir / "log2", dir / "err2"), 0) << test::slurp(dir / "err2");
  for (const auto& [p, size] : stores) EXPECT_EQ(fs::file_size(p), size) << p;
  const std::string err2 = test::slurp(dir / "err2");
  EXPECT_NE(err2.find("done earlier"), std::string::npos) << err2;
  EXPECT_EQ(err2.find("per step, ETA"), std::string::npos) << "a resumed run measured again:\n" << err2;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace dtflop
