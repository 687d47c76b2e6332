// The Ceres fit on samples made from a known profile: it must find that profile again, give
// intervals that cover it, flag disagreement with the start profile, keep what the samples
// cannot determine, and refuse what it cannot do.
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "calibrate/fit.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "tests/calibrate/synthetic.hpp"
#include "workloads/rbe/backend_counts.hpp"

namespace dtflop::calib {
namespace {

// The start profile: every parameter off the truth by a known factor.
MachineProfile perturbed(const MachineProfile& truth, double factor) {
  MachineProfile m = truth;
  for (const auto& [p, v] : truth.params()) {
    Parameter q = v;
    q.value = v.value * factor;
    q.provenance = Provenance::probed;
    m.set(p, q);
  }
  return m;
}

const std::vector<Param> kSeedPipelineLatency = {Param::B_CG_pageable, Param::B_GC_pageable, Param::L_CG_pageable,
                                                 Param::L_GC_pageable, Param::B_GG, Param::V_C1_fp32,
                                                 Param::V_G_fp32, Param::L_launch, Param::B_GC_staged,
                                                 Param::S_GC_staged, Param::S_GC_flat};

TEST(CalibFit, RecoversTheTruthFromExactSamples) {
  const MachineProfile truth = test::round_profile();
  const auto samples = test::seed_pipeline_samples(truth, Variant::latency, 0.0);
  FitOptions o;
  o.variant = Variant::latency;
  const FitResult r = fit(samples, perturbed(truth, 1.3), o);
  EXPECT_EQ(r.samples, static_cast<int>(samples.size()));
  EXPECT_EQ(r.free_parameters, static_cast<int>(kSeedPipelineLatency.size()));
  EXPECT_LT(r.rms_relative, 1e-6);
  for (Param p : kSeedPipelineLatency) {
    const Parameter& f = r.profile.get(p);
    EXPECT_EQ(f.provenance, Provenance::fitted) << info(p).name;
    EXPECT_NEAR(f.value / truth.get(p).value, 1.0, 1e-4) << info(p).name;
  }
  // Parameters the samples do not exercise are left as they were.
  EXPECT_EQ(r.profile.get(Param::V_C1_fp64).provenance, Provenance::probed);
  EXPECT_DOUBLE_EQ(r.profile.get(Param::V_C1_fp64).value, 1.3 * truth.get(Param::V_C1_fp64).value);
  // 30% off is within the default flag ratio (1.5): nothing flagged.
  for (const auto& f : r.params) EXPECT_FALSE(f.flagged) << info(f.id).name;
}

TEST(CalibFit, NoisySamplesGiveIntervalsThatCoverTheTruth) {
  const MachineProfile truth = test::round_profile();
  const auto samples = test::seed_pipeline_samples(truth, Variant::latency, 0.02, 11);
  FitOptions o;
  o.variant = Variant::latency;
  // Probes 10% below the truth: inside the physical bounds (1.25x the probed bandwidths and rates).
  const FitResult r = fit(samples, perturbed(truth, 0.9), o);
  ASSERT_TRUE(r.covariance_ok) << r.covariance_note;
  EXPECT_EQ(r.at_physical_bounds, 0);
  EXPECT_GT(r.rms_relative, 0.001);
  EXPECT_LT(r.rms_relative, 0.05);
  int covered = 0;
  for (const auto& f : r.params) {
    ASSERT_TRUE(f.fitted) << info(f.id).name;
    ASSERT_TRUE(f.has_interval);
    EXPECT_LT(f.lo95, f.value);
    EXPECT_GT(f.hi95, f.value);
    const double t = truth.get(f.id).value;
    EXPECT_NEAR(f.value / t, 1.0, 0.15) << info(f.id).name;
    covered += f.lo95 <= t && t <= f.hi95;
    // The profile carries the interval's half-width.
    EXPECT_NEAR(*r.profile.get(f.id).uncertainty, (f.hi95 - f.lo95) / 2, 1e-12 * f.value);
  }
  // Eight 95% intervals: all but at most one should hold the truth.
  EXPECT_GE(covered, static_cast<int>(r.params.size()) - 1);
}

TEST(CalibFit, AFitAboveWhatTheProbesSawEndsOnItsBoundAndSaysSo) {
  // Probes at half the truth: no bandwidth or rate may exceed 1.25x its probe, so the fit stops
  // at 0.625x the truth and reports each such parameter, with the reason; latencies (probed at
  // half of theirs) are inside their 0.02x .. 100x range and are fitted.
  const MachineProfile truth = test::round_profile();
  const auto samples = test::seed_pipeline_samples(truth, Variant::latency, 0.0);
  FitOptions o;
  o.variant = Variant::latency;
  const FitResult r = fit(samples, perturbed(truth, 0.5), o);
  EXPECT_GT(r.at_physical_bounds, 0);
  for (const auto& f : r.params) {
    const auto unit = info(f.id).unit;
    if (unit == "B/s" || unit == "FLOP/s") {
      EXPECT_TRUE(f.at_physical_bound) << info(f.id).name;
      EXPECT_NEAR(f.value, 1.25 * 0.5 * truth.get(f.id).value, 1e-6 * f.value) << info(f.id).name;
      EXPECT_NE(f.note.find("physical range"), std::string::npos) << f.note;
    }
    if (unit == "s") {
      EXPECT_FALSE(f.at_physical_bound) << info(f.id).name;
    }
  }
}

TEST(CalibFit, LargeDisagreementWithTheProbedValueIsFlagged) {
  const MachineProfile truth = test::round_profile();
  const auto samples = test::seed_pipeline_samples(truth, Variant::latency, 0.0);
  MachineProfile start = perturbed(truth, 1.0);
  Parameter b = start.get(Param::B_CG_pageable);
  b.value *= 3;  // the probe saw three times the bandwidth the workload gets
  start.set(Param::B_CG_pageable, b);
  FitOptions o;
  o.variant = Variant::latency;
  const FitResult r = fit(samples, start, o);
  for (const auto& f : r.params) {
    if (f.id == Param::B_CG_pageable) {
      EXPECT_TRUE(f.flagged);
      EXPECT_NE(f.note.find("0.33x"), std::string::npos) << f.note;
      EXPECT_NEAR(f.value / truth.get(f.id).value, 1.0, 1e-4);
    } else {
      EXPECT_FALSE(f.flagged) << info(f.id).name;
    }
  }
}

TEST(CalibFit, HostTimedLapsAndTapFactorsLeaveTheRoundTripAndTheGpuRateAtTheProbe) {
  // cuda-seed's counts: two laps in each of its three device components beside five, two and three
  // copies and launches, and FLOPs that are all window taps but two a cell. The samples cannot
  // tell a lap's round trip from the latencies beside it, nor the GPU's rate from the taps'
  // factors: the fit keeps L_wait and V_G_fp32 at the probe's values (here 0.8x and 1.1x the
  // truth) and finds the rest against them, which predicts every sample as the truth does.
  MachineProfile truth = test::round_profile();
  truth.set(Param::K_GW, {6.0, Provenance::probed, {}, {}, ""});
  truth.set(Param::V_CS, {2e9, Provenance::probed, {}, {}, ""});
  std::mt19937_64 rng(5);
  std::vector<Sample> samples;
  for (std::int64_t ix : {5, 41, 97})
    for (std::int64_t iy : {3, 33, 129})
      for (std::int64_t n : {200, 700}) {
        const CostCounts c = rbe::cuda_seed_counts(rbe::Shape{n, n + 50, ix, iy}, HostMemory::pinned);
        samples.push_back(test::synthetic_sample(fmt::format("{}/{}/{}", n, ix, iy), c, truth, Variant::latency, 0.0,
                                                 rng));
      }
  MachineProfile start = perturbed(truth, 1.1);
  Parameter w = start.get(Param::L_wait);
  w.value = 0.8 * truth.get(Param::L_wait).value;
  start.set(Param::L_wait, w);
  FitOptions o;
  o.variant = Variant::latency;
  const FitResult r = fit(samples, start, o);
  EXPECT_LT(r.rms_relative, 2e-3);
  int kept = 0;
  for (const auto& f : r.params) {
    if (f.id == Param::L_wait || f.id == Param::V_G_fp32) {
      ++kept;
      EXPECT_TRUE(f.kept_at_probe) << info(f.id).name;
      EXPECT_FALSE(f.fitted) << info(f.id).name;
      EXPECT_NE(f.note.find("kept at the probe"), std::string::npos) << f.note;
      EXPECT_DOUBLE_EQ(r.profile.get(f.id).value, start.get(f.id).value) << info(f.id).name;
      EXPECT_EQ(r.profile.get(f.id).provenance, Provenance::probed) << info(f.id).name;
    } else {
      EXPECT_FALSE(f.kept_at_probe) << info(f.id).name;
    }
  }
  EXPECT_EQ(kept, 2);
  // The taps' factors against the probe's rate: their cost per FLOP is the truth's.
  for (Param k : {Param::K_GR, Param::K_GW})
    EXPECT_NEAR(r.profile.get(k).value / start.get(Param::V_G_fp32).value,
                truth.get(k).value / truth.get(Param::V_G_fp32).value,
                0.01 * truth.get(k).value / truth.get(Param::V_G_fp32).value)
        << info(k).name;
  // Without a lap in any sample, or with a wait outside the components, L_wait is fitted as before.
  std::vector<Sample> waits = samples;
  for (auto& s : waits) s.counts.host_waits = 1;
  for (const auto& f : fit(waits, start, o).params) EXPECT_FALSE(f.kept_at_probe && f.id == Param::L_wait);
}

TEST(CalibFit, TheRecordsPassBesideTheMatchingIsKeptAtTheProbe) {
  // DCT cuda's host work: a records' pass and a matching that both scale with the frame's dots. The
  // samples cannot tell a record step from a matching step, so the fit keeps L_record at its probe
  // (here 0.7x the truth) and L_match takes the rest, which predicts every sample as the truth does.
  MachineProfile truth = test::round_profile();
  truth.set(Param::L_match, {20e-9, Provenance::probed, {}, {}, ""});
  truth.set(Param::L_record, {5e-9, Provenance::probed, {}, {}, ""});
  std::mt19937_64 rng(9);
  auto frames = [&](bool matched) {
    std::vector<Sample> out;
    for (std::int64_t dots : {150, 400, 900, 1600}) {
      CostCounts c;
      c.P = 4;
      c.precision = Precision::fp32;
      c.record_steps = 5 * (dots + 20);
      c.match_steps = matched ? 2 * dots : 0;
      out.push_back(test::synthetic_sample(fmt::format("{}", dots), c, truth, Variant::latency, 0.0, rng));
    }
    return out;
  };
  MachineProfile start = truth;
  Parameter r = start.get(Param::L_record);
  r.value *= 0.7;
  start.set(Param::L_record, r);
  FitOptions o;
  o.variant = Variant::latency;
  const FitResult fitted = fit(frames(true), start, o);
  EXPECT_LT(fitted.rms_relative, 2e-2);
  bool kept = false;
  for (const auto& f : fitted.params)
    if (f.id == Param::L_record) {
      kept = f.kept_at_probe;
      EXPECT_NE(f.note.find("matching"), std::string::npos) << f.note;
    }
  EXPECT_TRUE(kept);
  EXPECT_DOUBLE_EQ(fitted.profile.get(Param::L_record).value, 3.5e-9);
  EXPECT_GT(fitted.profile.get(Param::L_match).value, 20e-9);  // the records' remaining time
  // Frames with no matching (none of the reference's dots found): the pass alone, fitted.
  for (const auto& f : fit(frames(false), start, o).params) EXPECT_FALSE(f.id == Param::L_record && f.kept_at_probe);
}

TEST(CalibFit, ParametersThatMoveNoPredictionAreKept) {
  // All-thread CPU work: the one-thread rate is listed as needed but never used.
  MachineProfile truth = test::round_profile();
  std::mt19937_64 rng(3);
  std::vector<Sample> samples;
  for (int i = 1; i <= 12; ++i) {
    CostCounts c;
    c.N_C = 1'000'000LL * i;
    c.cpu_threads = truth.identity.cpu_threads;
    samples.push_back(test::synthetic_sample("cpu" + std::to_string(i), c, truth, Variant::seed, 0.0, rng, "cpu-par"));
  }
  const MachineProfile start = perturbed(truth, 2.0);
  FitOptions o;
  o.variant = Variant::seed;
  const FitResult r = fit(samples, start, o);
  ASSERT_EQ(r.params.size(), 2u);
  for (const auto& f : r.params) {
    if (f.id == Param::V_C1_fp32) {
      EXPECT_FALSE(f.fitted);
      EXPECT_NE(f.note.find("not identifiable"), std::string::npos) << f.note;
      EXPECT_EQ(r.profile.get(f.id).provenance, Provenance::probed);
      EXPECT_DOUBLE_EQ(r.profile.get(f.id).value, start.get(f.id).value);
    } else {
      EXPECT_EQ(f.id, Param::V_C_fp32);
      EXPECT_TRUE(f.fitted);
      EXPECT_NEAR(f.value / truth.get(f.id).value, 1.0, 1e-6);
      EXPECT_TRUE(f.flagged);  // the start was 2x off
    }
  }
}

TEST(CalibFit, ExtendedStartsFromTheLatencyFitSoBothSidesOfAMaxAreFitted) {
  // Kernels memory-bound at small kernel sizes and compute-bound at large ones (2 TFLOP/s).
  MachineProfile truth = test::round_profile();
  truth.set(Param::V_G_fp32, Parameter{2e12, Provenance::user, {}, {}, {}});
  const auto samples = test::seed_pipeline_samples(truth, Variant::extended, 0.0);
  // The probe's FMA peak is so high that no kernel looks compute-bound from there.
  MachineProfile start = truth;
  start.set(Param::V_G_fp32, Parameter{500e12, Provenance::probed, {}, {}, {}});
  FitOptions o;
  o.variant = Variant::extended;
  const FitResult warm = fit(samples, start, o);
  EXPECT_NEAR(warm.profile.get(Param::V_G_fp32).value / 2e12, 1.0, 1e-3);
  EXPECT_NEAR(warm.profile.get(Param::B_GG).value / truth.get(Param::B_GG).value, 1.0, 1e-3);
  EXPECT_LT(warm.rms_relative, 1e-4);
  // Started at the probed values instead, V_G has no gradient and stays where it was.
  o.warm_start = false;
  const FitResult cold = fit(samples, start, o);
  for (const auto& f : cold.params)
    if (f.id == Param::V_G_fp32) {
      EXPECT_FALSE(f.fitted);
      EXPECT_DOUBLE_EQ(f.value, 500e12);
    }
  EXPECT_GT(cold.rms_relative, 10 * warm.rms_relative);
}

// Frames whose labelled pixels and histogram counts always come one to one (a pixel labelled is a
// pixel counted, as in 8-bit frames of one region): the samples fix L_label + L_hist, not each. With
// the prior each stays near its probe and has an interval; a parameter the samples do determine
// (L_scan, probed 1.5x off) still goes to the truth, and the prior costs the fit nothing it can see.
TEST(CalibFit, APriorKeepsWhatTheSamplesCannotSeparateAtItsProbe) {
  MachineProfile truth = test::round_profile();
  const std::vector<std::pair<Param, double>> steps = {{Param::L_label, 6e-9}, {Param::L_hist, 0.3e-9}, {Param::L_scan, 1.3e-9}};
  for (auto [p, v] : steps) truth.set(p, Parameter{v, Provenance::user, {}, {}, {}});
  std::mt19937_64 rng(5);
  std::vector<Sample> samples;
  for (int i = 0; i < 24; ++i) {
    CostCounts c;
    c.cpu_threads = 1;
    c.label_steps = 1'000'000LL * (1 + i % 6);
    c.hist_steps = c.label_steps;
    c.pixel_steps = c.label_steps + c.hist_steps + 700'000LL * (1 + i / 6);
    samples.push_back(test::synthetic_sample(fmt::format("frame{}", i), c, truth, Variant::latency, 0.02, rng, "cpu-seq"));
  }
  MachineProfile start = truth;
  // The probes: labelling 10% cheap, the histogram 3x dear (their sum the truth's: 5.4 + 0.9 ns),
  // the scan step 1.5x dear.
  for (auto [p, f] : {std::pair{Param::L_label, 0.9}, {Param::L_hist, 3.0}, {Param::L_scan, 1.5}})
    start.set(p, Parameter{truth.get(p).value * f, Provenance::probed, {}, {}, {}});
  FitOptions o;
  o.variant = Variant::latency;
  const FitResult plain = fit(samples, start, o);
  EXPECT_FALSE(plain.covariance_ok);  // the two steps' columns are one
  EXPECT_EQ(plain.prior_log_sigma, 0);
  // Given too few iterations to converge, the plain fit is solved again with the probes as a prior
  // (sigma 0.5), which holds the two steps' shared direction still, and says so.
  ASSERT_GE(plain.iterations, 4);
  FitOptions few = o;
  few.max_iterations = plain.iterations / 2;
  const FitResult fell = fit(samples, start, few);
  EXPECT_EQ(fell.prior_log_sigma, 0.5);
  EXPECT_NE(fell.termination.find("solved again with the probes as a prior"), std::string::npos) << fell.termination;
  EXPECT_TRUE(fell.covariance_ok) << fell.covariance_note;
  o.prior_log_sigma = 0.3;
  const FitResult with = fit(samples, start, o);
  ASSERT_TRUE(with.covariance_ok) << with.covariance_note;
  auto value = [](const FitResult& r, Param p) { return r.profile.get(p).value; };
  // Near the probes, not pushed apart to explain the noise.
  EXPECT_NEAR(value(with, Param::L_label) / start.get(Param::L_label).value, 1.0, 0.05);
  EXPECT_NEAR(value(with, Param::L_hist) / start.get(Param::L_hist).value, 1.0, 0.3);
  // What the samples fix: the sum, and the scan step, whose probe was 1.5x off.
  const double sum = value(with, Param::L_label) + value(with, Param::L_hist);
  EXPECT_NEAR(sum / 6.3e-9, 1.0, 0.03);
  EXPECT_NEAR(value(with, Param::L_scan) / 1.3e-9, 1.0, 0.05);
  EXPECT_NEAR(value(plain, Param::L_scan) / 1.3e-9, 1.0, 0.05);
  EXPECT_LT(with.rms_relative, 1.05 * plain.rms_relative);
  for (const auto& f : with.params) {
    EXPECT_TRUE(f.fitted) << info(f.id).name;
    EXPECT_TRUE(f.has_interval) << info(f.id).name;
    EXPECT_FALSE(f.at_physical_bound) << info(f.id).name;
  }
  // On exact samples the scatter is nil, so is the prior's weight: the fit is the plain one.
  std::vector<Sample> exact;
  for (const auto& s0 : samples) exact.push_back(test::synthetic_sample(s0.key, s0.counts, truth, Variant::latency, 0.0, rng, "cpu-seq"));
  const FitResult e = fit(exact, start, o);
  o.prior_log_sigma = 0;
  const FitResult e0 = fit(exact, start, o);
  for (auto [p, v] : steps) EXPECT_NEAR(value(e, p) / value(e0, p), 1.0, 1e-6) << info(p).name;
}

TEST(CalibFit, RefusesWhatItCannotDo) {
  const MachineProfile truth = test::round_profile();
  FitOptions o;
  o.variant = Variant::latency;
  EXPECT_THROW(fit({}, truth, o), InputError);
  auto samples = test::seed_pipeline_samples(truth, Variant::latency, 0.0);
  samples.resize(5);  // 5 samples, 11 parameters
  try {
    fit(samples, truth, o);
    FAIL() << "fitted 11 parameters to 5 samples";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("5 samples cannot determine 11 parameters"), std::string::npos) << e.what();
  }
  samples = test::seed_pipeline_samples(truth, Variant::latency, 0.0);
  o.max_iterations = 1;
  // Without a prior, a fit that does not converge is solved again with the probes as one (in 50
  // iterations at least): on exact samples the prior weighs nothing and the fit converges.
  EXPECT_EQ(fit(samples, perturbed(truth, 20), o).prior_log_sigma, 0.5);
  // With a prior asked for, there is no second solve: one iteration from 20x off is refused.
  o.prior_log_sigma = 0.5;
  try {
    fit(samples, perturbed(truth, 20), o);
    FAIL() << "one iteration from 20x off converged";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("did not converge"), std::string::npos) << e.what();
  }
}

