// Rounds: `run_sweep` walking a plan R times (keys, round fields, resume, progress) and
// `merge_rounds` turning the rounds of a configuration into one sample (fastest, median or lower
// quartile of the rounds' medians).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <stdexcept>

#include <gtest/gtest.h>

#include "calibrate/rounds.hpp"
#include "calibrate/store.hpp"
#include "calibrate/sweep.hpp"
#include "model/errors.hpp"
#include "tests/calibrate/synthetic.hpp"
#include "tests/support/temp_dir.hpp"

namespace dtflop::calib {
namespace {

namespace fs = std::filesystem;

MachineIdentity machine() { return test::round_profile().identity; }

// A sample of configuration `key` in round `round` whose total's repetitions are `total` (and,
// when given, the CG component's `cg`).
Sample hand_sample(const std::string& key, int round, std::vector<double> total, std::vector<double> cg = {}) {
  Sample s;
  s.key = round_key(key, round);
  s.round = round;
  s.machine = machine();
  s.workload = "rbe";
  s.backend = "cuda-seed";
  s.plan = "hand";
  s.parameters = {{"grid", {100 + round, 100}}};  // tells the rounds apart
  s.counts = rbe::seed_gpu_counts({100, 100, 3, 3});
  s.steps = 10;
  s.components[Component::total] = summarize(std::move(total));
  if (!cg.empty()) s.components[Component::CG] = summarize(std::move(cg));
  s.detail = {{"cpu_utilization", 0.5 + 0.1 * round}};
  s.measured_at = "2026-11-21T10:00:0" + std::to_string(round) + "Z";
  return s;
}

TEST(CalibRounds, KeysCarryTheRoundFromTheSecondOn) {
  EXPECT_EQ(round_key("rbe/cpu-seq/100x100/k3x3", 1), "rbe/cpu-seq/100x100/k3x3");
  EXPECT_EQ(round_key("rbe/cpu-seq/100x100/k3x3", 2), "rbe/cpu-seq/100x100/k3x3/round=2");
  EXPECT_EQ(round_key("a", 12), "a/round=12");
  EXPECT_EQ(base_key("a/round=12"), "a");
  EXPECT_EQ(base_key("a/b/round=3"), "a/b");
  EXPECT_EQ(base_key("a"), "a");
  EXPECT_EQ(base_key("a/round="), "a/round=");    // no number: not a round suffix
  EXPECT_EQ(base_key("a/round=x2"), "a/round=x2");
  EXPECT_EQ(base_key("a/round=02"), "a/round=02");
  EXPECT_EQ(base_key("a/round=2/pinned"), "a/round=2/pinned");  // only at the end
}

TEST(CalibRounds, SampleRoundIsStoredAndAbsentMeansOne) {
  const Sample s = hand_sample("k", 3, {1, 2, 3});
  nlohmann::json j = to_json(s);
  EXPECT_EQ(j["round"], 3);
  EXPECT_EQ(sample_from_json(j).round, 3);
  j.erase("round");  // a sample written before rounds existed
  EXPECT_EQ(sample_from_json(j).round, 1);
  for (const auto& bad : {nlohmann::json(0), nlohmann::json(-1), nlohmann::json(1.5), nlohmann::json("2")}) {
    j["round"] = bad;
    try {
      sample_from_json(j);
      ADD_FAILURE() << "round " << bad.dump() << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("'round'"), std::string::npos) << e.what();
    }
  }
}

TEST(CalibRounds, MergeTakesTheMedianOfTheRoundsMedians) {
  // Given out of order: round 3, round 1, round 2; another configuration in between.
  std::vector<Sample> in = {
      hand_sample("a", 3, {0.95, 0.96, 0.94}, {0.40, 0.42, 0.41}),  // median 0.95, CG 0.41
      hand_sample("b", 1, {2.0, 2.0, 2.0}),
      hand_sample("a", 1, {1.0, 1.1, 0.9, 1.05, 0.97}, {0.30, 0.31, 0.29}),  // median 1.0, CG 0.30
      hand_sample("a", 2, {1.3, 1.2, 1.4}),  // median 1.3, no CG in this round
  };
  const Sample round1 = in[2];
  const MergedRounds m = merge_rounds(in, RoundCombine::median);
  EXPECT_TRUE(m.warnings.empty());
  ASSERT_EQ(m.samples.size(), 2u);
  EXPECT_EQ(m.input, 4);
  EXPECT_EQ(m.min_rounds, 1);
  EXPECT_EQ(m.max_rounds, 3);
  EXPECT_EQ(m.summary(), "2 configurations from 4 samples (1-3 rounds)");

  const Sample& a = m.samples[0];  // first met
  EXPECT_EQ(a.key, "a");
  EXPECT_EQ(a.round, 1);
  const Stats& t = a.components.at(Component::total);
  EXPECT_EQ(t.values, (std::vector<double>{1.0, 1.3, 0.95}));  // round order
  EXPECT_DOUBLE_EQ(t.median, 1.0);
  EXPECT_DOUBLE_EQ(t.min, 0.95);
  EXPECT_DOUBLE_EQ(t.max, 1.3);
  EXPECT_DOUBLE_EQ(t.p25, 0.975);  // type 7 over {0.95, 1.0, 1.3}
  EXPECT_DOUBLE_EQ(t.p75, 1.15);
  EXPECT_EQ(a.repetitions(), 3);
  // CG was measured in rounds 1 and 3 only: the median of those two.
  const Stats& cg = a.components.at(Component::CG);
  EXPECT_EQ(cg.values, (std::vector<double>{0.30, 0.41}));
  EXPECT_DOUBLE_EQ(cg.median, 0.355);
  // Identity, counts and parameters from round 1; what was merged in detail.
  EXPECT_EQ(a.parameters, round1.parameters);
  EXPECT_EQ(a.counts, round1.counts);
  EXPECT_EQ(a.measured_at, round1.measured_at);
  EXPECT_EQ(a.steps, 10);
  EXPECT_EQ(a.detail["rounds"], 3);
  EXPECT_DOUBLE_EQ(a.detail["round_spread"].get<double>(), (1.3 - 0.95) / 1.0);
  EXPECT_EQ(a.detail["repetitions_per_round"], 5);
  EXPECT_DOUBLE_EQ(a.detail["cpu_utilization"].get<double>(), 0.6);  // round 1's

  // A merged sample still makes valid JSON.
  const Sample back = sample_from_json(to_json(a));
  EXPECT_DOUBLE_EQ(back.find(Component::total)->median, 1.0);

  // An even number of rounds: the mean of the middle two.
  const MergedRounds two =
      merge_rounds({hand_sample("c", 1, {1, 1}), hand_sample("c", 2, {2, 2})}, RoundCombine::median);
  ASSERT_EQ(two.samples.size(), 1u);
  EXPECT_DOUBLE_EQ(two.samples[0].find(Component::total)->median, 1.5);
  EXPECT_EQ(two.summary(), "1 configuration from 2 samples (2 rounds)");
  EXPECT_EQ(two.how(), "; a configuration's time is the median of its rounds' medians");
}

TEST(CalibRounds, FastestTakesTheFastestRoundsMedian) {
  const std::vector<Sample> in = {
      hand_sample("a", 1, {1.0, 1.1, 0.9, 1.05, 0.97}, {0.30, 0.31, 0.29}),  // median 1.0, CG 0.30
      hand_sample("a", 2, {1.6, 1.7, 1.5}, {0.50, 0.52, 0.51}),              // a slow round: 1.6, CG 0.51
      hand_sample("a", 3, {1.5, 1.5, 1.5}),                                  // another: 1.5, no CG
      hand_sample("b", 1, {2.0, 2.0, 2.0}),                                  // one round: unchanged
  };
  const MergedRounds m = merge_rounds(in, RoundCombine::fastest);
  ASSERT_EQ(m.samples.size(), 2u);
  EXPECT_EQ(m.combine, RoundCombine::fastest);
  EXPECT_EQ(m.how(), "; a configuration's time is its fastest round's median");
  const Sample& a = m.samples[0];
  const Stats& t = a.components.at(Component::total);
  EXPECT_DOUBLE_EQ(t.median, 1.0);  // the fastest round, where the median of the three would be 1.5
  EXPECT_EQ(t.values, (std::vector<double>{1.0, 1.6, 1.5}));  // the rounds, as with median
  EXPECT_DOUBLE_EQ(t.max, 1.6);
  EXPECT_DOUBLE_EQ(a.components.at(Component::CG).median, 0.30);
  // The spread is still taken over the median of the rounds, not the fastest one.
  EXPECT_DOUBLE_EQ(a.detail["round_spread"].get<double>(), (1.6 - 1.0) / 1.5);
  EXPECT_EQ(a.detail["rounds_combined_by"], "fastest");
  EXPECT_DOUBLE_EQ(m.samples[1].find(Component::total)->median, 2.0);
  // Names.
  EXPECT_EQ(round_combine_from_string("fastest"), RoundCombine::fastest);
  EXPECT_EQ(round_combine_from_string("median"), RoundCombine::median);
  EXPECT_FALSE(round_combine_from_string("mean").has_value());
  EXPECT_EQ(to_string(RoundCombine::fastest), "fastest");
}

TEST(CalibRounds, P25TakesTheLowerQuartileOfTheRoundsMedians) {
  const std::vector<Sample> in = {
      hand_sample("a", 1, {1.6, 1.6, 1.6}, {0.50, 0.50}),  // rounds' medians 1.6, 1.0, 1.5, 1.2, 1.1
      hand_sample("a", 2, {1.0, 0.9, 1.1}, {0.30, 0.30}),
      hand_sample("a", 3, {1.5, 1.5, 1.5}, {0.40, 0.40}),
      hand_sample("a", 4, {1.2, 1.2, 1.2}),
      hand_sample("a", 5, {1.1, 1.1, 1.1}),
      hand_sample("b", 1, {2.0, 2.0}),  // three rounds: 2.0, 3.0, 2.5
      hand_sample("b", 2, {3.0, 3.0}),
      hand_sample("b", 3, {2.5, 2.5}),
  };
  const MergedRounds m = merge_rounds(in, RoundCombine::p25);
  ASSERT_EQ(m.samples.size(), 2u);
  EXPECT_EQ(m.how(), "; a configuration's time is the lower quartile of its rounds' medians");
  // Five rounds: the second fastest (type 7: position 0.25 x 4 = 1 of the sorted 1.0 1.1 1.2 1.5 1.6).
  const Stats& a = m.samples[0].components.at(Component::total);
  EXPECT_DOUBLE_EQ(a.median, 1.1);
  EXPECT_DOUBLE_EQ(a.min, 1.0);
  EXPECT_EQ(a.values, (std::vector<double>{1.6, 1.0, 1.5, 1.2, 1.1}));
  // CG in three rounds (0.50, 0.30, 0.40): halfway between the fastest and the median.
  EXPECT_DOUBLE_EQ(m.samples[0].components.at(Component::CG).median, 0.35);
  // Three rounds: halfway between the fastest (2.0) and the median (2.5).
  EXPECT_DOUBLE_EQ(m.samples[1].find(Component::total)->median, 2.25);
  EXPECT_EQ(m.samples[1].detail["rounds_combined_by"], "p25");
  EXPECT_EQ(round_combine_from_string("p25"), RoundCombine::p25);
  EXPECT_EQ(to_string(RoundCombine::p25), "p25");
  EXPECT_EQ(parse_round_combine("p25"), RoundCombine::p25);
  try {
    parse_round_combine("mean");
    ADD_FAILURE() << "'mean' was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--rounds-combine 'mean' is unknown; use fastest, median or p25"),
              std::string::npos)
        << e.what();
  }
}

