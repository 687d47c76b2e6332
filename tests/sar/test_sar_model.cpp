// The network term in the model: predicted as latency x messages + bytes / bandwidth, fitted by
// the calibration like every other term, and counted for a team step by sar::team_counts.
#include <gtest/gtest.h>

#include <random>

#include "calibrate/fit.hpp"
#include "model/predict.hpp"
#include "sar/counts.hpp"
#include "sar/world.hpp"
#include "workloads/rbe/summary_counts.hpp"
#include "sar/scenario.hpp"
#include "tests/calibrate/synthetic.hpp"

namespace dtflop::sar {
namespace {

MachineProfile truth() {
  MachineProfile m = test::round_profile();
  m.set(Param::L_net, {4e-6, Provenance::user, {}, {}, ""});
  m.set(Param::B_net, {3e9, Provenance::user, {}, {}, ""});
  return m;
}

TEST(SarModel, TheNetworkTermIsLatencyPerMessagePlusBytesOverBandwidth) {
  CostCounts c;
  c.net_messages = 6;
  c.net_bytes = 3'000'000;
  const Prediction p = predict(truth(), c, Variant::latency);
  EXPECT_DOUBLE_EQ(p.lat_net, 6 * 4e-6);
  EXPECT_DOUBLE_EQ(p.dt_net, 3e6 / 3e9);
  EXPECT_DOUBLE_EQ(p.total, p.lat_net + p.dt_net);
  // The seed variant has no latencies: bandwidth only.
  EXPECT_DOUBLE_EQ(predict(truth(), c, Variant::seed).total, 3e6 / 3e9);
  // A profile without the ping-pong's figures cannot price messages.
  EXPECT_THROW((void)predict(test::round_profile(), c, Variant::latency), MissingParameter);
}

TEST(SarModel, TheFitFindsLNetAndBNetFromTeamSteps) {
  const MachineProfile t = truth();
  std::mt19937_64 rng(3);
  std::vector<calib::Sample> samples;
  int i = 0;
  for (std::int64_t messages : {0, 1, 2, 4, 8})
    for (std::int64_t kib : {1, 64, 512, 4096}) {
      CostCounts c;
      c.P = 8;
      c.precision = Precision::fp64;
      c.N_C = 2'000'000 + 100'000 * i++;
      c.net_messages = messages;
      c.net_bytes = messages > 0 ? messages * kib * 1024 : 0;
      samples.push_back(test::synthetic_sample(fmt::format("team/{}", i), c, t, Variant::latency, 0.0, rng, "cpu-seq"));
    }
  MachineProfile start = t;
  for (Param p : {Param::L_net, Param::B_net, Param::V_C1_fp64}) {
    Parameter q = t.get(p);
    q.value *= 1.4;
    q.provenance = Provenance::probed;
    start.set(p, q);
  }
  calib::FitOptions o;
  o.variant = Variant::latency;
  const calib::FitResult r = calib::fit(samples, start, o);
  for (Param p : {Param::L_net, Param::B_net, Param::V_C1_fp64}) {
    EXPECT_EQ(r.profile.get(p).provenance, Provenance::fitted) << info(p).name;
    EXPECT_NEAR(r.profile.get(p).value / t.get(p).value, 1.0, 1e-4) << info(p).name;
  }
}

TEST(SarModel, ATeamStepCountsItsMessagesPerFusionPeriod) {
  Scenario s;
  s.helicopters = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  s.nx = 50, s.ny = 40, s.x_min = -1, s.x_max = 4, s.y_min = -2, s.y_max = 2;
  s.prior_x = 0, s.prior_y = 0;
  s.backend = "cpu-seq";
  s.rule = Rule::belief;
  s.interval = 4;
  TeamCounts t = team_counts(s, 3);
  EXPECT_EQ(t.steps, 4);
  EXPECT_EQ(t.net.net_messages, 2);              // one fusion per period, to 2 others
  EXPECT_EQ(t.net.net_bytes, 2 * 50 * 40 * 4);   // float32 beliefs
  // Four steps and, once a period, the backend's own fusion of 3 beliefs of 2000 cells: 2
  // multiplications and an addition per cell, A_c x sum, a division per cell (fusion_counts.hpp).
  EXPECT_EQ(t.rbe.N_C, rbe::step_counts("cpu-seq", t.shape).scaled(4).N_C + 4 * 2000 + 1);
  // The summary (the estimate and the control's 9 x 10 footprint sums) once a step, where the
  // belief lives: for cpu-seq on the host, for a helicopter at the grid's centre. Its windows of
  // 4 spreads (0.8 km) on 0.1 km cells hold 17 x 17 cells where the grid has them.
  const rbe::Grid g = s.grid();
  const std::vector<rbe::Point> at = lookahead_points(s, Helicopter{1.5, 0, 0});
  ASSERT_EQ(at.size(), 90u);
  EXPECT_EQ(t.summary, rbe::host_summary_counts(g, detection_footprint(s), at, rbe::BeliefCopy::in_place).scaled(4));
  EXPECT_EQ(t.host.N_C, 4 * 2000 * kLikelihoodFlopsPerCell);  // one likelihood a step, nothing else
  s.backend = "cuda-resident";
  const TeamCounts gpu = team_counts(s, 3);
  EXPECT_EQ(gpu.summary.N_C, 4 * (rbe::kDeviceSummaryFinish + 1 + 90));  // the host only finishes
  EXPECT_GT(gpu.summary.N_G, 0);
  s.backend = "cpu-seq";
  s.rule = Rule::observation;
  t = team_counts(s, 3);
  EXPECT_EQ(t.steps, 1);
  EXPECT_EQ(t.net.net_messages, 2);
  EXPECT_EQ(t.net.net_bytes, 2 * kObservationBytes);
  s.rule = Rule::none;
  EXPECT_EQ(team_counts(s, 3).net.net_messages, 0);
}

}  // namespace
}  // namespace dtflop::sar