TEST(CalibFit, CrossValidationPrefersTheVariantThatGeneratedTheData) {
  MachineProfile truth = test::round_profile();
  // Latencies that matter: 200 us per pageable copy, 50 us per launch.
  for (auto [p, v] : {std::pair{Param::L_CG_pageable, 200e-6}, {Param::L_GC_pageable, 200e-6}, {Param::L_launch, 50e-6}})
    truth.set(p, Parameter{v, Provenance::user, {}, {}, {}});
  const auto samples = test::seed_pipeline_samples(truth, Variant::latency, 0.01, 5);
  FitOptions o;
  const auto cv = cross_validate(samples, perturbed(truth, 1.2), o, all_variants(), 5, 1);
  ASSERT_EQ(cv.size(), all_variants().size());
  for (const auto& c : cv) {
    EXPECT_EQ(c.failed_folds, 0) << to_string(c.variant) << ": " << c.failure;
    EXPECT_EQ(c.held_out, static_cast<int>(samples.size()));
    EXPECT_EQ(c.fold_means.size(), 5u);
  }
  EXPECT_GT(cv[0].mean_rel, 5 * cv[1].mean_rel);  // seed cannot express the latencies
  EXPECT_LT(cv[1].mean_rel, 0.02);
  const VariantChoice choice = choose_variant(cv);
  EXPECT_EQ(choice.chosen, Variant::latency) << choice.reason;
  EXPECT_NE(choice.reason.find("5-fold"), std::string::npos);
  EXPECT_NE(choice.reason.find("seed"), std::string::npos);
}