TEST(CalibRounds, DefaultIsTheFastestRound) {
  // The rule chosen by the held-out errors of the stored experiments (docs/calibration.md).
  EXPECT_EQ(kDefaultRoundCombine, RoundCombine::fastest);
  const MergedRounds m = merge_rounds({hand_sample("a", 1, {1.3, 1.3}), hand_sample("a", 2, {1.0, 1.0}),
                                       hand_sample("a", 3, {1.2, 1.2})});
  EXPECT_EQ(m.combine, RoundCombine::fastest);
  EXPECT_DOUBLE_EQ(m.samples.at(0).find(Component::total)->median, 1.0);
  EXPECT_EQ(m.samples.at(0).detail["rounds_combined_by"], "fastest");
  EXPECT_EQ(MergedRounds{}.combine, RoundCombine::fastest);
}

TEST(CalibRounds, DriftIsThePooledDeviationOfLogTimeBetweenRounds) {
  // a: rounds 1.0 and 1.2; b: 2.0, 2.0 and 2.6; c: one round (no drift to see); each round's
  // median is its total. By hand: the squares of log t about each configuration's mean log t,
  // over the rounds less one each (1 + 2).
  const MergedRounds m = merge_rounds({hand_sample("a", 1, {1.0}), hand_sample("a", 2, {1.2}),
                                       hand_sample("b", 1, {2.0}), hand_sample("b", 2, {2.0}),
                                       hand_sample("b", 3, {2.6}), hand_sample("c", 1, {5.0})});
  const double a = std::log(1.2) / 2;  // each round's distance from a's mean
  const double b_mean = (2 * std::log(2.0) + std::log(2.6)) / 3;
  const double b = 2 * std::pow(std::log(2.0) - b_mean, 2) + std::pow(std::log(2.6) - b_mean, 2);
  EXPECT_EQ(m.round_configs, 2);
  EXPECT_NEAR(m.round_log_sd, std::sqrt((2 * a * a + b) / 3), 1e-12);
  // Rounds that agree show no drift; one round each, none measured.
  EXPECT_DOUBLE_EQ(merge_rounds({hand_sample("a", 1, {1.0}), hand_sample("a", 2, {1.0})}).round_log_sd, 0);
  const MergedRounds one = merge_rounds({hand_sample("a", 1, {1.0}), hand_sample("b", 1, {2.0})});
  EXPECT_EQ(one.round_configs, 0);
  EXPECT_DOUBLE_EQ(one.round_log_sd, 0);
}

