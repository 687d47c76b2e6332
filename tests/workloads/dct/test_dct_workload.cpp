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
  EXPECT_EQ(par["threads"].get<int>(), 0);  // every hardware thread of the machine that runs or is predicted
  EXPECT_EQ(W().backend("cpu-par").counts(par, nullptr).cpu_threads,
            static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
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

TEST(DctWorkload, AddedParametersKeepOldKeysAndAreCheckedWithMessages) {
  const wl::Backend& seq = W().backend("cpu-seq");
  const wl::Backend& gpu = W().backend("cuda");
  // A sample measured before these parameters existed holds none of them: it validates to the
  // defaults, which are what it did, and keeps its key.
  const json old = {{"size", "800x600"}, {"dots", 150}, {"radius", 6.5}, {"points", "24x16"}, {"support", 30},
                    {"interp", "mls"}, {"bits", "8"}, {"specimen-seed", 9}};
  const wl::Config c = W().validate(old, seq);
  EXPECT_EQ(c["weight"], "cubic");
  EXPECT_EQ(c["threshold"], "otsu");
  EXPECT_EQ(c["threshold-level"], 128.0);
  EXPECT_EQ(c["support-radius"], 0.0);
  EXPECT_EQ(W().key(seq, c), "dct/cpu-seq/size=800x600/dots=150/radius=6.5/points=24x16/support=30/interp=mls/bits=8/"
                             "specimen-seed=9");
  const PipelineOptions o = pipeline_options(c, "cpu-seq");
  EXPECT_EQ(o.mls.weight, Weight::cubic_spline);
  EXPECT_EQ(o.analysis.method, ThresholdMethod::otsu);
  EXPECT_EQ(o.mls.support.kind, Support::Kind::dots);
  const wl::Config g = W().validate(old, gpu);
  EXPECT_EQ(W().key(gpu, g), "dct/cuda/size=800x600/dots=150/radius=6.5/points=24x16/support=30/interp=mls/bits=8/"
                             "host-memory=pinned/specimen-seed=9");
  // Given the default, the key is the same; any other value is in it, in spec order.
  json d = old;
  d["weight"] = "cubic";
  d["block-dots"] = 128;
  EXPECT_EQ(W().key(gpu, W().validate(d, gpu)), W().key(gpu, g));
  json x = old;
  x["weight"] = "gaussian";
  x["threshold"] = "fixed";
  x["threshold-level"] = 100;
  x["block-points"] = 64;
  EXPECT_EQ(W().key(gpu, W().validate(x, gpu)),
            "dct/cuda/size=800x600/dots=150/radius=6.5/points=24x16/support=30/interp=mls/weight=gaussian/"
            "threshold=fixed/threshold-level=100.0/bits=8/host-memory=pinned/block-points=64/specimen-seed=9");
  json r = old;
  r.erase("support");
  r["support-radius"] = "120.5";
  EXPECT_NE(W().key(seq, W().validate(r, seq)).find("/support=40/interp=mls/support-radius=120.5/"), std::string::npos);
  EXPECT_EQ(W().label(W().validate(r, seq)), "800x600 150d r6.5 24x16p r120.5px");
  EXPECT_EQ(W().label(W().validate(x, gpu)), "800x600 150d r6.5 24x16p s30 gaussian fixed:100 b256/64/128");

  // Messages: one line each, naming the parameter and what to do.
  auto has = [](const std::string& m, const std::string& what) {
    EXPECT_NE(m.find(what), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  };
  has(rejection({{"weight", "wendland"}}), "use one of cubic, quartic, gaussian");
  has(rejection({{"threshold", "triangle"}}), "use one of otsu, fixed, adaptive");
  has(rejection({{"threshold-level", 100}}), "--threshold-level 100 applies to --threshold fixed only");
  has(rejection({{"threshold", "fixed"}, {"threshold-level", 300}}), "outside [1, 254]");
  has(rejection({{"threshold", "adaptive"}}, "cuda"), "adaptive runs on cpu-seq and cpu-par only");
  EXPECT_EQ(rejection({{"threshold", "adaptive"}}, "cpu-par"), "");
  has(rejection({{"support", 60}, {"support-radius", 150}}), "give one");
  has(rejection({{"support-radius", 3}, {"radius", 8}}), "smaller than the dots");
  has(rejection({{"support-radius", -1}}), "outside [0, 16384]");
  EXPECT_EQ(rejection({{"support-radius", 150}, {"interp", "fe"}}), "");
  has(rejection({{"block-pixels", 100}}, "cuda"), "--block-pixels 100 is not a multiple of 32");
  has(rejection({{"block-dots", 2048}}, "cuda"), "outside [32, 1024]");
  has(rejection({{"block-points", 64}}, "cpu-seq"), "applies to cuda only");
  EXPECT_EQ(rejection({{"block-pixels", 1024}, {"block-points", 32}, {"block-dots", 992}}, "cuda"), "");
  // A support radius with fewer dots than asked of --support is no conflict: the radius decides.
  EXPECT_EQ(rejection({{"dots", 20}, {"support-radius", 300}}), "");
}

// A store measured before the parameters were added (the H100's tuning of the open-hole plate,
// cpu-seq, cpu-par and cuda): every sample's parameters validate to a configuration whose key
// is the sample's key, and whose counts are the sample's (the defaults priced as before).
TEST(DctWorkload, AStoreMeasuredBeforeTheAddedParametersKeepsItsKeysAndCounts) {
  const auto path = std::filesystem::path(DTFLOP_SOURCE_DIR) / "results/tuning/h100-2026-11-24/dct/store.jsonl";
  std::ifstream in(path);
  ASSERT_TRUE(in) << path;
  std::string line;
  int samples = 0;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    const json j = json::parse(line);
    const wl::Backend& b = W().backend(j.at("backend").get<std::string>());
    for (const char* added : {"weight", "threshold", "threshold-level", "support-radius", "block-pixels"})
      EXPECT_FALSE(j.at("parameters").contains(added));
    const wl::Config c = W().validate(j.at("parameters"), b);
    EXPECT_EQ(W().key(b, c), j.at("key").get<std::string>());
    // The frame's counts as the sample declared them, repetitions of `steps` frames (cuda's
    // multiprocessor-free counts; the pixel classes are the rendered frame's, so compare the
    // terms the configuration alone fixes: the fields' FLOPs through N_C or N_G's difference).
    const CostCounts est = b.counts(c, nullptr);
    const json& k = j.at("counts");
    const std::int64_t steps = j.at("steps").get<std::int64_t>();
    EXPECT_EQ(est.launches * steps, k.at("launches").get<std::int64_t>()) << j.at("key");
    // The store predates the cuda records' single copy (2026-11-27): its frames (Otsu's threshold)
    // copied back the count and the threshold apart and the records in 7 arrays, 7 copies more.
    const std::int64_t copies_since = b.name() == "cuda" ? 7 : 0;
    EXPECT_EQ((est.transfers_GC + copies_since) * steps, k.at("transfers_GC").get<std::int64_t>()) << j.at("key");
    ++samples;
  }
  EXPECT_EQ(samples, 30);
}

// The pipeline a configuration makes does what its parameters say (a parameter ignored on the
// way would fail here): the weight changes the fields as the library's own weight does, the
// threshold is the one asked for, the support is the radius, on both CPU backends.
TEST(DctWorkload, ParametersReachThePipeline) {
  const json base = {{"size", "640x480"}, {"dots", 120}, {"radius", 6}, {"points", "12x9"}, {"support", 30}};
  for (const char* backend : {"cpu-seq", "cpu-par"}) {
    SCOPED_TRACE(backend);
    const wl::Backend& b = W().backend(backend);
    auto frame = [&](const json& given) {
      const wl::Config c = W().validate(given, b);
      const Specimen sp = specimen_of(c);
      auto p = make_backend(backend, pipeline_options(c, backend));
      p->set_reference(sp.reference_image());
      struct R {
        FrameOutput out;
        MlsTable table;
        std::vector<Vec2> reference;
      };
      return R{p->process(sp.deformed_image()), p->mls_table(), p->reference_positions()};
    };
    const auto cubic = frame(base);
    ASSERT_EQ(cubic.out.dots.size(), 120u);
    // Weight: the fields are those of the library's MLS with that weight on the same dots, and
    // differ from the cubic spline's.
    for (const char* w : {"quartic", "gaussian"}) {
      json g = base;
      g["weight"] = w;
      const auto r = frame(g);
      MlsOptions mo;
      mo.weight = weight_from_string(w);
      const auto expect = evaluate_mls(r.table, r.reference, r.out.displacement, r.out.tracked, mo);
      ASSERT_EQ(expect.size(), r.out.fields.size());
      double differs = 0;
      int ok = 0;
      for (std::size_t m = 0; m < r.out.fields.size(); ++m) {
        EXPECT_EQ(r.out.fields[m].status, expect[m].status);
        if (r.out.fields[m].status != PointStatus::ok || cubic.out.fields[m].status != PointStatus::ok) continue;
        ++ok;
        EXPECT_NEAR(r.out.fields[m].exx, expect[m].exx, 1e-12);
        differs = std::max(differs, std::abs(r.out.fields[m].exx - cubic.out.fields[m].exx));
      }
      EXPECT_GT(ok, 50);
      EXPECT_GT(differs, 1e-7) << w;
      EXPECT_EQ(r.out.shape.weight, weight_from_string(w));
    }
    // Threshold: Otsu's is computed from the frame; fixed is the level; adaptive has none.
    EXPECT_NE(cubic.out.stats.threshold, 100);
    json f = base;
    f["threshold"] = "fixed";
    f["threshold-level"] = 100;
    EXPECT_EQ(frame(f).out.stats.threshold, 100);
    f["threshold-level"] = 150;
    const auto fixed150 = frame(f);
    EXPECT_EQ(fixed150.out.stats.threshold, 150);
    EXPECT_FALSE(fixed150.out.shape.otsu);
    json a = base;
    a["threshold"] = "adaptive";
    const auto adaptive = frame(a);
    EXPECT_EQ(adaptive.out.stats.threshold, -1);
    EXPECT_TRUE(adaptive.out.shape.adaptive);
    EXPECT_EQ(adaptive.out.dots.size(), 120u);
    // Support radius: every point's support is the radius, and holds the dots within it.
    json r = base;
    r.erase("support");
    r["support-radius"] = 90;
    const auto byr = frame(r);
    for (double rho : byr.table.rho) EXPECT_EQ(rho, 90);
    for (double rho : cubic.table.rho) EXPECT_NE(rho, 90);
    EXPECT_NE(byr.table.entries(), cubic.table.entries());
  }
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
  const double radius = wl::get_real(c, "support-radius");
  if (radius > 0) {  // the dots (FE: twice them, at the inner points) within the radius, from the density: within 15%
    EXPECT_NEAR(static_cast<double>(e.support_entries), static_cast<double>(entries), 0.15 * static_cast<double>(entries));
  } else if (mls) {
    EXPECT_EQ(entries, nx * ny * wl::get_int(c, "support"));
    EXPECT_EQ(e.support_entries, entries);
  } else {  // FE's recovery triangles: estimated before the reference (counts.cpp, two per
            // support dot at the grid's inner points), within 30% (1.09-1.12x the count here)
    EXPECT_GT(entries, 0);
    EXPECT_NEAR(static_cast<double>(e.support_entries), static_cast<double>(entries), 0.3 * static_cast<double>(entries));
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
                      {"bits", "16"}, {"host-memory", "pageable"}}},
        // Every value of the parameters added for the tuner, on each CPU backend and on cuda.
        Case{"cpu-seq", {{"size", "640x480"}, {"dots", 120}, {"radius", 6}, {"points", "16x12"}, {"support", 20},
                         {"weight", "quartic"}, {"threshold", "fixed"}, {"threshold-level", 110}}},
        Case{"cpu-par", {{"size", "640x480"}, {"dots", 120}, {"radius", 6}, {"points", "16x12"}, {"support", 20},
                         {"weight", "gaussian"}, {"threshold", "adaptive"}, {"threads", 2}}},
        Case{"cpu-seq", {{"size", "640x480"}, {"dots", 120}, {"radius", 6}, {"points", "16x12"},
                         {"support-radius", 110}, {"threshold", "adaptive"}, {"bits", "16"}}},
        Case{"cpu-par", {{"size", "700x500"}, {"dots", 150}, {"radius", 6}, {"points", "12x10"},
                         {"support-radius", 140}, {"weight", "gaussian"}, {"threshold", "fixed"}, {"threads", 2}}},
        Case{"cpu-seq", {{"size", "700x500"}, {"dots", 150}, {"radius", 6}, {"points", "12x10"}, {"interp", "fe"},
                         {"support-radius", 140}, {"weight", "quartic"}}},
        Case{"cpu-par", {{"size", "640x480"}, {"dots", 120}, {"radius", 6}, {"points", "16x12"}, {"support", 20},
                         {"weight", "quartic"}, {"threshold", "fixed"}, {"bits", "16"}, {"threads", 1}}},
        Case{"cuda", {{"size", "640x480"}, {"dots", 120}, {"radius", 6}, {"points", "16x12"}, {"support-radius", 110},
                      {"weight", "gaussian"}, {"threshold", "fixed"}, {"block-pixels", 32}, {"block-points", 512},
                      {"block-dots", 64}}},
        Case{"cuda", {{"size", "641x481"}, {"dots", 120}, {"radius", 6}, {"points", "16x12"}, {"support", 20},
                      {"weight", "quartic"}, {"block-pixels", 1024}, {"block-points", 32}, {"block-dots", 1024}}}),
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
  // image-kinds: each still as a 16-bit MLS frame like image-sizes', and as 8- and 16-bit frames of
  // 150 dots with FE (what the other named plans leave to the random ones).
  const auto kinds = W().plan("image-kinds", b, 1);
  ASSERT_EQ(kinds.configs.size(), 18u);
  int wide_mls = 0, fe8 = 0, fe16 = 0;
  for (std::size_t i = 0; i < kinds.configs.size(); ++i) {
    const auto& c = kinds.configs[i];
    const auto& still = img.configs[i / 3];
    EXPECT_EQ(wl::get_size2(c, "size"), wl::get_size2(still, "size")) << i;
    EXPECT_EQ(wl::get_real(c, "radius"), wl::get_real(still, "radius")) << i;
    const bool fe = wl::get_text(c, "interp") == "fe", wide = wl::get_text(c, "bits") == "16";
    if (!fe && wide) {
      ++wide_mls;
      EXPECT_EQ(wl::get_int(c, "dots"), wl::get_int(still, "dots")) << i;
    } else if (fe) {
      (wide ? fe16 : fe8) += 1;
      EXPECT_EQ(wl::get_int(c, "dots"), 150) << i;
    }
  }
  EXPECT_EQ(wide_mls, 6);
  EXPECT_EQ(fe8, 6);
  EXPECT_EQ(fe16, 6);
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
