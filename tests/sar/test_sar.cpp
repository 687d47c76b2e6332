// The search-and-rescue scenario, world, fusion rules and link model, without MPI.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "model/errors.hpp"
#include "sar/fusion.hpp"
#include "sar/platform.hpp"
#include "sar/scenario.hpp"
#include "sar/world.hpp"
#include "workloads/rbe/backend.hpp"
#include "workloads/rbe/estimate.hpp"
#include "workloads/rbe/likelihood.hpp"

namespace dtflop::sar {
namespace {

const char* kSmall = R"(
name: small
area: {x: [-2, 2], y: [-1.5, 1.5], cells: [40, 30]}
time: {step: 1.0, steps: 50}
target:
  speed: {mean: 0.1, sigma: 0.02}
  heading: {mean: 0.0, sigma: 0.7}
  prior: {mean: [-1, 0], sigma: [0.3, 0.2]}
helicopters:
  speed: 0.12
  turn_coefficient: 0.8
  start: [[0, -1, 1.5708], [1, -1, 1.5708]]
fusion: {rule: loglinear, interval: 3}
backend: cpu-seq
)";

std::string error_of(const std::string& yaml) {
  try {
    (void)parse_scenario(yaml, "scenario 't.yaml'");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(SarScenario, ReadsEveryFieldAndKeepsDefaultsForTheRest) {
  const Scenario s = parse_scenario(kSmall, "t");
  EXPECT_EQ(s.nx, 40);
  EXPECT_EQ(s.ny, 30);
  EXPECT_DOUBLE_EQ(s.x_min, -2);
  EXPECT_EQ(s.helicopters.size(), 2u);
  EXPECT_DOUBLE_EQ(s.helicopters[1].x, 1);
  EXPECT_EQ(s.rule, Rule::loglinear);
  EXPECT_EQ(s.interval, 3);
  EXPECT_EQ(s.backend, "cpu-seq");
  EXPECT_DOUBLE_EQ(s.bandwidth_mbps, 70);  // default: the seed's 802.11n link
  EXPECT_DOUBLE_EQ(s.detection_spread, 0.2);
}

TEST(SarScenario, TheShippedScenarioIsTable55) {
  const Scenario s = load_scenario(std::string(DTFLOP_SOURCE_DIR) + "/sar/scenarios/table-5.5.yaml");
  EXPECT_DOUBLE_EQ(s.target_speed_mean, 0.1);
  EXPECT_DOUBLE_EQ(s.target_speed_sigma, 0.02);
  EXPECT_DOUBLE_EQ(s.target_heading_sigma, 0.7);
  EXPECT_DOUBLE_EQ(s.prior_x, -1);
  EXPECT_DOUBLE_EQ(s.prior_y, 1);
  EXPECT_DOUBLE_EQ(s.heli_speed, 0.12);
  EXPECT_DOUBLE_EQ(s.turn_coefficient, 0.8);
  EXPECT_DOUBLE_EQ(s.detection_spread, 0.2);
  EXPECT_DOUBLE_EQ(s.bandwidth_mbps, 70);
}

TEST(SarScenario, BadFieldsAreNamedWithValueAndExpectation) {
  auto with = [](const std::string& from, const std::string& to) {
    std::string t = kSmall;
    const auto at = t.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return t.replace(at, from.size(), to);
  };
  std::string m = error_of(with("speed: 0.12", "speed: -0.12"));
  EXPECT_NE(m.find("helicopters.speed"), std::string::npos) << m;
  EXPECT_NE(m.find("-0.12"), std::string::npos) << m;
  EXPECT_NE(m.find("> 0"), std::string::npos) << m;
  EXPECT_NE(m.find("t.yaml"), std::string::npos) << m;
  m = error_of(with("sigma: 0.02}", "sigma: 0}"));
  EXPECT_NE(m.find("target.speed.sigma is 0"), std::string::npos) << m;
  m = error_of(with("sigma: [0.3, 0.2]", "sigma: [0.3, -1]"));
  EXPECT_NE(m.find("target.prior.sigma[1]"), std::string::npos) << m;
  m = error_of(with("cells: [40, 30]", "cells: [40, 0]"));
  EXPECT_NE(m.find("area.cells[1]"), std::string::npos) << m;
  m = error_of(with("rule: loglinear", "rule: average"));
  EXPECT_NE(m.find("fusion.rule is 'average'"), std::string::npos) << m;
  m = error_of(with("interval: 3", "interval: 2.5"));
  EXPECT_NE(m.find("fusion.interval"), std::string::npos) << m;
  m = error_of(with("name: small", "name: small\ncolour: red"));
  EXPECT_NE(m.find("field colour is unknown"), std::string::npos) << m;
  m = error_of(with("x: [-2, 2]", "x: [2, -2]"));
  EXPECT_NE(m.find("area.x"), std::string::npos) << m;
  m = error_of(with("speed: 0.12", "speed: .nan"));
  EXPECT_NE(m.find("helicopters.speed"), std::string::npos) << m;
  m = error_of("{ unclosed: [");
  EXPECT_NE(m.find("not YAML"), std::string::npos) << m;
  m = error_of(with("start: [[0, -1, 1.5708], [1, -1, 1.5708]]", "start: []"));
  EXPECT_NE(m.find("helicopters.start"), std::string::npos) << m;
}

TEST(SarScenario, TheTeamDigestSeesTheGridAndTheRule) {
  Scenario a = parse_scenario(kSmall, "t"), b = a;
  EXPECT_EQ(team_digest(a), team_digest(b));
  b.nx = 41;
  EXPECT_NE(team_digest(a), team_digest(b));
  b = a;
  b.rule = Rule::belief;
  EXPECT_NE(team_digest(a), team_digest(b));
}

// What the log-linear pool is for: a belief every platform already shares stays as it is, where
// the product counts it once per platform.
TEST(SarFusion, TheLogLinearPoolDoesNotCountSharedInformationTwice) {
  const rbe::Grid g(-2, 2, -2, 2, 40, 40);
  Scenario s = parse_scenario(kSmall, "t");
  s.x_min = -2, s.x_max = 2, s.y_min = -2, s.y_max = 2, s.nx = 40, s.ny = 40, s.prior_x = 0.3, s.prior_y = -0.2;
  std::vector<double> b = prior_belief(s, g);
  double z = 0;
  for (double v : b) z += v * g.cell_area();
  for (double& v : b) v /= z;
  const std::vector<std::vector<double>> same = {b, b, b};
  const auto pooled = loglinear_pool(g, same);
  const auto product = rbe::fuse_beliefs(g, same);
  const rbe::Estimate e0 = rbe::estimate(g, b), ep = rbe::estimate(g, pooled), ex = rbe::estimate(g, product);
  EXPECT_NEAR(ep.cov_xx, e0.cov_xx, 1e-12);
  EXPECT_NEAR(ep.entropy, e0.entropy, 1e-9);
  // The product of three copies of a Gaussian is the Gaussian with a third of the variance.
  EXPECT_NEAR(ex.cov_xx / e0.cov_xx, 1.0 / 3.0, 0.02);
  EXPECT_LT(ex.entropy, e0.entropy - 1.0);
}

TEST(SarFusion, TheLogLinearPoolIsTheNormalizedGeometricMean) {
  const rbe::Grid g = rbe::Grid::unit(3, 1);
  const std::vector<std::vector<double>> two = {{0.5, 0.25, 0.25}, {0.125, 0.5, 0.375}};
  const auto p = loglinear_pool(g, two);
  const double a = std::sqrt(0.5 * 0.125), b = std::sqrt(0.25 * 0.5), c = std::sqrt(0.25 * 0.375);
  EXPECT_NEAR(p[0], a / (a + b + c), 1e-15);
  EXPECT_NEAR(p[1], b / (a + b + c), 1e-15);
  EXPECT_NEAR(p[2], c / (a + b + c), 1e-15);
  const std::vector<std::vector<double>> disjoint = {{1, 0, 0}, {0, 1, 0}};
  EXPECT_THROW((void)loglinear_pool(g, disjoint), rbe::NumericalError);
}

TEST(SarLink, DelayIsLatencyPlusBytesOverBandwidthPerMessage) {
  Scenario s = parse_scenario(kSmall, "t");
  s.rule = Rule::belief;
  s.interval = 4;
  s.latency_ms = 3;
  s.bandwidth_mbps = 70;
  // A team of 3: two beliefs of 40 x 30 float32 cells each on fusion steps only.
  EXPECT_EQ(traffic(s, 3, 3).messages, 0);
  const Traffic t = traffic(s, 3, 4);
  EXPECT_EQ(t.messages, 2);
  EXPECT_EQ(t.bytes, 2 * 40 * 30 * 4);
  EXPECT_NEAR(link_delay(s, t), 2 * 3e-3 + 8.0 * 9600 / 70e6, 1e-15);
  EXPECT_NEAR(mean_traffic(s, 3).bytes, 9600.0 / 4, 1e-12);
  s.rule = Rule::observation;
  EXPECT_EQ(traffic(s, 3, 3).bytes, 2 * kObservationBytes);
  s.link_enabled = false;
  EXPECT_EQ(link_delay(s, traffic(s, 3, 3)), 0.0);
}

TEST(SarWorld, HelicoptersFlyByTheTurnModel) {
  Scenario s = parse_scenario(kSmall, "t");
  Helicopter h{0, 0, 0};
  fly(s, h, 0.5, 2.0);
  EXPECT_NEAR(h.x, 0.24, 1e-15);  // 2 s x 0.12 km/s along +x
  EXPECT_NEAR(h.y, 0.0, 1e-15);
  EXPECT_NEAR(h.heading, 2.0 * 0.8 * 0.5, 1e-15);
  fly(s, h, 100, 1.0);  // the command is clamped to max_turn
  EXPECT_NEAR(h.heading, 0.8 + 0.8 * s.max_turn, 1e-12);
}

TEST(SarWorld, DetectionIsGaussianInDistanceAndNegativeObservationsComplementIt) {
  Scenario s = parse_scenario(kSmall, "t");
  EXPECT_NEAR(detection_probability(s, 0), 0.95, 1e-15);
  EXPECT_NEAR(detection_probability(s, 0.2), 0.95 * std::exp(-0.5), 1e-15);
  const rbe::Grid g = s.grid();
  Observation none;
  none.sensor_x = 0.05, none.sensor_y = 0.05;
  const auto l = likelihood(s, g, none);
  const rbe::Point c = g.centre(20, 15);
  EXPECT_NEAR(l[std::size_t(g.index(20, 15))], 1 - detection_probability(s, std::hypot(c.x - 0.05, c.y - 0.05)), 1e-15);
}

// 10^4 steps of negative observations: a helicopter searching under its control, seeing nothing,
// with a sensor that rules out the cells under it completely (detection max 1), on every CPU
// backend. The belief must stay finite, normalized and never all zero.
TEST(SarWorld, TenThousandStepsOfNegativeObservationsKeepAProperBelief) {
  Scenario s = parse_scenario(kSmall, "t");
  s.detection_max = 1.0;
  const rbe::Grid g = s.grid();
  // cpu-par on one thread: the float32 arithmetic is what is tested, and OpenMP's fork and join
  // 10^4 times on a busy 2-core machine would take a minute.
  rbe::BackendOptions one_thread;
  one_thread.threads = 1;
  for (const char* name : {"cpu-seq", "cpu-par"}) {
    SCOPED_TRACE(name);
    auto b = rbe::make_backend(name, one_thread);
    rbe::Problem p;
    p.grid = g;
    const rbe::GaussianMotion m = rbe::moments(s.drift(s.step_time));
    const rbe::KernelSize k = rbe::kernel_size_for_mass(m, g, s.kernel_mass);
    p.kernel = rbe::make_kernel(m, g, k.Ix, k.Iy);
    p.prior = prior_belief(s, g);
    p.likelihood.assign(std::size_t(g.cells()), 1.0);
    b->init(p);
    Helicopter h = s.helicopters[0];
    double turn = 0;
    int bad = 0, restarts = 0;
    for (int step = 0; step < 10000; ++step) {
      fly(s, h, turn, s.step_time);
      Observation o;
      o.sensor_x = h.x, o.sensor_y = h.y;
      try {
        (void)b->step(likelihood(s, g, o));
      } catch (const rbe::NumericalError&) {
        ++restarts;  // the platform restarts from the likelihood; count it as a failure here
        break;
      }
      const auto belief = b->belief();
      double mass = 0, top = 0;
      for (double v : belief) {
        if (!std::isfinite(v) || v < 0) ++bad;
        mass += v * g.cell_area();
        top = std::max(top, v);
      }
      if (bad || !(top > 0) || std::abs(mass - 1) > 1e-4) {
        ADD_FAILURE() << "step " << step << ": " << bad << " bad cells, max " << top << ", mass " << mass;
        break;
      }
      turn = choose_turn(s, g, h, belief);
    }
    EXPECT_EQ(restarts, 0);
    EXPECT_EQ(bad, 0);
  }
}

// A team of one through a transport that must never be called.
class NoTransport final : public Transport {
 public:
  int rank() const override { return 0; }
  int size() const override { return 1; }
  std::vector<std::vector<std::byte>> exchange(std::span<const std::byte>, std::int64_t) override {
    ADD_FAILURE() << "a team of one exchanged a message";
    return {};
  }
};

TEST(SarPlatform, ALoneHelicopterFindsTheRaftAndItsEstimateFollowsIt) {
  Scenario s = parse_scenario(kSmall, "t");
  s.helicopters.resize(1);
  s.helicopters[0] = {-1.2, -0.6, 1.5708};
  Platform p(s, 0, 1);
  NoTransport t;
  int detections = 0;
  double last_error = 0;
  for (std::int64_t k = 1; k <= 40; ++k) {
    const Record r = p.step(k, t);
    EXPECT_NEAR(r.dt, 1.0, 1e-15);  // no messages, no delay
    EXPECT_EQ(r.estimate.step, k);
    detections += r.estimate.detected;
    last_error = std::hypot(r.estimate.mean_x - r.raft.x, r.estimate.mean_y - r.raft.y);
  }
  EXPECT_GT(detections, 0);
  EXPECT_LT(last_error, 0.5);  // km: tracking, not lost
}

}  // namespace
}  // namespace dtflop::sar
