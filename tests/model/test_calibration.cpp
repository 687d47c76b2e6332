// Calibrations carried between machines and the intervals predictions state, checked against
// values worked out by hand.
#include <cmath>

#include <gtest/gtest.h>

#include "model/calibration.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/uncertainty.hpp"
#include "tests/model/fixtures.hpp"

namespace dtflop {
namespace {

MachineProfile probed(MachineProfile m) {
  const MachineProfile given = m;
  for (const auto& [p, v] : given.params()) {
    Parameter q = v;
    q.provenance = Provenance::probed;
    m.set(p, q);
  }
  return m;
}

Calibration pinned_copy_calibration() {
  Calibration c;
  c.workload = "rbe";
  c.backend = "cuda-seed";
  c.match = {"host-memory=pinned"};
  c.variant = Variant::latency;
  c.fitted_on = test::round_profile().identity;
  // The backend reaches 80% of the probed pinned bandwidth; K_GR has no probe.
  CalibrationFactor b;
  b.id = Param::B_CG_pinned;
  b.relative = true;
  b.factor = 0.8;
  b.value = 40e9;
  b.source_probed = 50e9;
  b.log_sigma = 0.01;
  CalibrationFactor k;
  k.id = Param::K_GR;
  k.value = 3.0;
  c.factors = {b, k};
  c.fit_error = {40, 0.02, 0.05, 0.025, "5-fold cross-validation"};
  return c;
}

TEST(Calibration, RelativeFactorsScaleTheTargetsProbesAndAbsoluteOnesAreCarried) {
  MachineProfile target = probed(test::round_profile());
  target.identity.gpu_name = "Other GPU";
  target.set(Param::B_CG_pinned, Parameter{100e9, Provenance::probed, {}, {}, {}});
  const Applied a = apply_calibration(pinned_copy_calibration(), target);
  EXPECT_EQ(a.basis, Basis::transferred);
  EXPECT_DOUBLE_EQ(a.profile.get(Param::B_CG_pinned).value, 80e9);  // 0.8 x this machine's 100 GB/s
  EXPECT_EQ(a.profile.get(Param::B_CG_pinned).provenance, Provenance::fitted);
  EXPECT_DOUBLE_EQ(a.profile.get(Param::K_GR).value, 3.0);
  EXPECT_EQ(a.notes.size(), 1u);  // K_GR carried as it is, and said so
  // Everything else is the target's probe.
  EXPECT_DOUBLE_EQ(a.profile.get(Param::B_GG).value, target.get(Param::B_GG).value);
  EXPECT_EQ(a.profile.metadata.at(kChosenVariantKey), "latency");
}

TEST(Calibration, OnItsOwnMachineItIsCalibratedAndAProbeItLacksIsCarried) {
  MachineProfile target = probed(test::round_profile());
  target.erase(Param::B_CG_pinned);
  const Applied a = apply_calibration(pinned_copy_calibration(), target);
  EXPECT_EQ(a.basis, Basis::calibrated);
  EXPECT_DOUBLE_EQ(a.profile.get(Param::B_CG_pinned).value, 40e9);  // the source machine's value
  ASSERT_EQ(a.notes.size(), 1u);
  EXPECT_NE(a.notes[0].find("no probe of B_CG_pinned"), std::string::npos) << a.notes[0];
}

// Another probe of the same kind of machine (another lend of it, another day) is a transfer: the
// calibration's factors were fitted against one probe's figures, and the interval must allow for
// what differs between the two. A calibration that records no probe time stays calibrated there.
TEST(Calibration, AnotherProbeOfTheSameMachineIsATransfer) {
  Calibration c = pinned_copy_calibration();
  c.fitted_on.measured_at = "2026-11-28T21:22:04Z";
  MachineProfile target = probed(test::round_profile());
  target.identity.measured_at = c.fitted_on.measured_at;
  EXPECT_EQ(apply_calibration(c, target).basis, Basis::calibrated);
  target.identity.measured_at = "2026-11-28T21:29:21Z";
  const Applied a = apply_calibration(c, target);
  EXPECT_EQ(a.basis, Basis::transferred);
  ASSERT_FALSE(a.notes.empty());
  EXPECT_NE(a.notes[0].find("another probe of this kind of machine (2026-11-28T21:22:04Z"), std::string::npos)
      << a.notes[0];
  EXPECT_DOUBLE_EQ(a.profile.get(Param::B_CG_pinned).value, 0.8 * target.get(Param::B_CG_pinned).value);
  c.fitted_on.measured_at.clear();
  EXPECT_EQ(apply_calibration(c, target).basis, Basis::calibrated);
}

// A calibration fitted before gpu-mls (no V_GM factor) priced the MLS fields inside the kernels'
// FLOPs: applied to a probe that has V_GM, it leaves V_GM out, as it was fitted; one fitted with
// it carries it as any other factor (and so for gpu-centroid's L_GP).
TEST(Calibration, ACalibrationFittedWithoutACodeRateLeavesTheTargetsProbeOfItOut) {
  MachineProfile target = probed(test::round_profile());
  Calibration with = pinned_copy_calibration();
  // The target probes `id` at `probe`: a calibration without it leaves it out; one that carries it
  // as `factor` x its source's probe applies that factor to the target's probe.
  auto left_out_then_carried = [&](Param id, double probe, double factor) {
    SCOPED_TRACE(info(id).name);
    target.set(id, Parameter{probe, Provenance::probed, {}, {}, {}});
    EXPECT_FALSE(apply_calibration(pinned_copy_calibration(), target).profile.has(id));
    CalibrationFactor f;
    f.id = id;
    f.relative = true;
    f.factor = factor;
    f.value = factor * probe;
    f.source_probed = probe;
    with.factors.push_back(f);
    const Applied a = apply_calibration(with, target);
    ASSERT_TRUE(a.profile.has(id));
    EXPECT_DOUBLE_EQ(a.profile.get(id).value, factor * probe);
  };
  left_out_then_carried(Param::V_GM, 3e8, 1.2);
  // The same for gpu-centroid's L_GP: before it the centroids' classification was bytes in N_GG.
  left_out_then_carried(Param::L_GP, 6e-11, 1.25);
  // And for cpu-records' L_record: before it the records' pass rode on the matching's steps, so a
  // calibration without it is applied without the target's probe of it (no pass priced twice).
  left_out_then_carried(Param::L_record, 4e-9, 1.5);
  // And for gpu-frame-pass's L_GF: before it the labelling's passes were their bytes in N_GG.
  left_out_then_carried(Param::L_GF, 3e-12, 1.1);
  // And for cpu-pixel's kinds of step: a calibration fitted at one L_pixel a step is applied
  // without the target's L_label, L_hist and L_scan, so its pixel steps are priced as they were fitted.
  const Param kinds[] = {Param::L_label, Param::L_label_all, Param::L_hist,
                         Param::L_hist_all, Param::L_scan, Param::L_scan_all};
  for (Param q : kinds) target.set(q, Parameter{1e-9, Provenance::probed, {}, {}, {}});
  const Applied c = apply_calibration(with, target);
  for (Param q : kinds) EXPECT_FALSE(c.profile.has(q)) << info(q).name;
}

// A frame's fixed cost on several threads: a calibration fitted with the all-thread pixel kinds but
// no L_pass_all (its machine's probe found no fixed cost worth one) keeps the target's L_pass_all;
// one from before the kinds (no L_*_all) leaves it out, as its fit priced the passes' fixed part in
// the steps.
TEST(Calibration, AFramesFixedCostIsTheTargetsWhereTheSourceProbeFoundNone) {
  MachineProfile target = probed(test::round_profile());
  target.identity.gpu_name = "Other GPU";
  for (Param q : {Param::L_label_all, Param::L_hist_all, Param::L_scan_all})
    target.set(q, Parameter{1e-9, Provenance::probed, {}, {}, {}});
  target.set(Param::L_pass_all, Parameter{250e-6, Provenance::probed, {}, {}, {}});
  Calibration before = pinned_copy_calibration();
  before.workload = "dct";
  before.backend = "cpu-par";
  before.match = {};
  EXPECT_FALSE(apply_calibration(before, target).profile.has(Param::L_pass_all));
  Calibration kinds = before;
  for (Param q : {Param::L_label_all, Param::L_hist_all, Param::L_scan_all})
    kinds.factors.push_back(CalibrationFactor{.id = q, .relative = true, .factor = 0.5, .value = 0.5e-9,
                                              .source_probed = 1e-9});
  const Applied a = apply_calibration(kinds, target);
  ASSERT_TRUE(a.profile.has(Param::L_pass_all));
  EXPECT_DOUBLE_EQ(a.profile.get(Param::L_pass_all).value, 250e-6);
  EXPECT_DOUBLE_EQ(a.profile.get(Param::L_label_all).value, 0.5e-9);
  // Without two of the three kinds it is a calibration from before them: left out.
  kinds.factors.resize(kinds.factors.size() - 2);
  EXPECT_FALSE(apply_calibration(kinds, target).profile.has(Param::L_pass_all));
}

TEST(Calibration, RefusesAFittedTargetAndAGpuCalibrationForAMachineWithoutOne) {
  MachineProfile fitted = probed(test::round_profile());
  fitted.set(Param::B_GG, Parameter{1e12, Provenance::fitted, {}, {}, {}});
  EXPECT_THROW(apply_calibration(pinned_copy_calibration(), fitted), InputError);
  MachineProfile cpu_only = probed(test::round_profile());
  cpu_only.identity.gpu_name.clear();
  try {
    apply_calibration(pinned_copy_calibration(), cpu_only);
    FAIL() << "a GPU calibration applied to a machine without a GPU";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("has no GPU"), std::string::npos) << e.what();
  }
}

TEST(Calibration, JsonRoundTripsAndBadFieldsAreNamed) {
  Calibration c = pinned_copy_calibration();
  c.transfer_error = ErrorFigure{50, 0.04, 0.1, 0.05, "held-out"};
  c.transfer_measured_on = "Other";
  const Calibration back = calibration_from_json(to_json(c));
  EXPECT_EQ(back.workload, "rbe");
  EXPECT_EQ(back.backend, "cuda-seed");
  EXPECT_EQ(back.match, c.match);
  EXPECT_EQ(back.variant, Variant::latency);
  EXPECT_EQ(back.fitted_on.gpu_name, "Test GPU");
  ASSERT_EQ(back.factors.size(), 2u);
  ASSERT_NE(back.find(Param::B_CG_pinned), nullptr);
  EXPECT_TRUE(back.find(Param::B_CG_pinned)->relative);
  EXPECT_DOUBLE_EQ(back.find(Param::B_CG_pinned)->factor, 0.8);
  EXPECT_FALSE(back.find(Param::K_GR)->relative);
  EXPECT_DOUBLE_EQ(back.fit_error.rms_log, 0.025);
  ASSERT_TRUE(back.transfer_error.has_value());
  EXPECT_DOUBLE_EQ(back.transfer_error->rms_log, 0.05);
  // No drift recorded: none written, none read, and the interval's sigma is the rms alone.
  EXPECT_FALSE(to_json(c)["fit_error"].contains("round_log_sd"));
  EXPECT_DOUBLE_EQ(back.fit_error.round_log_sd, 0);
  EXPECT_DOUBLE_EQ(back.fit_error.sigma(), 0.025);
  // A fit's drift between its rounds travels with it and widens the interval in quadrature.
  Calibration drifted = c;
  drifted.fit_error.round_log_sd = 0.04;
  drifted.fit_error.round_configs = 88;
  const Calibration d = calibration_from_json(to_json(drifted));
  EXPECT_DOUBLE_EQ(d.fit_error.round_log_sd, 0.04);
  EXPECT_EQ(d.fit_error.round_configs, 88);
  EXPECT_DOUBLE_EQ(d.fit_error.sigma(), std::hypot(0.025, 0.04));

  auto message = [](nlohmann::json j) {
    try {
      calibration_from_json(j);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  nlohmann::json j = to_json(c);
  j["factors"]["B_XX"] = j["factors"]["K_GR"];
  EXPECT_NE(message(j).find("factors.B_XX"), std::string::npos) << message(j);
  j = to_json(c);
  j["factors"]["K_GR"]["value"] = -1;
  EXPECT_NE(message(j).find("factors.K_GR.value"), std::string::npos) << message(j);
  j = to_json(c);
  j["schema"] = kProfileSchemaName;
  EXPECT_NE(message(j).find("schema"), std::string::npos) << message(j);
  j = to_json(c);
  j["fit_error"]["rms_log"] = "big";
  EXPECT_NE(message(j).find("fit_error.rms_log"), std::string::npos) << message(j);
}

CostCounts one_pinned_copy() {
  CostCounts c;
  c.P = 4;
  c.N_CG = 250'000'000;  // 1 GB: 20 ms at the round profile's 50 GB/s
  c.host_memory = HostMemory::pinned;
  return c;
}

TEST(Uncertainty, TheIntervalIsTheBasisErrorAroundThePrediction) {
  const MachineProfile m = probed(test::round_profile());
  const CostCounts c = one_pinned_copy();
  const Prediction p = predict(m, c, Variant::seed);
  ASSERT_DOUBLE_EQ(p.total, 0.02);
  const BasisError b = basis_of(m, c, Variant::seed);
  EXPECT_EQ(b.basis, Basis::probe_only);
  EXPECT_DOUBLE_EQ(b.sigma, kProbeOnlySigma.gpu);  // a copy to the device: a GPU backend's prediction
  const Interval iv = interval_of(p, m, c, b);
  EXPECT_DOUBLE_EQ(iv.sigma_params, 0);  // no parameter carries an uncertainty
  const double z = 1.6448536269514722;   // the 95% normal quantile: a central 90% interval
  EXPECT_NEAR(iv.lo, 0.02 * std::exp(-z * kProbeOnlySigma.gpu), 1e-12);
  EXPECT_NEAR(iv.hi, 0.02 * std::exp(z * kProbeOnlySigma.gpu), 1e-12);
  CostCounts cpu;
  cpu.N_C = 1000;
  EXPECT_DOUBLE_EQ(basis_of(m, cpu, Variant::seed).sigma, kProbeOnlySigma.cpu);
  EXPECT_NEAR(normal_quantile(0.95), z, 1e-12);
  // A backend that declares its own measured probe-only error gets it instead.
  BasisError own;
  own.sigma = 0.3;
  own.source = "measured";
  const BasisError declared = basis_of(m, cpu, Variant::seed, own);
  EXPECT_EQ(declared.basis, Basis::probe_only);
  EXPECT_DOUBLE_EQ(declared.sigma, 0.3);
  EXPECT_EQ(declared.source, "measured");
  // A fitted parameter makes the prediction calibrated, whatever the backend declares.
  MachineProfile fitted = m;
  fitted.set(Param::V_C1_fp32, Parameter{100e9, Provenance::fitted, {}, {}, {}});
  EXPECT_EQ(basis_of(fitted, cpu, Variant::seed, own).basis, Basis::calibrated);
}

TEST(Uncertainty, AParametersIntervalSpreadsTheTimeByItsElasticity) {
  MachineProfile m = probed(test::round_profile());
  // B_CG_pinned fitted to within +-10% (95%): log sigma = log(1.1) / 1.96; the time is inversely
  // proportional to it (elasticity -1), so the time's log sigma is the same.
  m.set(Param::B_CG_pinned, Parameter{50e9, Provenance::fitted, 5e9, {}, {}});
  m.metadata["fit_cv_rms_log"] = "0.03";
  const CostCounts c = one_pinned_copy();
  const Prediction p = predict(m, c, Variant::seed);
  const BasisError b = basis_of(m, c, Variant::seed);
  EXPECT_EQ(b.basis, Basis::calibrated);
  EXPECT_DOUBLE_EQ(b.sigma, 0.03);
  const Interval iv = interval_of(p, m, c, b);
  EXPECT_NEAR(iv.sigma_params, std::log(1.1) / 1.959963984540054, 1e-6);
  EXPECT_NEAR(iv.sigma, std::hypot(std::log(1.1) / 1.959963984540054, 0.03), 1e-6);
  // The fit's drift between rounds joins the cross-validated error in quadrature.
  m.metadata["fit_round_log_sd"] = "0.04";
  const BasisError drifted = basis_of(m, c, Variant::seed);
  EXPECT_NEAR(drifted.sigma, 0.05, 1e-12);
  EXPECT_NE(drifted.source.find("drift"), std::string::npos) << drifted.source;
}

TEST(Uncertainty, TheParametersTheProfilePricesWithAreTheOnesWhoseUncertaintyCounts) {
  // Pixel steps on two threads are priced at L_pixel_all where the profile has it: its fitted
  // interval, not L_pixel's, spreads the time, and it makes the basis "calibrated".
  MachineProfile m = probed(test::round_profile());
  m.set(Param::L_pixel, Parameter{2e-9, Provenance::probed, {}, {}, {}});
  m.set(Param::L_pixel_all, Parameter{1e-9, Provenance::fitted, 0.1e-9, {}, {}});
  m.metadata["fit_cv_rms_log"] = "0.03";
  CostCounts c;
  c.pixel_steps = 1'000'000;
  c.cpu_threads = 2;
  const Prediction p = predict(m, c, Variant::latency);
  EXPECT_NEAR(p.total, 1e-3, 1e-12);
  const BasisError b = basis_of(m, c, Variant::latency);
  EXPECT_EQ(b.basis, Basis::calibrated);
  EXPECT_NEAR(interval_of(p, m, c, b).sigma_params, std::log(1.1) / 1.959963984540054, 1e-6);
}

TEST(Uncertainty, TheDeadlineVerdictIsTheProbabilityOfMeetingIt) {
  Interval iv;
  iv.sigma = 0.1;
  // At the prediction itself: even odds.
  auto at = judge_deadline(1e-3, iv, 1e-3);
  EXPECT_NEAR(at.probability_met, 0.5, 1e-12);
  EXPECT_EQ(at.verdict, Verdict::uncertain);
  // Two sigma of log time above: P = Phi(2) = 0.977 >= 0.95, met.
  auto above = judge_deadline(1e-3, iv, 1e-3 * std::exp(0.2));
  EXPECT_NEAR(above.probability_met, 0.9772498680518208, 1e-9);
  EXPECT_EQ(above.verdict, Verdict::met);
  auto below = judge_deadline(1e-3, iv, 1e-3 * std::exp(-0.2));
  EXPECT_EQ(below.verdict, Verdict::missed);
  // One sigma above: 0.84, neither.
  EXPECT_EQ(judge_deadline(1e-3, iv, 1e-3 * std::exp(0.1)).verdict, Verdict::uncertain);
}

TEST(Uncertainty, ACarriedCalibrationAddsTheTransferError) {
  Calibration c = pinned_copy_calibration();
  const BasisError here = basis_of(c, Basis::calibrated);
  EXPECT_DOUBLE_EQ(here.sigma, 0.025);
  const BasisError there = basis_of(c, Basis::transferred);
  EXPECT_DOUBLE_EQ(there.sigma, std::hypot(0.025, kTransferSigma.gpu));  // a GPU backend's calibration
  // The backend's measured error of carried calibrations replaces kTransferSigma, in quadrature
  // with the calibration's own; on its own machine it plays no part.
  BasisError carried;
  carried.sigma = 0.34;
  carried.source = "measured error of this backend's carried calibrations";
  EXPECT_DOUBLE_EQ(basis_of(c, Basis::transferred, carried).sigma, std::hypot(0.025, 0.34));
  EXPECT_NE(basis_of(c, Basis::transferred, carried).source.find("carried calibrations"), std::string::npos);
  EXPECT_DOUBLE_EQ(basis_of(c, Basis::calibrated, carried).sigma, 0.025);
  c.transfer_error = ErrorFigure{50, 0.04, 0.1, 0.05, "held-out"};
  EXPECT_DOUBLE_EQ(basis_of(c, Basis::transferred).sigma, 0.05);  // measured: it replaces the default
  EXPECT_DOUBLE_EQ(basis_of(c, Basis::transferred, carried).sigma, 0.05);  // and the backend's figure
  // The fit's drift between its rounds is part of its own error, here and carried.
  c.transfer_error.reset();
  c.fit_error.round_log_sd = 0.04;
  c.fit_error.round_configs = 20;
  EXPECT_DOUBLE_EQ(basis_of(c, Basis::calibrated).sigma, std::hypot(0.025, 0.04));
  EXPECT_NE(basis_of(c, Basis::calibrated).source.find("drift"), std::string::npos);
  EXPECT_DOUBLE_EQ(basis_of(c, Basis::transferred, carried).sigma, std::hypot(std::hypot(0.025, 0.04), 0.34));
}

}  // namespace
}  // namespace dtflop
