// Scenario files: what is read, and every bad field named with its value and what was expected.
#include <gtest/gtest.h>

#include "model/errors.hpp"
#include "tune/scenario.hpp"

namespace dtflop::tune {
namespace {

const char* kGood = R"(
name: t
description: a test
workload: rbe
machine: m.json
calibrations: [c1.json]
deadline: 50ms
confidence: 0.9
space:
  backend: [cpu-seq, cpu-par]
  grid: [100x100, [200, 150]]
  kernel: {from: 5, to: 13, step: 4, square: true}
  threads: [1, 2]
fixed:
  problem-seed: 7
accuracy:
  area: [1, 1]
)";

std::string error_of(const std::string& yaml) {
  try {
    parse_scenario(yaml, "base", "test.yaml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Scenario, ReadsEveryField) {
  const Scenario s = parse_scenario(kGood, "base", "test.yaml");
  EXPECT_EQ(s.name, "t");
  EXPECT_EQ(s.workload, "rbe");
  EXPECT_EQ(s.machine, "base/m.json");
  ASSERT_EQ(s.calibrations.size(), 1u);
  EXPECT_EQ(s.calibrations[0], "base/c1.json");
  ASSERT_TRUE(s.deadline);
  EXPECT_DOUBLE_EQ(*s.deadline, 0.05);
  EXPECT_DOUBLE_EQ(s.confidence, 0.9);
  EXPECT_EQ(s.backends, (std::vector<std::string>{"cpu-seq", "cpu-par"}));
  ASSERT_EQ(s.axes.size(), 3u);
  EXPECT_EQ(s.axes[0].param, "grid");
  EXPECT_EQ(s.axes[0].values, (std::vector<std::string>{"100x100", "200x150"}));
  EXPECT_EQ(s.axes[1].values, (std::vector<std::string>{"5x5", "9x9", "13x13"}));
  EXPECT_EQ(s.axes[2].values, (std::vector<std::string>{"1", "2"}));
  EXPECT_EQ(s.fixed.at("problem-seed"), "7");
  EXPECT_EQ(s.accuracy["area"], nlohmann::json::array({1, 1}));
}

TEST(Scenario, NamesTheFieldTheValueAndWhatWasExpected) {
  const std::string base = "name: t\nworkload: rbe\nspace: {grid: [100x100]}\n";
  EXPECT_NE(error_of(base + "colour: red\n").find("colour: unknown field"), std::string::npos);
  EXPECT_NE(error_of(base + "deadline: soon\n").find("deadline"), std::string::npos);
  EXPECT_NE(error_of(base + "deadline: -1ms\n").find("deadline"), std::string::npos);
  EXPECT_NE(error_of(base + "confidence: 1.5\n").find("confidence: 1.5 is not a probability"), std::string::npos);
  EXPECT_NE(error_of("name: t\nworkload: rbe\nspace: {kernel: {from: 5, to: 9, step: 0}}\n").find("space.kernel.step"),
            std::string::npos);
  EXPECT_NE(error_of("name: t\nworkload: rbe\nspace: {kernel: {from: 9, to: 5, step: 1}}\n").find("space.kernel.to"),
            std::string::npos);
  EXPECT_NE(error_of("name: t\nworkload: rbe\nspace: {kernel: []}\n").find("space.kernel: an empty list"),
            std::string::npos);
  EXPECT_NE(error_of("name: t\nworkload: rbe\nspace: {kernel: [5, 5]}\n").find("listed twice"), std::string::npos);
  EXPECT_NE(error_of("name: t\nworkload: rbe\nspace: {a: {from: 1, to: 1e7, step: 1}}\n").find("more than"),
            std::string::npos);
  EXPECT_NE(error_of(base + "fixed: {grid: 5x5}\n").find("fixed.grid: also in space"), std::string::npos);
  EXPECT_NE(error_of("workload: rbe\nspace: {grid: [1x1]}\n").find("name: missing"), std::string::npos);
  EXPECT_NE(error_of("name: t\nworkload: rbe\n").find("space: missing"), std::string::npos);
  EXPECT_NE(error_of("name: [unclosed\n").find("not valid YAML"), std::string::npos);
  EXPECT_NE(error_of("- a list\n").find("expected a mapping"), std::string::npos);
  EXPECT_NE(error_of(base + "accuracy: 5\n").find("accuracy: expected a mapping"), std::string::npos);
  EXPECT_NE(error_of(base + "deadline: .nan\n").find("deadline"), std::string::npos);
  // Text that is not UTF-8 (found by the fuzz target: it reached a JSON serializer in a message).
  EXPECT_NE(error_of(base + "description: grid\xff\xff\n")
                .find("byte " + std::to_string(base.size() + 17) + " is not UTF-8"),
            std::string::npos);
  EXPECT_NE(error_of(base + "description: \xed\xa0\x80\n").find("not UTF-8"), std::string::npos);  // a surrogate
  EXPECT_EQ(error_of(base + "description: caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x9a\x81\n"), "");  // é € 🚁
}

TEST(Scenario, AFileIsReadWithinItsLimitAndAMissingOneIsNamed) {
  try {
    load_scenario("/nonexistent/scenario.yaml");
    FAIL() << "a missing file was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/scenario.yaml"), std::string::npos);
  }
}

TEST(Scenario, ShippedScenariosRead) {
  for (const char* f : {"sar-raft.yaml", "sar-drift-cpu.yaml", "sar-drift-gpu.yaml", "open-hole-plate.yaml",
                        "rail-1080p.yaml", "open-hole-plate-gpu.yaml"}) {
    const Scenario s = load_scenario(std::string(DTFLOP_SOURCE_DIR) + "/tune/scenarios/" + f);
    EXPECT_FALSE(s.axes.empty()) << f;
    EXPECT_TRUE(s.deadline) << f;
  }
}

}  // namespace
}  // namespace dtflop::tune
