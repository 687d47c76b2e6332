// `dtflop probe` end to end: the executable, its files and its errors.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "model/json_io.hpp"
#include "tests/cli/run_cli.hpp"

namespace dtflop::test {
namespace {

TEST(ProbeCli, ListsTheProbes) {
  const auto r = run_dtflop("probe --list");
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* n : {"cpu-memory", "cpu-fma", "gpu-transfers", "gpu-memory", "gpu-fma", "gpu-launch"})
    EXPECT_NE(r.out.find(n), std::string::npos) << n;
}

TEST(ProbeCli, UnknownProbeIsOneLineAndExitTwo) {
  const auto r = run_dtflop("probe --only cpu-fma,warp-drive");
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("warp-drive"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("cpu-memory"), std::string::npos) << r.err;
}

TEST(ProbeCli, QuickWritesALoadableProfile) {
  const auto path = std::filesystem::temp_directory_path() /
                    ("dtflop_probe_cli_" + std::to_string(::getpid()) + ".json");
  const auto r = run_dtflop("probe --quick -o " + path.string());
  ASSERT_EQ(r.status, 0) << r.err;
  // The table on stdout, progress on stderr.
  EXPECT_NE(r.out.find("Model parameters"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("V_C_fp32"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("cpu-fma"), std::string::npos) << r.err;
  const MachineProfile p = load_profile(path);
  std::filesystem::remove(path);
  EXPECT_TRUE(p.has(Param::B_host));
  EXPECT_TRUE(p.has(Param::V_C_fp64));
  EXPECT_EQ(p.metadata.at("probe.effort"), "quick");
  if (p.identity.gpu_name.empty()) {
    for (const char* name : {"B_CG_pinned", "B_GC_pinned", "B_CG_pageable", "B_GC_pageable",
                             "L_CG_pinned", "L_GC_pinned", "L_CG_pageable", "L_GC_pageable",
                             "B_GG", "B_GG_copy", "V_G_fp32", "V_G_fp64", "L_launch"})
      EXPECT_FALSE(p.has(*param_from_name(name))) << name << " present without a GPU";
    EXPECT_NE(r.out.find("GPU: none"), std::string::npos) << r.out;
  }
}

TEST(ProbeCli, JsonIsTheProfile) {
  const auto r = run_dtflop("probe --only cpu-fma --json");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("schema"), "dtflop.machine-profile");
  const MachineProfile p = profile_from_json(j);
  EXPECT_TRUE(p.has(Param::V_C1_fp32));
  EXPECT_FALSE(p.has(Param::B_host)) << "cpu-memory was not asked for";
}

}  // namespace
}  // namespace dtflop::test