TEST(CalibRounds, OneRoundPassesThroughUnchanged) {
  const std::vector<Sample> in = {hand_sample("a", 1, {1, 2, 3, 4}), hand_sample("b", 2, {5, 6})};
  const MergedRounds m = merge_rounds(in);
  ASSERT_EQ(m.samples.size(), 2u);
  EXPECT_TRUE(m.warnings.empty());
  EXPECT_EQ(to_json(m.samples[0]), to_json(in[0]));
  EXPECT_EQ(to_json(m.samples[1]), to_json(in[1]));  // a lone round 2 keeps its key
  EXPECT_EQ(m.samples[1].key, "b/round=2");
  EXPECT_FALSE(m.samples[0].detail.contains("rounds"));
  EXPECT_EQ(m.summary(), "2 configurations from 2 samples (1 round)");
  EXPECT_EQ(merge_rounds({}).samples.size(), 0u);
}

TEST(CalibRounds, DuplicatedSampleKeepsTheFirstAndWarns) {
  const MergedRounds m = merge_rounds({hand_sample("a", 1, {1, 1}), hand_sample("a", 2, {2, 2}),
                                       hand_sample("a", 2, {100, 100}), hand_sample("a", 3, {3, 3})});
  ASSERT_EQ(m.samples.size(), 1u);
  ASSERT_EQ(m.warnings.size(), 1u);
  EXPECT_NE(m.warnings[0].find("'a/round=2'"), std::string::npos) << m.warnings[0];
  EXPECT_NE(m.warnings[0].find("keeping the first"), std::string::npos) << m.warnings[0];
  EXPECT_EQ(m.samples[0].find(Component::total)->values, (std::vector<double>{1, 2, 3}));
  EXPECT_EQ(m.samples[0].detail["rounds"], 3);
  EXPECT_EQ(m.input, 4);

  // Round 1 twice and nothing else: the first, unchanged.
  const MergedRounds one = merge_rounds({hand_sample("b", 1, {1, 1}), hand_sample("b", 1, {9, 9})});
  ASSERT_EQ(one.samples.size(), 1u);
  EXPECT_EQ(one.warnings.size(), 1u);
  EXPECT_EQ(one.samples[0].find(Component::total)->values, (std::vector<double>{1, 1}));
}

