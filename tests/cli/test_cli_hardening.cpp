// Every input boundary of the `dtflop` executable, one test per class of bad input (issue 16):
// what crashed, overflowed, exhausted memory, showed an internal error, lost data or was
// accepted as nonsense. Each must end with exit status 2, one line on stderr naming the input,
// and every file that existed before byte-identical after.
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/cli/run_cli.hpp"
#include "tests/support/temp_dir.hpp"

namespace dtflop {
namespace {

namespace fs = std::filesystem;

class Hardening : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::fresh_test_dir("dtflop_hardening");
    fs::copy_file(test::source_path("docs/examples/h200.json"), dir_ / "m.json");
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& f) const { return (dir_ / f).string(); }
  void write(const std::string& f, const std::string& text) const {
    std::ofstream(dir_ / f, std::ios::binary) << text;
  }
  // Every regular file under the test folder, by path, with its bytes (links: their target's name).
  std::map<std::string, std::string> snapshot() const {
    std::map<std::string, std::string> out;
    for (const auto& e : fs::recursive_directory_iterator(dir_)) {
      if (e.is_symlink()) out[e.path().string()] = "link to " + fs::read_symlink(e.path()).string();
      else if (e.is_regular_file()) out[e.path().string()] = test::slurp(e.path());
      else out[e.path().string()] = "folder";
    }
    return out;
  }
  // Runs `args` (in the test folder) and expects bad input: status 2, nothing written, the error as
  // one line "dtflop: error: ..." containing `needle`, last on stderr (a verb that measures may say
  // what it is about to run first).
  void expect_refused(const std::string& args, const std::string& needle) {
    const auto before = snapshot();
    const auto r = test::run_dtflop(args, dir_.string());
    EXPECT_EQ(r.status, 2) << args << "\n" << r.err;
    const auto last = r.err.rfind('\n', r.err.size() >= 2 ? r.err.size() - 2 : 0);
    const std::string error = last == std::string::npos ? r.err : r.err.substr(last + 1);
    EXPECT_EQ(error.rfind("dtflop: error:", 0), 0u) << args << "\n" << r.err;
    EXPECT_EQ(test::count_lines(error), 1) << args << "\n" << r.err;
    EXPECT_EQ(r.err.find("dtflop: error:"), r.err.size() - error.size()) << args << ": more than one error line";
    EXPECT_NE(error.find(needle), std::string::npos) << args << "\n" << r.err;
    const auto after = snapshot();
    for (const auto& [file, bytes] : before) {
      auto it = after.find(file);
      EXPECT_TRUE(it != after.end() && it->second == bytes) << args << ": '" << file << "' changed or went";
    }
    for (const auto& [file, bytes] : after)
      EXPECT_TRUE(before.count(file)) << args << ": wrote '" << file << "'";
  }

  // A sample store of one small measured configuration (rbe cpu-seq), and its line as JSON.
  nlohmann::json one_sample() {
    write("plan.json", R"({"configs": [{"grid": "64x48", "kernel": "3x3"}]})");
    const auto r = test::run_dtflop("sweep rbe -b cpu-seq --plan " + path("plan.json") + " --store " +
                                    path("one.jsonl") + " --steps 1 --reps 2 --warmup 0 -q");
    EXPECT_EQ(r.status, 0) << r.err;
    const std::string line = test::slurp(dir_ / "one.jsonl");
    fs::remove(dir_ / "one.jsonl");
    return nlohmann::json::parse(line);
  }

  fs::path dir_;
};

std::string nested(int depth, char open, char close) { return std::string(depth, open) + std::string(depth, close); }

// ---- Crashes -----------------------------------------------------------------------------