// Two plans whose configurations run at different rates (a kind of configuration the machine runs
// 30% slower): random folds mix them and see a compromise; leaving a plan out sees the whole shift,
// which is what a held-out set of the other kind meets.
TEST(CalibFit, LeavingAPlanOutSeesWhatRandomFoldsAverageAway) {
  MachineProfile truth = test::round_profile();
  MachineProfile slower = truth;
  slower.set(Param::V_C_fp32, Parameter{0.7 * truth.get(Param::V_C_fp32).value, Provenance::user, {}, {}, {}});
  std::mt19937_64 rng(4);
  std::vector<Sample> samples;
  for (int i = 1; i <= 24; ++i) {
    CostCounts c;
    c.N_C = 1'000'000LL * i;
    c.cpu_threads = truth.identity.cpu_threads;
    Sample s = test::synthetic_sample(fmt::format("cpu{}", i), c, i % 2 ? truth : slower, Variant::seed, 0.01, rng, "cpu-par");
    s.plan = i % 2 ? "small-frames" : "large-frames";
    samples.push_back(s);
  }
  FitOptions o;
  o.variant = Variant::seed;
  EXPECT_EQ(plans_of(samples), (std::vector<std::string>{"small-frames", "large-frames"}));
  const CvResult by_plan = cross_validate_by_plan(samples, truth, o);
  EXPECT_EQ(by_plan.folds, 2);
  EXPECT_EQ(by_plan.failed_folds, 0) << by_plan.failure;
  EXPECT_EQ(by_plan.held_out, 24);
  // Fitted to one plan, the other is 30% (or 1/0.7 - 1 = 43%) off.
  EXPECT_NEAR(by_plan.rms_log, std::log(1 / 0.7), 0.03);
  const CvResult random = cross_validate(samples, truth, o, {Variant::seed}, 4, 1).front();
  EXPECT_LT(random.rms_log, 0.7 * by_plan.rms_log);
  EXPECT_NE(plan_error_figure(by_plan, 24).how.find("each of 2 plans"), std::string::npos);
  // One plan: nothing to leave out.
  for (auto& s : samples) s.plan = "one";
  EXPECT_THROW(cross_validate_by_plan(samples, truth, o), InputError);
}