TEST(CalibRounds, OtherMachinesAndBackendsAreNotMerged) {
  Sample other = hand_sample("a", 2, {2, 2});
  other.machine.cpu_threads = 64;
  Sample pinned = hand_sample("a", 3, {3, 3});
  pinned.backend = "cuda-resident";
  const MergedRounds m = merge_rounds({hand_sample("a", 1, {1, 1}), other, pinned});
  ASSERT_EQ(m.samples.size(), 3u);
  EXPECT_TRUE(m.warnings.empty());
  for (const auto& s : m.samples) EXPECT_FALSE(s.detail.contains("rounds")) << s.key;
  EXPECT_EQ(m.samples[1].machine.cpu_threads, 64);
  // The same round of the same key on two machines is no duplicate.
  Sample twin = hand_sample("a", 1, {5, 5});
  twin.machine.gpu_name = "Other GPU";
  const MergedRounds t = merge_rounds({hand_sample("a", 1, {1, 1}), twin, hand_sample("a", 2, {2, 2})});
  ASSERT_EQ(t.samples.size(), 2u);
  EXPECT_TRUE(t.warnings.empty());
  EXPECT_EQ(t.samples[0].find(Component::total)->values, (std::vector<double>{1, 2}));
  EXPECT_EQ(t.samples[1].find(Component::total)->values, (std::vector<double>{5, 5}));
}