TEST_F(Hardening, DeeplyNestedJsonIsRefusedNotACrash) {
  write("list.json", nested(100000, '[', ']'));
  expect_refused("predict rbe -b cpu-seq --machine list.json", "list.json");
  std::string obj;
  for (int i = 0; i < 100000; ++i) obj += "{\"a\":";
  obj += "1" + std::string(100000, '}');
  write("object.json", obj);
  expect_refused("predict rbe -b cpu-seq --machine object.json", "object.json");
  auto s = one_sample();
  std::string line = s.dump();
  line.insert(line.size() - 1, ",\"detail\":" + nested(100000, '[', ']'));
  write("deep.jsonl", line + "\n");
  expect_refused("validate --store deep.jsonl --machine m.json", "deep.jsonl");
}

TEST_F(Hardening, ThreadsBeyondTheMachineAreRefused) {
  const std::string more = std::to_string(std::max(1u, std::thread::hardware_concurrency()) + 1);
  expect_refused("run rbe -b cpu-par --grid 64 --kernel 3 --steps 1 --reps 2 --warmup 0 --threads " + more,
                 "--threads " + more);
  expect_refused("run dct -b cpu-par --size 256 --dots 20 --support 10 --steps 1 --reps 2 --warmup 0 --threads " + more,
                 "--threads " + more);
  expect_refused("run rbe -b cpu-par --threads 100000", "--threads 100000");
}

// ---- Overflow ------------------------------------------------------------------------------

TEST_F(Hardening, NumbersBeyondTheirTypeAreRefused) {
  std::string profile = test::slurp(dir_ / "m.json");
  const auto at = profile.find("\"value\": ");
  ASSERT_NE(at, std::string::npos);
  profile.replace(at, profile.find(',', at) - at, "\"value\": 1e309");
  write("big.json", profile);
  expect_refused("predict rbe -b cpu-seq --machine big.json", "big.json");
  expect_refused("predict dct -b cpu-seq --radius 1e309", "--radius");
  expect_refused("fields --specimen uniform:size=400x300 --roi 0,0,100000,100000 -o out", "--roi");
}

// ---- Resource exhaustion ------------------------------------------------------------------

TEST_F(Hardening, SizesAreEstimatedBeforeAllocating) {
  expect_refused("specimen uniform:size=300x200,radius=0.01 -o sp", "radius");
  expect_refused("specimen uniform:size=16000x1500,radius=1,pitch=2 -o sp", "dots");
  expect_refused("validate --store /dev/zero --machine m.json", "/dev/zero");
  expect_refused("fields --reference m.json --frames 'x%1000000000d.png' -o out", "--frames");
  expect_refused("run rbe -b cpu-seq --steps 2147483647", "--steps");
  // A PNG whose header declares 100000x100000 pixels (a few bytes on disk).
  std::string png = "\x89PNG\r\n\x1a\n";
  png += std::string("\0\0\0\x0dIHDR", 8);
  for (std::uint32_t v : {100000u, 100000u})
    for (int s = 24; s >= 0; s -= 8) png += static_cast<char>((v >> s) & 0xff);
  png += std::string("\x08\0\0\0\0\0\0\0\0", 9);
  write("huge.png", png);
  expect_refused("fields --reference huge.png --frames huge.png -o out", "huge.png");
}

// ---- Input errors shown as internal errors -----------------------------------------------

TEST_F(Hardening, InputErrorsAreNotInternalErrors) {
  fs::create_directories(dir_ / "plans");
  expect_refused("sweep rbe -b cpu-seq --plan plans --store s.jsonl", "plans");
  write("exists.txt", "keep me\n");
  expect_refused("specimen uniform:size=400x300 -o exists.txt", "exists.txt");
  expect_refused("fields --specimen uniform:size=400x300 -o exists.txt", "exists.txt");
  write("bad.json", "{\"schema\": ");
  expect_refused("predict rbe -b cpu-seq --machine bad.json", "bad.json");
}

// ---- Data lost ----------------------------------------------------------------------------

