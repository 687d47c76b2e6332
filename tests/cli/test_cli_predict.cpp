// `dtflop predict` end to end: the real executable, good and bad input.
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "cuda/device.hpp"
#include <nlohmann/json.hpp>

#include "model/calibration.hpp"
#include "model/json_io.hpp"
#include "model/uncertainty.hpp"
#include "model/predict.hpp"
#include "tests/cli/run_cli.hpp"
#include "tests/model/fixtures.hpp"
#include "workloads/rbe/backend.hpp"
#include "workloads/rbe/backend_counts.hpp"
#include "workloads/rbe/counts.hpp"
#include "workloads/workload.hpp"

namespace dtflop {
namespace {

class PredictCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("dtflop_predict_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
    profile_ = test::round_profile();
    save_profile(profile_, dir_ / "m.json");
    auto cpu_only = profile_;
    for (auto p : {Param::V_G_fp32, Param::V_G_fp64, Param::B_GG, Param::B_CG_pageable})
      cpu_only.erase(p);
    save_profile(cpu_only, dir_ / "cpu.json");
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string path(const char* f) const { return (dir_ / f).string(); }

  // A bad invocation: non-zero exit, nothing on stdout, one line on stderr containing `needle`.
  void expect_one_line_error(const std::string& args, const std::string& needle) {
    const auto r = test::run_dtflop(args);
    EXPECT_NE(r.status, 0) << args;
    EXPECT_EQ(test::count_lines(r.err), 1) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(needle), std::string::npos) << args << "\n" << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
  }