TEST(CalibRounds, RoundsThatCannotBeComparedAreLeftOutOrFlagged) {
  Sample steps = hand_sample("a", 2, {20, 20});
  steps.steps = 20;
  Sample counts = hand_sample("a", 3, {3, 3});
  counts.counts = rbe::seed_gpu_counts({200, 100, 3, 3});
  const MergedRounds m = merge_rounds({hand_sample("a", 1, {1, 1}), steps, counts});
  ASSERT_EQ(m.samples.size(), 1u);
  ASSERT_EQ(m.warnings.size(), 2u);
  EXPECT_NE(m.warnings[0].find("leaving round 2 out"), std::string::npos) << m.warnings[0];
  EXPECT_NE(m.warnings[1].find("different cost counts"), std::string::npos) << m.warnings[1];
  EXPECT_EQ(m.samples[0].find(Component::total)->values, (std::vector<double>{1, 3}));
  EXPECT_EQ(m.samples[0].counts, rbe::seed_gpu_counts({100, 100, 3, 3}));
  EXPECT_EQ(m.samples[0].detail["rounds"], 2);
}

class CalibRoundsSweep : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::fresh_test_dir("dtflop_rounds");
    store_ = dir_ / "samples.jsonl";
    for (int i = 0; i < 4; ++i)
      plan_.items.push_back({"cfg" + std::to_string(i), "config " + std::to_string(i), {{"i", i}}});
    plan_.items.push_back(plan_.items[1]);  // a plan may repeat a configuration
    plan_.name = "fake";
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A measuring function that records the keys it was given and fails after `limit` samples.
  MeasureFn fake(std::vector<std::string>& seen, int limit = 1 << 30) {
    return [&seen, limit](const PlanItem& item) {
      if (static_cast<int>(seen.size()) >= limit) throw std::runtime_error("killed");
      seen.push_back(item.key);
      Sample s = hand_sample(item.key, 1, {1.0 + static_cast<double>(seen.size())});
      s.key = "whatever the backend says";  // the sweep sets the key and round
      s.round = 7;
      return s;
    };
  }

  fs::path dir_, store_;
  Plan plan_;
};

