// The DCT workload behind the contract: its parameter space and messages, the counts a Run
// declares before its first frame against what the frames did, the plans, and the store key.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <thread>

#include "model/errors.hpp"
#include "tests/support/temp_dir.hpp"
#include "workloads/dct/backend.hpp"
#include "workloads/dct/workload.hpp"
#include "workloads/workload.hpp"

namespace dtflop::dct {
namespace {

namespace wl = ::dtflop::workload;
using nlohmann::json;

const wl::Workload& W() { return workload(); }

// The InputError message of validating `given` on `backend` ("" when it is valid).
std::string rejection(const json& given, const std::string& backend = "cpu-seq") {
  try {
    W().validate(given, W().backend(backend));
  } catch (const InputError& e) {
    return e.what();
  }
  return {};
}

TEST(DctWorkload, IsRegisteredWithItsBackendsDeclaredOnce) {
  EXPECT_EQ(&wl::find("dct"), &W());
  std::vector<std::string> names;
  for (const auto& b : W().backends()) names.push_back(b->name());
  EXPECT_EQ(names, backend_names());
  EXPECT_EQ(names, (std::vector<std::string>{"cpu-seq", "cpu-par", "cuda"}));
  EXPECT_FALSE(W().backend("cpu-seq").needs_gpu());
  EXPECT_FALSE(W().backend("cpu-par").needs_gpu());
  EXPECT_TRUE(W().backend("cuda").needs_gpu());
  EXPECT_EQ(W().backend("cuda").unavailable().empty(), cuda_unavailable_reason().empty());
  EXPECT_TRUE(W().backend("cpu-par").unavailable().empty());
  try {
    make_backend("opencl", PipelineOptions{});
    FAIL() << "an unknown backend was made";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cpu-seq, cpu-par, cuda"), std::string::npos) << e.what();
  }
  EXPECT_EQ(W().step_name(), "frame");
}

TEST(DctWorkload, DefaultsFillEveryApplicableParameter) {
  const wl::Config seq = W().validate(json::object(), W().backend("cpu-seq"));
  EXPECT_EQ(seq["size"], json::array({1600, 1200}));
  EXPECT_EQ(seq["points"], json::array({32, 32}));
  EXPECT_EQ(seq["interp"], "mls");
  EXPECT_FALSE(seq.contains("threads"));
  EXPECT_FALSE(seq.contains("host-memory"));
  const wl::Config par = W().validate(json::object(), W().backend("cpu-par"));
  EXPECT_EQ(par["threads"].get<int>(), static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
  const wl::Config gpu = W().validate(json::object(), W().backend("cuda"));
  EXPECT_EQ(gpu["host-memory"], "pinned");
  EXPECT_FALSE(gpu.contains("threads"));
}

TEST(DctWorkload, RejectsWithOneLineSayingWhatToDo) {
  // Zero points: outside the grid's domain.
  std::string m = rejection({{"points", "0x32"}});
  EXPECT_NE(m.find("--points"), std::string::npos) << m;
  EXPECT_NE(m.find("at least 1"), std::string::npos) << m;
  m = rejection({{"points", json::array({0, 32})}});
  EXPECT_NE(m.find("[1, 256]"), std::string::npos) << m;
  // An image the configuration cannot hold.
  m = rejection({{"size", "640x480"}, {"dots", 3000}, {"radius", 10}});
  EXPECT_NE(m.find("cannot hold"), std::string::npos) << m;
  EXPECT_NE(m.find("give fewer dots"), std::string::npos) << m;
  m = rejection({{"size", "64x64"}, {"radius", 30}, {"dots", 6}, {"support", 6}});
  EXPECT_NE(m.find("leaves no room"), std::string::npos) << m;
  // More than 24 MP.
  m = rejection({{"size", "6000x4100"}});
  EXPECT_NE(m.find("24 MP"), std::string::npos) << m;
  // Unknown parameter; one that does not apply to the backend.
  m = rejection({{"frames", 3}});
  EXPECT_NE(m.find("has no parameter 'frames'"), std::string::npos) << m;
  m = rejection({{"threads", 2}}, "cpu-seq");
  EXPECT_NE(m.find("--threads applies to cpu-par only, not cpu-seq"), std::string::npos) << m;
  m = rejection({{"host-memory", "pageable"}}, "cpu-par");
  EXPECT_NE(m.find("--host-memory applies to cuda only"), std::string::npos) << m;
  // Support larger than the dots; fewer than the quadratic basis needs.
  m = rejection({{"dots", 20}, {"support", 30}});
  EXPECT_NE(m.find("--support <= --dots"), std::string::npos) << m;
  m = rejection({{"support", 5}});
  EXPECT_NE(m.find("--support 5 is outside [6, 1000]"), std::string::npos) << m;
  // FE ignores the support: the same dots are fine.
  EXPECT_EQ(rejection({{"dots", 20}, {"support", 30}, {"interp", "fe"}, {"size", "640x480"}}), "");
  // Non-finite and bad values.
  m = rejection({{"radius", "nan"}});
  EXPECT_NE(m.find("not a finite number"), std::string::npos) << m;
  m = rejection({{"bits", "12"}});
  EXPECT_NE(m.find("use one of 8, 16"), std::string::npos) << m;
  // Odd-sized frames are frames like any other, on every backend.
  EXPECT_EQ(rejection({{"size", "641x481"}, {"dots", 100}}, "cuda"), "");
  EXPECT_EQ(rejection({{"size", "641x481"}, {"dots", 100}}, "cpu-seq"), "");
  // Every message is one line.
  for (const json& bad : {json{{"points", "0x32"}}, json{{"dots", 20}, {"support", 30}}})
    EXPECT_EQ(rejection(bad).find('\n'), std::string::npos);
}

TEST(DctWorkload, StoreKeyNamesEveryParameterInSpecOrder) {
  const wl::Backend& par = W().backend("cpu-par");
  const wl::Config c = W().validate({{"size", "800x600"}, {"dots", 150}, {"radius", 6.5}, {"points", "24x16"},
                                     {"support", 30}, {"bits", "16"}, {"threads", 2}, {"specimen-seed", 9}},
                                    par);
  EXPECT_EQ(W().key(par, c),
            "dct/cpu-par/size=800x600/dots=150/radius=6.5/points=24x16/support=30/interp=mls/bits=16/threads=2/specimen-seed=9");
  const wl::Backend& gpu = W().backend("cuda");
  const wl::Config g = W().validate({{"host-memory", "pageable"}}, gpu);
  EXPECT_NE(W().key(gpu, g).find("/host-memory=pageable/"), std::string::npos) << W().key(gpu, g);
  // Typed on the command line or given as JSON: one key.
  EXPECT_EQ(W().key(par, W().validate({{"dots", "150"}, {"size", "800x600"}}, par)),
            W().key(par, W().validate({{"dots", 150}, {"size", json::array({800, 600})}}, par)));
}

// ---- Counts before the frame ----------------------------------------------------------------

struct Case {
  std::string backend;
  json given;
};
void PrintTo(const Case& c, std::ostream* os) { *os << c.backend << " " << c.given.dump(); }

class CountsBeforeFrame : public ::testing::TestWithParam<Case> {};

TEST_P(CountsBeforeFrame, DeclaredCountsAreWhatTheFramesDid) {
  const Case& k = GetParam();
  const wl::Backend& b = W().backend(k.backend);
  if (const std::string why = b.unavailable(); !why.empty()) GTEST_SKIP() << why;
  const wl::Config c = W().validate(k.given, b);
  const std::int64_t steps = 2;
  auto run = b.prepare(c, steps);
  const CostCounts declared = run->counts();
  // Declared before any frame; a repetition is `steps` frames of the same counts.
  const json before = run->detail();
  EXPECT_FALSE(before.contains("frame_dots"));
  EXPECT_EQ(run->check(), "no frame was processed");
  const wl::PhaseTimes t = run->repeat();
  EXPECT_EQ(run->check(), "");
  EXPECT_EQ(run->counts(), declared);
  EXPECT_GT(t.wall, 0);
  if (b.needs_gpu()) {
    EXPECT_EQ(declared.N_C, 0);
    EXPECT_EQ(declared.transfers_CG, 2 * steps);
    EXPECT_GT(t.G_events, 0);
  } else {
    EXPECT_EQ(t.C, t.wall);
    EXPECT_EQ(declared.N_CG + declared.N_GC + declared.launches, 0);
  }
  // Dots, points and MLS support entries are the configuration's, so the estimate without an
  // image prices them exactly; its pixel classes are within 15% of the frame's.
  const json d = run->detail();
  const auto [nx, ny] = wl::get_size2(c, "points");
  EXPECT_EQ(d["reference_dots"].get<std::int64_t>(), wl::get_int(c, "dots"));
  EXPECT_EQ(d["frame_dots"].get<std::int64_t>(), wl::get_int(c, "dots"));
  EXPECT_EQ(d["matched"].get<std::int64_t>(), wl::get_int(c, "dots"));
  EXPECT_EQ(d["points"].get<std::int64_t>(), nx * ny);
  const bool mls = wl::get_text(c, "interp") == "mls";
  const auto entries = d["support_entries"].get<std::int64_t>();
  const FrameShape e = estimated_shape(c);
  EXPECT_EQ(e.dots, wl::get_int(c, "dots"));
  if (mls) {
    EXPECT_EQ(entries, nx * ny * wl::get_int(c, "support"));
    EXPECT_EQ(e.support_entries, entries);
  } else {  // FE's recovery triangles: estimated before the reference (counts.cpp), within 2x
    EXPECT_GT(entries, 0);
    EXPECT_LT(static_cast<double>(e.support_entries), 2.0 * static_cast<double>(entries));
    EXPECT_GT(static_cast<double>(e.support_entries), 0.5 * static_cast<double>(entries));
  }
  const auto window = static_cast<double>(d["window_pixels"].get<std::int64_t>());
  EXPECT_NEAR(static_cast<double>(e.window_pixels), window, 0.15 * window);
  const CostCounts est = b.counts(c, nullptr);
  const CostCounts per_frame = run->counts();
  if (b.needs_gpu()) {
    EXPECT_EQ(est.transfers_GC * steps, per_frame.transfers_GC);
    EXPECT_EQ(est.launches * steps, per_frame.launches);
  } else {
    EXPECT_NEAR(static_cast<double>(est.N_C * steps), static_cast<double>(per_frame.N_C), 0.15 * static_cast<double>(per_frame.N_C));
  }
}

INSTANTIATE_TEST_SUITE_P(
    RenderedSpecimens, CountsBeforeFrame,
    ::testing::Values(
        Case{"cpu-seq", {{"size", "640x480"}, {"dots", 120}, {"radius", 6}, {"points", "16x12"}, {"support", 20}}},
        Case{"cpu-seq", {{"size", "500x400"}, {"dots", 60}, {"radius", 8}, {"points", "8x8"}, {"interp", "fe"},
                         {"bits", "16"}, {"specimen-seed", 5}}},
        Case{"cpu-par", {{"size", "640x480"}, {"dots", 150}, {"radius", 5}, {"points", "24x16"}, {"support", 40},
                         {"threads", 2}, {"specimen-seed", 3}}},
        Case{"cpu-par", {{"size", "700x500"}, {"dots", 80}, {"radius", 7.5}, {"points", "10x10"}, {"interp", "fe"},
                         {"threads", 2}}},
        Case{"cuda", {{"size", "640x480"}, {"dots", 120}, {"radius", 6}, {"points", "16x12"}, {"support", 20}}},
        Case{"cuda", {{"size", "640x480"}, {"dots", 100}, {"radius", 6}, {"points", "16x12"}, {"interp", "fe"},
                      {"bits", "16"}, {"host-memory", "pageable"}}}),
    [](const ::testing::TestParamInfo<Case>& p) {
      std::string name = p.param.backend;
      name.erase(std::remove(name.begin(), name.end(), '-'), name.end());
      return name + "_" + std::to_string(p.index);
    });

TEST(DctWorkload, CheckNamesWhatDiffers) {
  FrameShape a;
  a.components = 100;
  a.window_pixels = 5000;
  FrameShape b = a;
  EXPECT_EQ(shape_difference(a, b), "");
  b.components = 101;
  b.window_pixels = 5008;
  EXPECT_EQ(shape_difference(a, b), "components 101 (declared 100), window pixels 5008 (declared 5000)");
  CostCounts x = cuda_counts(a, HostMemory::pinned), y = x;
  EXPECT_EQ(counts_difference(x, y), "");
  y.launches += 1;
  y.host_memory = HostMemory::pageable;
  EXPECT_EQ(counts_difference(x, y), "launches 12 (declared 11), host memory pageable (declared pinned)");
}

TEST(DctWorkload, PrepareRefusesBadSteps) {
  const wl::Backend& b = W().backend("cpu-seq");
  const wl::Config c = W().validate({{"size", "320x240"}, {"dots", 30}, {"support", 10}}, b);
  EXPECT_THROW(b.prepare(c, 0), InputError);
}

// ---- Plans ----------------------------------------------------------------------------------

TEST(DctPlans, NamedPlansHoldTheSeedsSizes) {
  const wl::Backend& b = W().backend("cpu-seq");
  const auto sup = W().plan("seed-support", b, 1);
  ASSERT_EQ(sup.configs.size(), 10u);
  for (std::size_t i = 0; i < sup.configs.size(); ++i) {
    const auto& c = sup.configs[i];
    EXPECT_EQ(wl::get_int(c, "support"), 10 * static_cast<std::int64_t>(i + 1));
    EXPECT_EQ(wl::get_int(c, "dots"), 369);
    EXPECT_EQ(wl::get_size2(c, "points"), (std::pair<std::int64_t, std::int64_t>{32, 32}));
  }
  const auto pts = W().plan("seed-points", b, 1);
  ASSERT_EQ(pts.configs.size(), 8u);
  std::int64_t last = 0;
  for (const auto& c : pts.configs) {
    const auto [nx, ny] = wl::get_size2(c, "points");
    EXPECT_GT(nx * ny, last);
    last = nx * ny;
    EXPECT_EQ(wl::get_int(c, "dots"), 369);
  }
  EXPECT_EQ(wl::get_size2(pts.configs.front(), "points").first * wl::get_size2(pts.configs.front(), "points").second,
            384);
  EXPECT_EQ(last, 2048);
  const auto img = W().plan("image-sizes", b, 1);
  ASSERT_EQ(img.configs.size(), 6u);
  EXPECT_EQ(wl::get_int(img.configs.front(), "dots"), 560);
  EXPECT_EQ(wl::get_int(img.configs.back(), "dots"), 1611);
  EXPECT_EQ(wl::get_size2(img.configs.back(), "size"), (std::pair<std::int64_t, std::int64_t>{6000, 4000}));
  for (std::size_t i = 1; i < img.configs.size(); ++i)
    EXPECT_GT(wl::get_int(img.configs[i], "dots"), wl::get_int(img.configs[i - 1], "dots"));
  // Every named plan is described for --help.
  for (const auto& [name, what] : W().plan_names()) {
    EXPECT_FALSE(W().plan(name, b, 1).description.empty()) << name;
    EXPECT_FALSE(what.empty());
  }
}

TEST(DctPlans, RandomPlanIsDeterministicAndInsideItsRanges) {
  const wl::Backend& b = W().backend("cuda");  // validating needs no device
  const auto p = W().plan("random:60", b, 7);
  ASSERT_EQ(p.configs.size(), 60u);
  EXPECT_EQ(W().plan("random:60", b, 7).configs, p.configs);
  EXPECT_NE(W().plan("random:60", b, 8).configs, p.configs);
  std::set<std::string> interps, bits, memory;
  std::set<std::string> keys;
  for (const auto& c : p.configs) {
    const auto [w, h] = wl::get_size2(c, "size");
    EXPECT_LE(w * h, 24'000'000);
    EXPECT_GE(w * h, 250'000);
    EXPECT_GE(wl::get_int(c, "dots"), 6);
    EXPECT_LE(wl::get_int(c, "dots"), 1611);
    EXPECT_GE(wl::get_real(c, "radius"), 4);
    EXPECT_LE(wl::get_real(c, "radius"), 24);
    const auto [nx, ny] = wl::get_size2(c, "points");
    EXPECT_GE(nx * ny, 300);
    EXPECT_LE(nx * ny, 2200);
    EXPECT_GE(wl::get_int(c, "support"), 6);
    EXPECT_LE(wl::get_int(c, "support"), 100);
    interps.insert(wl::get_text(c, "interp"));
    bits.insert(wl::get_text(c, "bits"));
    memory.insert(wl::get_text(c, "host-memory"));
    keys.insert(W().key(b, c));
  }
  EXPECT_EQ(interps, (std::set<std::string>{"fe", "mls"}));
  EXPECT_EQ(bits, (std::set<std::string>{"16", "8"}));
  EXPECT_EQ(memory, (std::set<std::string>{"pageable", "pinned"}));
  EXPECT_EQ(keys.size(), 60u);  // no configuration twice
  // A held-out plan shares no configuration with a fit plan of another seed.
  for (const auto& c : W().plan("random:60", b, 1).configs) EXPECT_EQ(keys.count(W().key(b, c)), 0u);
  for (const char* bad : {"random:0", "random:x", "random:", "random:100001"}) {
    try {
      W().plan(bad, b, 1);
      FAIL() << bad;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("random:50"), std::string::npos) << e.what();
    }
  }
}

TEST(DctPlans, PlanFilesAreValidatedAgainstTheSpace) {
  const auto dir = test::fresh_test_dir("dct_plans");
  const auto good = dir / "plan.json";
  std::ofstream(good) << R"({"description": "two", "configs": [{"size": "640x480", "dots": 50},
                           {"size": [800, 600], "dots": 90, "interp": "fe"}]})";
  const wl::Backend& b = W().backend("cpu-seq");
  const auto p = W().plan(good.string(), b, 1);
  ASSERT_EQ(p.configs.size(), 2u);
  EXPECT_EQ(p.description, "two");
  EXPECT_EQ(wl::get_text(p.configs[1], "interp"), "fe");
  const auto bad = dir / "bad.json";
  std::ofstream(bad) << R"({"configs": [{"dots": 50}, {"points": "0x4"}]})";
  try {
    W().plan(bad.string(), b, 1);
    FAIL() << "a plan with zero points was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("configs[1]"), std::string::npos) << e.what();
  }
  EXPECT_THROW(W().plan((dir / "missing.json").string(), b, 1), InputError);
}

TEST(DctPlans, ProtocolDefaults) {
  const auto cpu = W().defaults(W().backend("cpu-seq"));
  const auto gpu = W().defaults(W().backend("cuda"));
  EXPECT_GE(cpu.steps, 1);
  EXPECT_GT(gpu.steps, cpu.steps);
  EXPECT_GE(gpu.warmup, 1);
  EXPECT_GE(cpu.repetitions, 3);
}

}  // namespace
}  // namespace dtflop::dct