TEST_F(Hardening, AnOutputNeverReplacesAnInputALinkOrADevice) {
  write("s.jsonl", one_sample().dump() + "\n");
  expect_refused("calibrate --store s.jsonl --machine m.json -o s.jsonl --variant seed", "s.jsonl");
  expect_refused("calibrate --store s.jsonl --machine m.json -o m.json --variant seed", "m.json");
  expect_refused("predict rbe -b cpu-seq --json -o /dev/full", "/dev/full");
  write("target.json", "untouched\n");
  fs::create_symlink("target.json", dir_ / "link.json");
  expect_refused("predict rbe -b cpu-seq --json -o link.json", "link.json");
  EXPECT_TRUE(fs::is_symlink(dir_ / "link.json"));
  expect_refused("sweep rbe -b cpu-seq --plan random:1 --store /dev/null", "/dev/null");
}

TEST_F(Hardening, AWrittenOutputIsWholeAndLeavesNoTemporaryFile) {
  const auto r = test::run_dtflop("predict rbe -b cpu-seq --json -o " + path("p.json"));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(test::slurp(dir_ / "p.json")), nlohmann::json::parse(r.out));
  for (const auto& e : fs::directory_iterator(dir_))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

// ---- Nonsense accepted --------------------------------------------------------------------

TEST_F(Hardening, NonsenseOnTheCommandLineIsRefused) {
  expect_refused("predict dct -b cpu-seq --dots 0", "--dots");
  expect_refused("sweep --seed 18446744073709551616 rbe -b cpu-seq --plan random:1 --store s.jsonl", "--seed");
  expect_refused("sweep rbe -b cpu-seq --plan random:1 --store s.jsonl --steps 0", "--steps");
  expect_refused("sweep rbe -b cpu-seq --plan random:1 --store s.jsonl --reps 0", "--reps");
  expect_refused("sweep rbe -b cpu-seq --plan random:1 --store s.jsonl --warmup -1", "--warmup");
  expect_refused("fields --specimen uniform:size=400x300 --search-radius nan -o out", "--search-radius");
  expect_refused("fields --specimen uniform:size=400x300 --support infpx -o out", "infpx");
  // A support too small for any point to hold enough dots: said why, not a blank field and exit 0.
  expect_refused("fields --specimen uniform:size=400x300 --support 12.5px -o out", "no point has a valid value");
  expect_refused("fields --specimen uniform:size=400x300 --strain-range 5:-5 -o out", "--strain-range");
  expect_refused("validate --store s.jsonl --machine m.json --target-mean inf", "--target-mean");
  expect_refused("calibrate --store s.jsonl --machine m.json -o f.json --loss-scale nan", "--loss-scale");
}

TEST_F(Hardening, NonsenseSpecimensAreRefused) {
  expect_refused("specimen uniform:size=400x300,count=5 -o sp", "count");
  expect_refused("specimen uniform:size=400x300,strain=-1 -o sp", "strain");
  expect_refused("specimen uniform:size=400x300,ground=100,ink=100 -o sp", "ink");
  expect_refused("specimen uniform:size=400x300,pattern=random,gap=-5 -o sp", "gap");
  expect_refused("specimen uniform:size=400x300,radius=5,radius=6 -o sp", "radius");
  expect_refused("specimen uniform:size=400x300,dx=3 -o sp", "dx");
}

TEST_F(Hardening, NonsenseSamplesAreRefused) {
  const nlohmann::json good = one_sample();
  auto foo = good;
  foo["workload"] = "foo";
  write("foo.jsonl", foo.dump() + "\n");
  expect_refused("validate --store foo.jsonl --machine m.json", "foo");
  auto nx = good;
  nx["parameters"]["grid"] = {-1, 48};
  write("nx.jsonl", nx.dump() + "\n");
  expect_refused("validate --store nx.jsonl --machine m.json", "--grid");
  auto zero = good;
  for (auto& [name, c] : zero["components"].items())
    for (auto& v : c["values"]) v = 0.0;
  write("zero.jsonl", good.dump() + "\n" + zero.dump() + "\n");
  expect_refused("validate --store zero.jsonl --machine m.json", "total");
  expect_refused("calibrate --store zero.jsonl --machine m.json -o f.json --variant seed", "total");
}

}  // namespace
}  // namespace dtflop