TEST(CalibFit, CrossValidationNeedsEnoughSamples) {
  const MachineProfile truth = test::round_profile();
  auto samples = test::seed_pipeline_samples(truth, Variant::latency, 0.0);
  samples.resize(3);
  EXPECT_THROW(cross_validate(samples, truth, FitOptions{}, all_variants(), 5, 1), InputError);
  EXPECT_THROW(cross_validate(samples, truth, FitOptions{}, all_variants(), 1, 1), InputError);
  EXPECT_THROW(choose_variant({}), InputError);
}

// The measured components are the model's phases (model/terms.hpp): the same sums as the
// formulas written out here before the table of terms, and with the host waits they make the total.
TEST(CalibSample, PredictedComponentsAreThePhasesOfThePrediction) {
  CostCounts c;
  c.N_CG = 1'000'000;
  c.N_GC = 500'000;
  c.N_GG = 2'000'000;
  c.N_G = 1'000'000'000;
  c.N_GS = 300'000;
  c.N_C = 6'000'000;
  c.N_CC = 3'000'000;
  c.transfers_CG = 3;
  c.transfers_GC = 2;
  c.launches = 4;
  c.waves = 5;
  c.atomics = 100;
  c.host_waits = 2;
  c.cpu_syncs = 3;
  c.cpu_threads = 8;
  for (Variant v : all_variants()) {
    const Prediction p = predict(test::round_profile(), c, v);
    EXPECT_EQ(predicted(p, Component::total), p.total);
    EXPECT_NEAR(predicted(p, Component::CG), p.dt_CG + p.lat_CG, 1e-18) << to_string(v);
    EXPECT_NEAR(predicted(p, Component::GC), p.dt_GC + p.lat_GC, 1e-18) << to_string(v);
    EXPECT_NEAR(predicted(p, Component::G),
                (v == Variant::extended ? std::max(p.dt_GG, p.dt_G) : p.dt_GG + p.dt_G) + p.lat_launch + p.lat_wave +
                    p.lat_atomic + p.dt_GS,
                1e-18)
        << to_string(v);
    EXPECT_EQ(predicted(p, Component::C), p.dt_C) << to_string(v);
    double sum = p.lat_wait;
    for (Component k : {Component::CG, Component::GC, Component::G, Component::C}) sum += predicted(p, k);
    EXPECT_NEAR(sum, p.total, 1e-15 * p.total) << to_string(v);
  }
  EXPECT_EQ(phase(Component::total), std::nullopt);
  EXPECT_EQ(phase(Component::G), Phase::G);
}

}  // namespace
}  // namespace dtflop::calib

