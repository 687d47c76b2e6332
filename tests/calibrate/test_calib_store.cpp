// Samples as JSON and the append-only store: round trips, torn lines, damage, foreign files,
// one writer at a time.
#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>

#include "calibrate/store.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "tests/calibrate/synthetic.hpp"
#include "tests/support/temp_dir.hpp"

namespace dtflop::test {
inline std::string slurp_file(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}
}  // namespace dtflop::test

namespace dtflop::calib {
namespace {

namespace fs = std::filesystem;

class Store : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::fresh_test_dir("dtflop_store");
    path_ = dir_ / "samples.jsonl";
  }
  void TearDown() override { fs::remove_all(dir_); }

  Sample sample(int i) {
    std::mt19937_64 rng(static_cast<std::uint64_t>(i));
    return test::synthetic_sample("k" + std::to_string(i), rbe::seed_gpu_counts({100 + i, 100, 3, 3}),
                                  test::round_profile(), Variant::latency, 0.01, rng);
  }
  void append_raw(const std::string& text) {
    std::ofstream out(path_, std::ios::app | std::ios::binary);
    out << text;
  }

  fs::path dir_, path_;
};

TEST_F(Store, SampleRoundTripsThroughJson) {
  Sample s = sample(1);
  s.detail = {{"note", "x"}};
  s.timing_note = "because";
  const Sample back = sample_from_json(nlohmann::json::parse(to_json(s).dump()));
  EXPECT_EQ(back.key, s.key);
  EXPECT_EQ(back.counts, s.counts);
  EXPECT_EQ(back.machine.cpu_model, s.machine.cpu_model);
  EXPECT_EQ(back.machine.cpu_threads, s.machine.cpu_threads);
  EXPECT_EQ(back.timing_note, "because");
  EXPECT_EQ(back.detail["note"], "x");
  ASSERT_EQ(back.components.size(), s.components.size());
  for (const auto& [c, st] : s.components) {
    EXPECT_EQ(back.find(c)->values, st.values) << to_string(c);
    EXPECT_DOUBLE_EQ(back.find(c)->median, st.median);
  }
  EXPECT_EQ(back.repetitions(), 5);
}

TEST_F(Store, SampleJsonIsValidated) {
  auto j = to_json(sample(1));
  auto broken = j;
  broken.erase("counts");
  EXPECT_THROW(sample_from_json(broken), InputError);
  broken = j;
  broken["components"]["total"]["values"] = nlohmann::json::array({1.0, -2.0});
  try {
    sample_from_json(broken);
    FAIL() << "a negative time was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("components.total.values[1]"), std::string::npos) << e.what();
  }
  broken = j;
  broken["components"].erase("total");
  EXPECT_THROW(sample_from_json(broken), InputError);
  broken = j;
  broken["components"]["dt_X"] = j["components"]["total"];
  EXPECT_THROW(sample_from_json(broken), InputError);
  broken = j;
  broken["schema_version"] = 99;
  EXPECT_THROW(sample_from_json(broken), InputError);
}

TEST_F(Store, MissingFileReadsEmpty) {
  const auto c = read_store(path_);
  EXPECT_TRUE(c.samples.empty());
  EXPECT_TRUE(c.warnings.empty());
}

TEST_F(Store, AppendsOneLinePerSample) {
  std::vector<std::string> warnings;
  {
    StoreWriter w(path_, warnings);
    for (int i = 0; i < 3; ++i) w.append(sample(i));
  }
  EXPECT_TRUE(warnings.empty());
  const std::string text = test::slurp_file(path_);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 3);
  const auto c = read_store(path_);
  ASSERT_EQ(c.samples.size(), 3u);
  EXPECT_EQ(c.samples[2].key, "k2");
  EXPECT_EQ(c.keys().size(), 3u);
}

TEST_F(Store, TornLastLineIsSkippedWithAWarningAndCutByTheNextWriter) {
  std::vector<std::string> warnings;
  {
    StoreWriter w(path_, warnings);
    w.append(sample(0));
    w.append(sample(1));
  }
  const std::string line = to_json(sample(2)).dump();
  append_raw(line.substr(0, line.size() / 2));  // a write cut short
  auto c = read_store(path_);
  EXPECT_EQ(c.samples.size(), 2u);
  EXPECT_TRUE(c.torn_tail);
  ASSERT_EQ(c.warnings.size(), 1u);
  EXPECT_NE(c.warnings[0].find("last line"), std::string::npos);

  {
    StoreWriter w(path_, warnings);  // cuts the torn line off
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("cut off a torn last line"), std::string::npos);
    w.append(sample(2));
  }
  c = read_store(path_);
  EXPECT_TRUE(c.warnings.empty());
  ASSERT_EQ(c.samples.size(), 3u);
  EXPECT_EQ(c.samples[2].key, "k2");
}

