// Accuracy models: the kernel's share of the motion against an independent Monte Carlo of eq. 5.23,
// and each constraint discarding what it should, with its reason.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "model/errors.hpp"
#include "tune/accuracy.hpp"
#include "workloads/workload.hpp"

namespace dtflop::tune {
namespace {

// Samples the one-step displacement and counts those landing in the kernel's cells: a cell offset
// k = round(d / cell) must lie within -(I-1)/2 .. I-1-(I-1)/2.
double monte_carlo_mass(int ix, int iy, double cx, double cy, double dt, double vm, double vs, double hm, double hs,
                        bool polar) {
  std::mt19937_64 rng(12345);
  std::normal_distribution<double> a(vm, vs), b(hm, hs);
  const int n = 400000;
  int in = 0;
  for (int i = 0; i < n; ++i) {
    double dx, dy;
    if (polar) {
      const double v = a(rng), h = b(rng);
      dx = dt * v * std::cos(h);
      dy = dt * v * std::sin(h);
    } else {
      dx = dt * a(rng);
      dy = dt * b(rng);
    }
    const long kx = std::lround(dx / cx), ky = std::lround(dy / cy);
    const long lox = -(ix - 1) / 2, hix = ix - 1 + lox, loy = -(iy - 1) / 2, hiy = iy - 1 + loy;
    in += kx >= lox && kx <= hix && ky >= loy && ky <= hiy;
  }
  return static_cast<double>(in) / n;
}

TEST(KernelMass, MatchesAMonteCarloOfTheRaftsMotion) {
  // Table 5.5: speed N(0.1, 0.02) km/s, heading N(0, 0.7) rad; 1 s steps on 10 m cells.
  for (int i : {9, 17, 25, 33}) {
    const double q = kernel_mass(i, i, 0.01, 0.01, 1, 0.1, 0.02, 0, 0.7);
    const double mc = monte_carlo_mass(i, i, 0.01, 0.01, 1, 0.1, 0.02, 0, 0.7, true);
    EXPECT_NEAR(q, mc, 3e-3) << "kernel " << i;
  }
  // An even kernel reaches one cell further in +x: more of a +x drift.
  EXPECT_GT(kernel_mass(20, 20, 0.01, 0.01, 1, 0.1, 0.02, 0, 0.7), kernel_mass(19, 19, 0.01, 0.01, 1, 0.1, 0.02, 0, 0.7));
  EXPECT_NEAR(kernel_mass(20, 20, 0.01, 0.01, 1, 0.1, 0.02, 0, 0.7),
              monte_carlo_mass(20, 20, 0.01, 0.01, 1, 0.1, 0.02, 0, 0.7, true), 3e-3);
}

TEST(KernelMass, CartesianMatchesAMonteCarlo) {
  for (int i : {5, 15, 25}) {
    const double q = kernel_mass_cartesian(i, i + 2, 0.01, 0.012, 1, 0.05, 0.02, -0.01, 0.03);
    const double mc = monte_carlo_mass(i, i + 2, 0.01, 0.012, 1, 0.05, 0.02, -0.01, 0.03, false);
    EXPECT_NEAR(q, mc, 3e-3) << "kernel " << i;
  }
}

const workload::Workload& rbe() { return workload::find("rbe"); }

AccuracyJudgement judge_rbe(AccuracyModel& m, const std::string& backend, const nlohmann::json& given) {
  const auto& b = rbe().backend(backend);
  return m.judge(b, rbe().validate(given, b));
}

TEST(RbeAccuracy, DiscardsShortKernelsCoarseGridsAndSeparablePredictionOfANonSeparableMotion) {
  const nlohmann::json polar = {{"area", {2, 2}}, {"time-step", 1}, {"likelihood-sigma", 0.03}};
  auto m = make_accuracy_model("rbe", polar);
  // 200 cells over 2 km: 10 m cells, 3 per 30 m sigma.
  auto a = judge_rbe(*m, "cpu-seq", {{"grid", "200x200"}, {"kernel", "41x41"}, {"prediction", "full"}});
  EXPECT_TRUE(a.ok) << a.reason;
  EXPECT_DOUBLE_EQ(a.error, 10);
  a = judge_rbe(*m, "cpu-seq", {{"grid", "200x200"}, {"kernel", "41x41"}, {"prediction", "separable"}});
  EXPECT_FALSE(a.ok);
  EXPECT_EQ(a.constraint, "separable");
  a = judge_rbe(*m, "cuda-resident", {{"grid", "200x200"}, {"kernel", "41x41"}});
  EXPECT_EQ(a.constraint, "separable");
  a = judge_rbe(*m, "cpu-seq", {{"grid", "200x200"}, {"kernel", "9x9"}, {"prediction", "full"}});
  EXPECT_EQ(a.constraint, "kernel-mass");
  EXPECT_NE(a.reason.find("9x9"), std::string::npos);
  a = judge_rbe(*m, "cpu-seq", {{"grid", "50x50"}, {"kernel", "13x13"}, {"prediction", "full"}});
  EXPECT_EQ(a.constraint, "resolution");

  nlohmann::json cart = polar;
  cart["target-velocity"] = {{"x", {0.1, 0.02}}, {"y", {0, 0.02}}};
  auto c = make_accuracy_model("rbe", cart);
  a = judge_rbe(*c, "cpu-seq", {{"grid", "200x200"}, {"kernel", "41x41"}, {"prediction", "separable"}});
  EXPECT_TRUE(a.ok) << a.reason;
}

TEST(RbeAccuracy, BadNeedsAreNamed) {
  auto err = [](const nlohmann::json& j) {
    try {
      make_accuracy_model("rbe", j);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const nlohmann::json ok = {{"area", {2, 2}}, {"time-step", 1}, {"likelihood-sigma", 0.03}};
  EXPECT_EQ(err(ok), "");
  auto with = [&](const char* k, nlohmann::json v) {
    nlohmann::json j = ok;
    j[k] = std::move(v);
    return err(j);
  };
  EXPECT_NE(with("area", {2}).find("accuracy.area"), std::string::npos);
  EXPECT_NE(with("time-step", -1).find("accuracy.time-step"), std::string::npos);
  EXPECT_NE(with("kernel-mass", 1.5).find("accuracy.kernel-mass"), std::string::npos);
  EXPECT_NE(with("colour", 1).find("accuracy.colour: unknown field"), std::string::npos);
  EXPECT_NE(with("target-velocity", {{"x", {0.1, 0.02}}}).find("target-velocity"), std::string::npos);
  nlohmann::json missing = ok;
  missing.erase("likelihood-sigma");
  EXPECT_NE(err(missing).find("likelihood-sigma: missing"), std::string::npos);
}

TEST(DctAccuracy, MoreDotsPerSupportSmoothMoreAndFeOutsideTheTriangulationIsInvalid) {
  auto m = make_accuracy_model("dct", {{"max-strain-rms", 1e6}, {"min-valid-points", 0.5}});
  const auto& w = workload::find("dct");
  const auto& b = w.backend("cpu-seq");
  auto judge = [&](int support, const char* interp) {
    return m->judge(b, w.validate({{"size", "480x360"}, {"dots", 90}, {"radius", 6}, {"points", "8x8"},
                                   {"support", support}, {"interp", interp}},
                                  b));
  };
  const auto small = judge(10, "mls"), large = judge(40, "mls");
  ASSERT_TRUE(small.ok) << small.reason;
  ASSERT_TRUE(large.ok) << large.reason;
  EXPECT_GT(small.error, large.error);  // noise averages over more dots
  EXPECT_GT(large.error, 0);
  EXPECT_EQ(large.figures["points"], 64);
  // A need no configuration meets, with its reason.
  auto strict = make_accuracy_model("dct", {{"max-strain-rms", 1e-3}});
  const auto a = strict->judge(b, w.validate({{"size", "480x360"}, {"dots", 90}, {"radius", 6}, {"points", "8x8"},
                                              {"support", 40}},
                                             b));
  EXPECT_FALSE(a.ok);
  EXPECT_EQ(a.constraint, "strain-error");
  EXPECT_NE(a.reason.find("microstrain"), std::string::npos);
}

TEST(DctAccuracy, WeightThresholdAndSupportRadiusChangeTheMeasuredError) {
  auto m = make_accuracy_model("dct", {{"min-valid-points", 0.9}});
  const auto& w = workload::find("dct");
  const auto& seq = w.backend("cpu-seq");
  const auto& gpu = w.backend("cuda");
  const nlohmann::json base = {{"size", "480x360"}, {"dots", 90}, {"radius", 6}, {"points", "8x8"}, {"support", 30}};
  auto judge = [&](const workload::Backend& b, const nlohmann::json& extra) {
    nlohmann::json g = base;
    for (const auto& [k, v] : extra.items()) {
      if (k == "support-radius") g.erase("support");
      g[k] = v;
    }
    return m->judge(b, w.validate(g, b));
  };
  const auto cubic = judge(seq, nlohmann::json::object());
  ASSERT_TRUE(cubic.ok) << cubic.reason;
  // Each weight function weighs the same dots differently: another error.
  for (const char* wf : {"quartic", "gaussian"}) {
    const auto a = judge(seq, {{"weight", wf}});
    ASSERT_TRUE(a.ok) << wf << ": " << a.reason;
    EXPECT_NE(a.error, cubic.error) << wf;
  }
  // A fixed threshold finds the same dots (ground 200, ink 40), with regions a little other
  // than Otsu's and so centroids weighed over other edge pixels: an error near Otsu's, not
  // equal; likewise the adaptive threshold's.
  const auto fixed = judge(seq, {{"threshold", "fixed"}});
  ASSERT_TRUE(fixed.ok) << fixed.reason;
  EXPECT_NE(fixed.error, cubic.error);
  EXPECT_NEAR(fixed.error, cubic.error, 0.05 * cubic.error);
  const auto adaptive = judge(seq, {{"threshold", "adaptive"}});
  ASSERT_TRUE(adaptive.ok) << adaptive.reason;
  EXPECT_GT(adaptive.error, 0);
  // By radius: a support holding about 6 dots leaves points invalid (too few dots); a wider one
  // averages more noise away than a narrower one.
  const auto tiny = judge(seq, {{"support-radius", 30}});
  EXPECT_FALSE(tiny.ok);
  EXPECT_EQ(tiny.constraint, "valid-points");
  const auto narrow = judge(seq, {{"support-radius", 110}}), wide = judge(seq, {{"support-radius", 200}});
  ASSERT_TRUE(narrow.ok) << narrow.reason;
  ASSERT_TRUE(wide.ok) << wide.reason;
  EXPECT_GT(narrow.error, wide.error);
  // How the device spreads the work changes no field: the cuda layouts share one measurement.
  EXPECT_EQ(judge(gpu, {{"block-pixels", 64}, {"block-points", 512}}).error, judge(gpu, {}).error);
  EXPECT_EQ(judge(gpu, {}).error, cubic.error);
}

TEST(AccuracyModels, AWorkloadWithoutAModelRefusesNeeds) {
  EXPECT_THROW(make_accuracy_model("other", {{"a", 1}}), InputError);
  EXPECT_NO_THROW(make_accuracy_model("other", nlohmann::json::object()));
}

}  // namespace
}  // namespace dtflop::tune