TEST_F(CalibRoundsSweep, SweepWalksThePlanOncePerRound) {
  std::vector<std::string> seen;
  std::FILE* progress = std::tmpfile();
  ASSERT_NE(progress, nullptr);
  const SweepReport r = run_sweep(plan_, store_, machine(), fake(seen), progress, 3);
  EXPECT_EQ(r.planned, 12);
  EXPECT_EQ(r.configurations, 4);
  EXPECT_EQ(r.rounds, 3);
  EXPECT_EQ(r.measured, 12);
  EXPECT_EQ(r.already, 0);
  const std::vector<std::string> expected = {
      "cfg0",         "cfg1",         "cfg2",         "cfg3",         "cfg0/round=2", "cfg1/round=2",
      "cfg2/round=2", "cfg3/round=2", "cfg0/round=3", "cfg1/round=3", "cfg2/round=3", "cfg3/round=3"};
  EXPECT_EQ(seen, expected);  // interleaved: every configuration once per round

  const StoreContents c = read_store(store_);
  ASSERT_EQ(c.samples.size(), 12u);
  for (std::size_t i = 0; i < c.samples.size(); ++i) {
    EXPECT_EQ(c.samples[i].key, expected[i]);
    EXPECT_EQ(c.samples[i].round, static_cast<int>(i / 4) + 1) << expected[i];
  }

  std::rewind(progress);
  std::string text;
  char buf[4096];
  while (std::size_t n = std::fread(buf, 1, sizeof buf, progress)) text.append(buf, n);
  std::fclose(progress);
  EXPECT_NE(text.find("4 configurations x 3 rounds = 12 samples, 0 already"), std::string::npos) << text;
  EXPECT_NE(text.find("round 1/3 [1/4] config 0:"), std::string::npos) << text;
  EXPECT_NE(text.find("round 2/3 [3/4] config 2:"), std::string::npos) << text;
  EXPECT_NE(text.find("round 3/3 [4/4] config 3:"), std::string::npos) << text;

  // Merged, the store is four configurations of three rounds each.
  const MergedRounds m = merge_rounds(c.samples, RoundCombine::median);
  ASSERT_EQ(m.samples.size(), 4u);
  EXPECT_EQ(m.summary(), "4 configurations from 12 samples (3 rounds)");
  EXPECT_EQ(m.samples[2].key, "cfg2");
  // cfg2 was the 3rd, 7th and 11th measurement: totals 4, 8, 12.
  EXPECT_EQ(m.samples[2].find(Component::total)->values, (std::vector<double>{4, 8, 12}));
  EXPECT_DOUBLE_EQ(m.samples[2].find(Component::total)->median, 8);
}

TEST_F(CalibRoundsSweep, KilledSweepResumesWithTheMissingRoundsOnly) {
  std::vector<std::string> first;
  EXPECT_THROW(run_sweep(plan_, store_, machine(), fake(first, 5), nullptr, 3), std::runtime_error);
  ASSERT_EQ(read_store(store_).samples.size(), 5u);  // round 1 and the first of round 2

  std::vector<std::string> second;
  const SweepReport r = run_sweep(plan_, store_, machine(), fake(second), nullptr, 3);
  EXPECT_EQ(r.already, 5);
  EXPECT_EQ(r.measured, 7);
  EXPECT_EQ(second, (std::vector<std::string>{"cfg1/round=2", "cfg2/round=2", "cfg3/round=2", "cfg0/round=3",
                                              "cfg1/round=3", "cfg2/round=3", "cfg3/round=3"}));
  const StoreContents c = read_store(store_);
  ASSERT_EQ(c.samples.size(), 12u);
  EXPECT_EQ(c.keys().size(), 12u);  // nothing measured twice

  // Nothing left: the same command measures nothing.
  std::vector<std::string> third;
  const SweepReport again = run_sweep(plan_, store_, machine(), fake(third), nullptr, 3);
  EXPECT_EQ(again.measured, 0);
  EXPECT_EQ(again.already, 12);
  EXPECT_TRUE(third.empty());
}

TEST_F(CalibRoundsSweep, MoreRoundsOnAnOldStoreMeasureOnlyTheNewRounds) {
  std::vector<std::string> first;
  const SweepReport one = run_sweep(plan_, store_, machine(), fake(first), nullptr);  // default: 1 round
  EXPECT_EQ(one.measured, 4);
  EXPECT_EQ(first, (std::vector<std::string>{"cfg0", "cfg1", "cfg2", "cfg3"}));
  std::vector<std::string> second;
  const SweepReport two = run_sweep(plan_, store_, machine(), fake(second), nullptr, 2);
  EXPECT_EQ(two.already, 4);
  EXPECT_EQ(two.measured, 4);
  EXPECT_EQ(second, (std::vector<std::string>{"cfg0/round=2", "cfg1/round=2", "cfg2/round=2", "cfg3/round=2"}));
}

TEST_F(CalibRoundsSweep, RoundsBelowOneAreRefused) {
  std::vector<std::string> seen;
  for (int bad : {0, -2}) {
    try {
      run_sweep(plan_, store_, machine(), fake(seen), nullptr, bad);
      ADD_FAILURE() << "rounds " << bad << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("--rounds"), std::string::npos) << e.what();
    }
  }
  EXPECT_TRUE(seen.empty());
  EXPECT_FALSE(fs::exists(store_));
}

}  // namespace
}  // namespace dtflop::calib
