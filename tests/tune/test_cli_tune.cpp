// `dtflop tune` end to end on this machine's CPU backends: a tuning that measures through the
// store and resumes without measuring again, its result run by `dtflop run --tuned`, ranking
// without measuring, and bad input (one line, exit 2, nothing overwritten).
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "calibrate/machine.hpp"
#include "model/json_io.hpp"
#include "model/profile.hpp"
#include "run_cli.hpp"
#include "tests/support/gpu.hpp"

namespace dtflop::test {
namespace {

namespace fs = std::filesystem;

class CliTune : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("dtflop_tune_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    // The example profile of a 2-vCPU host, as this machine's: predictions need not be good for
    // the tuning to work; the model strategy corrects each backend by what it measures.
    MachineProfile p = load_profile(source_path("docs/examples/vm-2vcpu.json"));
    p.identity = calib::this_machine();
    save_profile(p, dir_ / "here.json");
    write("s.yaml", R"(
name: small
workload: rbe
machine: here.json
deadline: 1s
space:
  backend: [cpu-seq, cpu-par]
  grid: [64x64, 80x80, 96x96]
  kernel: {from: 9, to: 21, step: 4, square: true}
  prediction: [separable, full]
  threads: [1]
accuracy: {area: [1, 1], time-step: 1, target-velocity: {x: [0.05, 0.01], y: [0, 0.01]}, likelihood-sigma: 0.03}
)");
  }
  void TearDown() override { fs::remove_all(dir_); }
  void write(const std::string& name, const std::string& text) { std::ofstream(dir_ / name) << text; }
  CliResult tune(const std::string& args) { return run_dtflop("tune " + args, dir_.string()); }
  fs::path dir_;
};

int lines_of(const fs::path& p) { return fs::exists(p) ? count_lines(slurp(p)) : 0; }

TEST_F(CliTune, MeasuresThroughTheStoreResumesAndItsChoiceRuns) {
  CliResult r = tune("--scenario s.yaml --budget 6 --reps 2 --warmup 0 --store st.jsonl -o tuned.json --json -q");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["verdicts"], "measured");
  EXPECT_LE(j["measured"].get<int>(), 6);
  EXPECT_GE(j["measured"].get<int>(), 4);  // one of each of the four groups at least
  EXPECT_EQ(j["measured_now"], j["measured"]);
  EXPECT_EQ(lines_of(dir_ / "st.jsonl"), j["measured_now"].get<int>());
  // 9 m per 30 m sigma: every grid resolves; kernels under the motion's reach are removed.
  EXPECT_GT(j["space"]["removed"]["kernel-mass"].get<int>(), 0);
  EXPECT_TRUE(j["meets_deadline"].get<bool>());
  ASSERT_TRUE(j.contains("chosen"));
  const double chosen = j["chosen"]["measured_seconds"].get<double>();
  for (const auto& x : j["runners_up"]) EXPECT_GE(x["measured_seconds"].get<double>(), chosen);
  EXPECT_FALSE(j["pareto_front"].empty());
  EXPECT_EQ(nlohmann::json::parse(slurp(dir_ / "tuned.json"))["backend"], j["backend"]);

  // The same tuning again measures nothing: every configuration it asks for is in the store.
  r = tune("--scenario s.yaml --budget 6 --reps 2 --warmup 0 --store st.jsonl --json -q");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["measured_now"], 0);
  EXPECT_EQ(lines_of(dir_ / "st.jsonl"), j["measured_now"].get<int>());

  // `run --tuned` runs the choice.
  r = run_dtflop("run rbe --tuned tuned.json --steps 1 --reps 2 --json", dir_.string());
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["backend"], j["backend"]);
}

TEST_F(CliTune, ReusesWhatASweepOfThisMachineMeasured) {
  write("two.yaml", R"(
name: two
workload: rbe
machine: here.json
space:
  backend: [cpu-seq]
  grid: [64x64, 96x96]
  kernel: [9x9]
  prediction: [full]
)");
  write("plan.json", R"({"description": "one", "configs": [{"grid": "96x96", "kernel": "9x9", "prediction": "full"}]})");
  CliResult r = run_dtflop("sweep rbe --backend cpu-seq --plan plan.json --store st.jsonl --reps 2 --warmup 0 -q",
                           dir_.string());
  ASSERT_EQ(r.status, 0) << r.err;
  r = tune("--scenario two.yaml --strategy exhaustive --store st.jsonl --reps 2 --warmup 0 --json -q");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["measured"], 2);
  EXPECT_EQ(j["measured_now"], 1);  // the sweep's configuration came from the store
  EXPECT_EQ(lines_of(dir_ / "st.jsonl"), 2);
}