TEST_F(Store, TornOnlyLineIsSkipped) {
  const std::string line = to_json(sample(0)).dump();
  append_raw(line.substr(0, 40));
  const auto c = read_store(path_);
  EXPECT_TRUE(c.samples.empty());
  EXPECT_TRUE(c.torn_tail);
  EXPECT_EQ(c.warnings.size(), 1u);
}

TEST_F(Store, LastSampleWithoutNewlineIsKeptAndTheNextAppendStartsANewLine) {
  append_raw(to_json(sample(0)).dump());  // complete, but no newline (written by hand)
  std::vector<std::string> warnings;
  {
    StoreWriter w(path_, warnings);
    w.append(sample(1));
  }
  const auto c = read_store(path_);
  ASSERT_EQ(c.samples.size(), 2u);
  EXPECT_TRUE(warnings.empty());
}

TEST_F(Store, DamageBeforeTheLastLineIsAnErrorNamingTheLine) {
  std::vector<std::string> warnings;
  {
    StoreWriter w(path_, warnings);
    w.append(sample(0));
  }
  append_raw("{\"schema\": \"dtflop.sample\", trunc\n");
  {
    std::ofstream out(path_, std::ios::app);
    out << to_json(sample(1)).dump() << "\n";
  }
  try {
    read_store(path_);
    FAIL() << "a damaged store was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("line 2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("damaged"), std::string::npos) << e.what();
  }
}

TEST_F(Store, ForeignFileIsRejected) {
  save_profile(test::round_profile(), path_);  // a machine profile, pretty-printed JSON
  EXPECT_THROW(read_store(path_), InputError);
  std::vector<std::string> warnings;
  EXPECT_THROW(StoreWriter(path_, warnings), InputError);
  const std::string before = test::slurp_file(path_);
  EXPECT_EQ(before, to_json(test::round_profile()).dump(2) + "\n");  // untouched

  fs::remove(path_);
  append_raw("{\"schema\": \"dtflop.machine-profile\"}\n");  // one line, valid JSON, not a sample
  try {
    read_store(path_);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("not a dtflop sample store"), std::string::npos) << e.what();
  }
}

TEST_F(Store, OneWriterAtATime) {
  std::vector<std::string> warnings;
  StoreWriter first(path_, warnings);
  try {
    StoreWriter second(path_, warnings);
    FAIL() << "two writers on one store";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("another process"), std::string::npos) << e.what();
  }
}

// A fit or a validation takes one workload's samples: stores that mix workloads are refused with
// one line saying what to do, and filters pick what is kept.
TEST_F(Store, LoadingKeepsWhatTheFilterKeepsAndRefusesMixedWorkloads) {
  std::vector<std::string> warnings;
  {
    StoreWriter w(path_, warnings);
    for (int i = 0; i < 3; ++i) w.append(sample(i));
  }
  LoadedSamples l = load_samples({path_.string()}, {});
  EXPECT_EQ(l.samples.size(), 3u);
  l = load_samples({path_.string()}, {{}, {"k1"}});
  ASSERT_EQ(l.samples.size(), 1u);
  EXPECT_EQ(l.samples[0].key, "k1");
  EXPECT_THROW(load_samples({path_.string()}, {{"cuda-nothing"}, {}}), InputError);
  EXPECT_THROW(load_samples({(dir_ / "absent.jsonl").string()}, {}), InputError);

  Sample other = sample(7);
  other.workload = "dct";
  other.backend = "cpu-seq";
  other.parameters = nlohmann::json::object();
  {
    StoreWriter w(path_, warnings);
    w.append(other);
  }
  try {
    (void)load_samples({path_.string()}, {});
    FAIL() << "a store mixing workloads was loaded";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("more than one workload"), std::string::npos) << m;
    EXPECT_NE(m.find("dct"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
}

}  // namespace
}  // namespace dtflop::calib