namespace dtflop::calib {
namespace {

// What a calibration is for: a backend that reaches the same share of each machine's probed
// figures on two machines is fitted on one and predicted exactly on the other from that one's
// probes alone.
TEST(CalibFit, ACalibrationCarriesABackendsEfficiencyToAnotherMachinesProbes) {
  const MachineProfile probe_a = perturbed(test::round_profile(), 1.0);
  // Machine B: twice the copy bandwidths, half the latencies, a faster GPU.
  MachineProfile probe_b = probe_a;
  probe_b.identity.gpu_name = "Other GPU";
  for (const auto& [p, v] : probe_a.params()) {
    Parameter q = v;
    const auto unit = info(p).unit;
    q.value = unit == "s" ? v.value / 2 : unit == "B/s" || unit == "FLOP/s" ? v.value * 2 : v.value;
    probe_b.set(p, q);
  }
  // The backend's truth on either machine: 70% of each probed bandwidth and rate, 1.5x each latency.
  auto truth_of = [](const MachineProfile& probe) {
    MachineProfile t = probe;
    for (const auto& [p, v] : probe.params()) {
      Parameter q = v;
      const auto unit = info(p).unit;
      q.value = unit == "s" ? v.value * 1.5 : unit == "B/s" || unit == "FLOP/s" ? v.value * 0.7 : v.value;
      t.set(p, q);
    }
    return t;
  };
  FitOptions o;
  o.variant = Variant::latency;
  const FitResult r = fit(test::seed_pipeline_samples(truth_of(probe_a), Variant::latency, 0.0), probe_a, o);
  const Calibration c = to_calibration(r, "rbe", "cuda-seed", {}, ErrorFigure{10, 0.01, 0.02, 0.01, "test"});
  for (const auto& f : c.factors) {
    if (f.fitted && info(f.id).unit != "B") {
      EXPECT_TRUE(f.relative) << info(f.id).name;
    }
  }
  const Applied a = apply_calibration(c, probe_b);
  EXPECT_EQ(a.basis, Basis::transferred);
  const MachineProfile truth_b = truth_of(probe_b);
  for (const auto& s : test::seed_pipeline_samples(truth_b, Variant::latency, 0.0, 3)) {
    const double want = predict(truth_b, s.counts, Variant::latency).total;
    EXPECT_NEAR(predict(a.profile, s.counts, Variant::latency).total / want, 1.0, 1e-3) << s.key;
  }
}

}  // namespace
}  // namespace dtflop::calib