TEST_F(CliTune, RanksWithoutMeasuringAndSaysTheVerdictsArePredictions) {
  const CliResult r = tune("--scenario s.yaml --no-measure");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("every verdict below is a prediction"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("Pareto front"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir_ / "small.samples.jsonl"));
}

TEST_F(CliTune, BadInputIsOneLineExitTwoAndNothingIsOverwritten) {
  const std::string scenario = slurp(dir_ / "s.yaml");
  auto bad = [&](const std::string& args, const std::string& says) {
    const CliResult r = tune(args);
    EXPECT_EQ(r.status, 2) << args << ": " << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << args << ": " << r.err;
    EXPECT_NE(r.err.find(says), std::string::npos) << args << ": " << r.err;
  };
  bad("--scenario s.yaml --budget 0", "--budget 0");
  bad("--scenario s.yaml --strategy annealing", "unknown strategy");
  bad("--scenario s.yaml --no-measure -o s.yaml", "s.yaml");
  EXPECT_EQ(slurp(dir_ / "s.yaml"), scenario);
  // Accuracy no configuration meets: which constraint removed what.
  write("strict.yaml", scenario.substr(0, scenario.find("accuracy:")) +
                           "accuracy: {area: [1, 1], time-step: 1, likelihood-sigma: 0.5, kernel-mass: 0.999999, "
                           "target-velocity: {x: [0.5, 0.2], y: [0, 0.2]}}\n");
  bad("--scenario strict.yaml --no-measure", "kernel-mass");
  write("field.yaml", scenario + "colour: red\n");
  bad("--scenario field.yaml --no-measure", "colour");
  // A profile of another machine while measuring here.
  fs::copy_file(source_path("docs/examples/h200.json"), dir_ / "h200.json");
  bad("--scenario s.yaml --machine h200.json", "--no-measure");
  // A store of another machine: one of this machine's samples, its CPU renamed.
  ASSERT_EQ(tune("--scenario s.yaml --budget 1 --reps 2 --warmup 0 --store mine.jsonl -q").status, 0);
  auto sample = nlohmann::json::parse(slurp(dir_ / "mine.jsonl"));
  sample["machine"]["cpu_model"] = "Another CPU";
  write("other.jsonl", sample.dump() + "\n");
  bad("--scenario s.yaml --budget 1 --store other.jsonl", "another --store");
  // Replaying another machine's store: it needs the store, which must be that machine's.
  bad("--scenario s.yaml --machine h200.json --no-measure --replay 5", "--store");
  bad("--scenario s.yaml --machine h200.json --no-measure --replay 5 --store absent.jsonl", "not a file");
  bad("--scenario s.yaml --machine h200.json --no-measure --replay 5 --store mine.jsonl", "another --store");
  // The machine's own store replayed without measuring: the one configuration it holds, the others
  // counted under `store`, nothing appended.
  const std::string mine = slurp(dir_ / "mine.jsonl");
  const CliResult replayed = tune("--scenario s.yaml --no-measure --replay 1 --replay-seeds 2 --store mine.jsonl -q");
  EXPECT_EQ(replayed.status, 0) << replayed.err;
  EXPECT_NE(replayed.out.find("replayed on the 1 measured configurations"), std::string::npos) << replayed.out;
  EXPECT_NE(replayed.out.find("removed by store"), std::string::npos) << replayed.out;
  EXPECT_EQ(slurp(dir_ / "mine.jsonl"), mine);
  if (!gpu_unavailable_reason().empty()) {  // a scenario for a backend this machine cannot run
    write("gpu.yaml", "name: g\nworkload: rbe\nmachine: here.json\nspace: {backend: [cuda-seed]}\n");
    bad("--scenario gpu.yaml", "cuda-seed");
  }
}

}  // namespace
}  // namespace dtflop::test