  std::filesystem::path dir_;
  MachineProfile profile_;
};

TEST_F(PredictCli, CountsOnlyWithoutMachineAreTheBackendsOwn) {
  const auto r = test::run_dtflop("predict rbe --backend cuda-seed --grid 100x80 --kernel 5x7 --json");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  const auto c = counts_from_json(j.at("counts"));
  // The counts a cuda-seed sample records (N_GR included), not a second formula.
  EXPECT_EQ(c, rbe::step_counts("cuda-seed", {100, 80, 5, 7}));
  EXPECT_GT(c.N_GR, 0);
  EXPECT_FALSE(j.contains("prediction"));
}

TEST_F(PredictCli, PredictionMatchesModelAndDeadline) {
  const auto r = test::run_dtflop("predict --machine " + path("m.json") +
                                  " rbe -b cuda-seed --grid 1000x1000 --kernel 33x33 --deadline 1s --json --variant seed");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  const auto expected = predict(profile_, rbe::step_counts("cuda-seed", {1000, 1000, 33, 33}), Variant::seed);
  EXPECT_DOUBLE_EQ(j.at("prediction").at("total").get<double>(), expected.total);
  EXPECT_DOUBLE_EQ(j.at("prediction").at("dt_CG").get<double>(), expected.dt_CG);
  EXPECT_TRUE(j.at("meets_deadline").get<bool>());  // 1.5 ms against 1 s: met even by a probe-only interval
  EXPECT_EQ(j.at("uncertainty").at("basis"), "probe-only");
  EXPECT_EQ(j.at("uncertainty").at("deadline_verdict").at("verdict"), "met");
  EXPECT_LT(j.at("uncertainty").at("interval").at("lo").get<double>(), expected.total);
  EXPECT_GT(j.at("uncertainty").at("interval").at("hi").get<double>(), expected.total);
  EXPECT_EQ(j.at("prediction").at("variant"), "seed");
  EXPECT_EQ(j.at("variant"), "seed");
}

TEST_F(PredictCli, DeadlineIsPrintedAndMissedDeadlineExitsThree) {
  // The round profile predicts ~1.5 ms per step of the pageable seed pipeline at 1000x1000.
  const std::string args = "predict --machine " + path("m.json") + " rbe -b cuda-seed --grid 1000x1000 --kernel 33x33";
  auto r = test::run_dtflop(args + " --deadline 1s");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("MET"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("dt_CG"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("90% interval"), std::string::npos) << r.out;
  r = test::run_dtflop(args + " --deadline 10us");
  EXPECT_EQ(r.status, 3) << r.err;  // documented: a missed deadline
  EXPECT_NE(r.out.find("MISSED"), std::string::npos) << r.out;
  // 2 ms is above the prediction but inside a probe-only profile's interval: neither.
  r = test::run_dtflop(args + " --deadline 2ms");
  EXPECT_EQ(r.status, 4) << r.err;  // documented: uncertain
  EXPECT_NE(r.out.find("UNCERTAIN"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("calibrate this backend on a machine of this class"), std::string::npos) << r.out;
}

TEST_F(PredictCli, AnUncertainVerdictOfACalibratedPredictionDoesNotAskForACalibration) {
  auto m = profile_;
  Parameter fitted = m.get(Param::B_CG_pageable);
  fitted.provenance = Provenance::fitted;
  m.set(Param::B_CG_pageable, fitted);
  m.metadata["fit_cv_rms_log"] = "0.1";
  save_profile(m, dir_ / "fitted.json");
  const std::string args = "predict --machine " + path("fitted.json") + " rbe -b cuda-seed --grid 1000x1000 --kernel 33x33";
  auto r = test::run_dtflop(args + " --json");
  ASSERT_EQ(r.status, 0) << r.err;
  const double t = nlohmann::json::parse(r.out).at("prediction").at("total").get<double>();
  r = test::run_dtflop(args + " --deadline " + std::to_string(std::llround(1.05e6 * t)) + "us");  // within 0.1 of log time
  EXPECT_EQ(r.status, 4) << r.out << r.err;
  EXPECT_NE(r.out.find("calibrated on this machine"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("UNCERTAIN"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("calibrate this backend"), std::string::npos) << r.out;
}

TEST_F(PredictCli, ChosenVariantOfAFittedProfileIsUsed) {
  auto m = profile_;
  m.metadata["model_variant"] = "latency";
  save_profile(m, dir_ / "fitted.json");
  const auto r = test::run_dtflop("predict --machine " + path("fitted.json") + " rbe -b cuda-seed --json");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("variant"), "latency");
  const auto expected = predict(m, rbe::step_counts("cuda-seed", {1000, 1000, 33, 33}), Variant::latency);
  EXPECT_DOUBLE_EQ(j.at("prediction").at("total").get<double>(), expected.total);
}

TEST_F(PredictCli, MissingFittedParameterFallsBackAndSaysSo) {
  // A profile only probes made has no K_CW: cpu-par predicts with the richest variant it supports.
  auto probed = profile_;
  probed.erase(Param::K_CW);
  save_profile(probed, dir_ / "probed.json");
  const auto r = test::run_dtflop("predict --machine " + path("probed.json") + " rbe -b cpu-par --json");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("variant"), "latency");
  EXPECT_NE(j.at("variant_fallback").get<std::string>().find("K_CW"), std::string::npos);
  EXPECT_NE(r.err.find("K_CW"), std::string::npos) << r.err;
  EXPECT_EQ(test::count_lines(r.err), 1) << r.err;
}

TEST_F(PredictCli, ACalibrationCarriedToAnotherMachineIsAppliedToItsProbes) {
  Calibration c;
  c.workload = "rbe";
  c.backend = "cuda-seed";
  c.variant = Variant::seed;
  c.fitted_on = profile_.identity;
  c.fitted_on.gpu_name = "Source GPU";
  CalibrationFactor b;  // the backend's copies reach half the probed pageable bandwidth
  b.id = Param::B_CG_pageable;
  b.relative = true;
  b.factor = 0.5;
  b.value = 1;
  c.factors = {b};
  c.fit_error = {50, 0.02, 0.05, 0.03, "test"};
  save_calibration(c, dir_ / "cal.json");
  const std::string args = "predict --machine " + path("m.json") + " --calibration " + path("cal.json") +
                           " rbe -b cuda-seed --grid 1000x1000 --kernel 33x33 --json";
  const auto r = test::run_dtflop(args);
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  auto m = profile_;
  m.set(Param::B_CG_pageable, Parameter{0.5 * profile_.get(Param::B_CG_pageable).value, Provenance::fitted, {}, {}, {}});
  const auto expected = predict(m, rbe::step_counts("cuda-seed", {1000, 1000, 33, 33}), Variant::seed);
  EXPECT_DOUBLE_EQ(j.at("prediction").at("total").get<double>(), expected.total);
  EXPECT_EQ(j.at("uncertainty").at("basis"), "transferred");
  EXPECT_EQ(j.at("uncertainty").at("calibrated_on"), "Source GPU");
  // The calibration's own error and cuda-seed's measured error of carried calibrations (0.24,
  // workloads/rbe/workload.cpp), in quadrature.
  EXPECT_NEAR(j.at("uncertainty").at("basis_error").at("sigma_log").get<double>(), std::hypot(0.03, 0.24), 1e-12);
  EXPECT_NE(j.at("uncertainty").at("basis_error").at("source").get<std::string>().find("cuda-seed's calibrations carried"),
            std::string::npos);
  // Another backend, or a fitted target profile: one line, exit 2.
  expect_one_line_error("predict --machine " + path("m.json") + " --calibration " + path("cal.json") + " rbe -b cpu-seq",
                        "is of rbe on cuda-seed");
  auto fitted = profile_;
  fitted.set(Param::B_GG, Parameter{1e12, Provenance::fitted, {}, {}, {}});
  save_profile(fitted, dir_ / "fitted.json");
  expect_one_line_error("predict --machine " + path("fitted.json") + " --calibration " + path("cal.json") +
                            " rbe -b cuda-seed",
                        "probe profile");
}

// Every profile docs/examples ships predicts every backend of every workload its machine can run
// (a GPU backend needs a profile with a GPU), with an interval, from the probes alone.
TEST_F(PredictCli, EveryExampleProfilePredictsEveryBackendItsMachineCanRun) {
  int profiles = 0;
  for (const auto& e : std::filesystem::directory_iterator(test::source_path("docs/examples"))) {
    if (e.path().extension() != ".json") continue;
    ++profiles;
    const MachineProfile m = load_profile(e.path());
    for (const workload::Workload* w : workload::all())
      for (const auto& b : w->backends()) {
        const std::string args = "predict --machine " + e.path().string() + " " + std::string(w->name()) + " -b " +
                                 b->name() + " --json";
        const auto r = test::run_dtflop(args);
        if (b->needs_gpu() && m.identity.gpu_name.empty()) {
          EXPECT_EQ(r.status, 2) << args;  // no GPU to predict for: bad input, said so
          continue;
        }
        if (m.find(Param::B_net) == nullptr && w->name() == std::string_view("sar-net")) {
          EXPECT_EQ(r.status, 2) << args;  // a profile probed without net-mpi cannot price messages
          EXPECT_NE(r.err.find("lacks B_net"), std::string::npos) << r.err;
          continue;
        }
        ASSERT_EQ(r.status, 0) << args << "\n" << r.err;
        const auto j = nlohmann::json::parse(r.out);
        EXPECT_GT(j.at("prediction").at("total").get<double>(), 0) << args;
        EXPECT_EQ(j.at("uncertainty").at("basis"), "probe-only") << args;
      }
  }
  EXPECT_GE(profiles, 3);  // a CPU-only machine, the H100 and the H200
}

// `run` applies a calibration as `predict` does, and says whether the measured time fell inside
// the stated interval.
TEST_F(PredictCli, RunAppliesACalibrationToItsPrediction) {
  Calibration c;
  c.workload = "rbe";
  c.backend = "cpu-seq";
  c.variant = Variant::seed;
  c.fitted_on = profile_.identity;
  c.fitted_on.cpu_model = "Source CPU";
  CalibrationFactor v;  // the taps run at a tenth of the probed rate
  v.id = Param::V_C1_fp64;
  v.relative = true;
  v.factor = 0.1;
  v.value = 1;
  c.factors = {v};
  c.fit_error = {50, 0.02, 0.05, 0.03, "test"};
  save_calibration(c, dir_ / "cal.json");
  const auto r = test::run_dtflop("run --machine " + path("m.json") + " --calibration " + path("cal.json") +
                                  " rbe -b cpu-seq --grid 40x30 --kernel 5x5 --steps 2 --reps 2 --warmup 0 --json");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("uncertainty").at("basis"), "transferred");
  EXPECT_TRUE(j.at("measured_within_interval").is_boolean());
  auto m = profile_;
  m.set(Param::V_C1_fp64, Parameter{0.1 * profile_.get(Param::V_C1_fp64).value, Provenance::fitted, {}, {}, {}});
  const auto counts = counts_from_json(j.at("counts_per_repetition"));
  EXPECT_DOUBLE_EQ(j.at("prediction_per_repetition").at("total").get<double>(), predict(m, counts, Variant::seed).total);
}

TEST_F(PredictCli, BadInputGivesOneLineAndExitStatusTwo) {
  expect_one_line_error("predict nosuch-workload --grid 10x10", "nosuch-workload");
  expect_one_line_error("predict", "rbe");
  expect_one_line_error("predict rbe --grid 10x10", "--backend");
  expect_one_line_error("predict rbe -b cuda-fast", "cuda-fast");
  expect_one_line_error("predict rbe -b cuda-seed --grid 0x10", "--grid");
  expect_one_line_error("predict rbe -b cuda-seed --grid -5x10", "--grid");
  expect_one_line_error("predict rbe -b cuda-seed --grid 100000000x100000000", "--grid");
  expect_one_line_error("predict rbe -b cuda-seed --grid 10x10 --kernel 33x33", "larger than the grid");
  expect_one_line_error("predict rbe -b cuda-seed --grid banana", "--grid");
  expect_one_line_error("predict rbe -b cuda-seed --gird 10x10", "--gird");
  expect_one_line_error("predict rbe -b cpu-seq --layout 32x8", "cuda-resident");
  expect_one_line_error("predict rbe -b cuda-seed --host-memory shared", "--host-memory");
  expect_one_line_error("predict --machine " + path("cpu.json") + " rbe -b cuda-seed", "V_G_fp32");
  expect_one_line_error("predict --machine " + path("absent.json") + " rbe -b cuda-seed", "absent.json");
  expect_one_line_error("predict rbe -b cuda-seed --deadline 1ms", "--machine");
  expect_one_line_error("predict --machine " + path("m.json") + " rbe -b cuda-seed --deadline soon", "--deadline");
  expect_one_line_error("predict --machine " + path("m.json") + " rbe -b cuda-seed --variant magic", "--variant");
  for (const char* args : {"predict rbe -b cuda-seed --grid 0x10", "predict rbe --gird 3", "predict"})
    EXPECT_EQ(test::run_dtflop(args).status, 2) << args;
}

TEST_F(PredictCli, CudaResidentWavesOnTheProfilesMultiprocessors) {
  // 1000 x 1000, k33, 32x8x8: 512 blocks. A profile of 100 multiprocessors: 6 waves.
  auto m = profile_;
  m.identity.gpu_sms = 100;
  save_profile(m, dir_ / "sms.json");
  const std::string args = " rbe -b cuda-resident --grid 1000x1000 --kernel 33x33 --layout 32x8x8";
  auto r = test::run_dtflop("predict --machine " + path("sms.json") + args + " --json");
  ASSERT_EQ(r.status, 0) << r.err;
  auto j = nlohmann::json::parse(r.out);
  const auto expected = rbe::cuda_resident_counts({1000, 1000, 33, 33}, rbe::parse_layout("32x8x8"), 100);
  EXPECT_EQ(expected.waves, 6);
  EXPECT_EQ(counts_from_json(j.at("counts")), expected);
  EXPECT_DOUBLE_EQ(j.at("prediction").at("lat_wave").get<double>(), 6 * 2e-6);
  EXPECT_DOUBLE_EQ(j.at("prediction").at("lat_atomic").get<double>(), 512 * 5e-9);  // one per block
  // A profile that does not say: this machine's GPU, else 132.
  r = test::run_dtflop("predict --machine " + path("m.json") + args + " --json");
  ASSERT_EQ(r.status, 0) << r.err;
  j = nlohmann::json::parse(r.out);
  const int here = cuda::device_sms() > 0 ? cuda::device_sms() : rbe::kDefaultGpuSms;
  EXPECT_EQ(counts_from_json(j.at("counts")),
            rbe::cuda_resident_counts({1000, 1000, 33, 33}, rbe::parse_layout("32x8x8"), here));
}

TEST_F(PredictCli, HelpListsWorkloadsBackendsAndParameters) {
  auto r = test::run_dtflop("predict --help");
  EXPECT_EQ(r.status, 0);
  for (const workload::Workload* w : workload::all()) EXPECT_NE(r.out.find(std::string(w->name())), std::string::npos);
  r = test::run_dtflop("predict rbe --help");
  EXPECT_EQ(r.status, 0);
  for (const auto& b : workload::find("rbe").backends()) EXPECT_NE(r.out.find(b->name()), std::string::npos) << r.out;
  for (const auto& p : workload::find("rbe").params()) EXPECT_NE(r.out.find("--" + p.name), std::string::npos) << r.out;
}

}  // namespace
}  // namespace dtflop