namespace dtflop::calib {
namespace {

// What the repository ships holds no parameter outside its physical range: every calibration
// (its factors against the source machine's probes) and every fitted profile kept beside the probe
// profile it was fitted from.
// B_GS and L_atomic have probes (gpu-tiles, gpu-atomics): where the start profile holds their probed
// values, the fit is bounded by them as B_GG is by its probe; a profile without them (an older probe)
// leaves the generic ranges.
TEST(CalibBounds, TileFillsAndAtomicsAreBoundedByTheirProbes) {
  MachineProfile probed;
  probed.set(Param::B_GS, Parameter{3.2e12, Provenance::probed, {}, {}, {}});
  probed.set(Param::L_atomic, Parameter{8e-9, Provenance::probed, {}, {}, {}});
  const Bound gs = physical_bounds(Param::B_GS, probed, 3.2e12);
  EXPECT_DOUBLE_EQ(gs.hi, kBoundAbove * 3.2e12);
  EXPECT_DOUBLE_EQ(gs.lo, 1e-4 * 3.2e12);
  const Bound at = physical_bounds(Param::L_atomic, probed, 8e-9);
  EXPECT_DOUBLE_EQ(at.lo, 0.02 * 8e-9);
  EXPECT_DOUBLE_EQ(at.hi, 100 * 8e-9);
  const MachineProfile none;
  EXPECT_DOUBLE_EQ(physical_bounds(Param::B_GS, none, 1e12).hi, 1e18);  // a million-fold of the start
  EXPECT_DOUBLE_EQ(physical_bounds(Param::L_atomic, none, 1e-5).lo, 1e-10);
}

TEST(CalibBounds, ShippedCalibrationsAndFittedProfilesStayInTheirBounds) {
  namespace fs = std::filesystem;
  int calibrations = 0, profiles = 0;
  for (const auto& e : fs::recursive_directory_iterator(fs::path(DTFLOP_SOURCE_DIR) / "results")) {
    const std::string name = e.path().filename().string();
    if (name.size() > 9 && name.ends_with(".cal.json")) {
      ++calibrations;
      const Calibration c = load_calibration(e.path());
      MachineProfile source;
      for (const auto& f : c.factors)
        if (f.source_probed) source.set(f.id, Parameter{*f.source_probed, Provenance::probed, {}, {}, {}});
      for (const auto& f : c.factors) {
        if (!f.fitted) continue;
        const Bound b = physical_bounds(f.id, source, f.value);
        EXPECT_GE(f.value, b.lo * (1 - 1e-9)) << name << " " << info(f.id).name;
        EXPECT_LE(f.value, b.hi * (1 + 1e-9)) << name << " " << info(f.id).name;
      }
    }
    if (name.starts_with("fitted-") && name.ends_with(".json") && fs::exists(e.path().parent_path() / "probed.json")) {
      ++profiles;
      const MachineProfile fitted = load_profile(e.path());
      const MachineProfile probe = load_profile(e.path().parent_path() / "probed.json");
      for (const auto& [id, par] : fitted.params()) {
        if (par.provenance != Provenance::fitted) continue;
        const Bound b = physical_bounds(id, probe, par.value);
        EXPECT_GE(par.value, b.lo * (1 - 1e-9)) << e.path() << " " << info(id).name;
        EXPECT_LE(par.value, b.hi * (1 + 1e-9)) << e.path() << " " << info(id).name;
      }
    }
  }
  EXPECT_GE(calibrations, 8);  // results/portability/calibrations
  EXPECT_GE(profiles, 5);
}

}  // namespace
}  // namespace dtflop::calib
