// Live mode: the YAML run configuration (valid and invalid), the frame-by-frame loop on a
// rendered image sequence checked against the closed form, a stream that stops mid-way, and
// `dtflop live dct` end to end.
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <thread>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "model/errors.hpp"
#include "sources/frame_source.hpp"
#include "sources/live.hpp"
#include "tests/cli/run_cli.hpp"
#include "tests/support/temp_dir.hpp"
#include "workloads/dct/specimen.hpp"

namespace dtflop::live {
namespace {

namespace fs = std::filesystem;

std::string config_error(const std::string& yaml) {
  try {
    parse_live_config(yaml, "run.yaml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(LiveConfig, EveryKeyIsRead) {
  const LiveConfig c = parse_live_config(R"(
source: "file:clip.avi?paced=1"
reference: first
roi: [10, 20, 300, 200]
threshold: "fixed:90"
polarity: light
area: [8, 5000]
backend: cpu-seq
interpolation: fe
weight: cubic
support: 40dots
points: 8x6
threads: 1
search_radius: 3.5
output: out
max_frames: 12
overlay_every: 5
)",
                                         "run.yaml");
  EXPECT_EQ(c.source, "file:clip.avi?paced=1");
  EXPECT_EQ(c.pipeline.analysis.roi, cv::Rect(10, 20, 300, 200));
  EXPECT_EQ(c.pipeline.analysis.method, dct::ThresholdMethod::fixed);
  EXPECT_DOUBLE_EQ(c.pipeline.analysis.threshold, 90);
  EXPECT_EQ(c.pipeline.analysis.polarity, dct::Polarity::light_dots);
  EXPECT_EQ(c.pipeline.analysis.min_area, 8);
  EXPECT_EQ(c.pipeline.analysis.max_area, 5000);
  EXPECT_EQ(c.backend, "cpu-seq");
  EXPECT_EQ(c.pipeline.interp, dct::Interp::fe);
  EXPECT_EQ(c.pipeline.mls.support.dots, 40);
  EXPECT_TRUE(c.support_given);
  EXPECT_EQ(c.pipeline.points_x, 8);
  EXPECT_EQ(c.pipeline.points_y, 6);
  EXPECT_EQ(c.pipeline.threads, 1);
  EXPECT_DOUBLE_EQ(c.pipeline.match.search_radius, 3.5);
  EXPECT_EQ(c.output, "out");
  EXPECT_EQ(c.max_frames, 12);
  EXPECT_EQ(c.overlay_every, 5);
}

TEST(LiveConfig, InvalidFilesAreRefusedNamingTheField) {
  const std::pair<const char*, const char*> cases[] = {
      {"sorce: x", "'sorce'"},
      {"area: [5]", "'area'"},
      {"area: [50, 5]", "'area'"},
      {"roi: [0, 0, 0, 10]", "'roi'"},
      {"threshold: fixed:999", "'threshold'"},
      {"threshold: median", "'threshold'"},
      {"polarity: grey", "'polarity'"},
      {"backend: fpga", "'backend'"},
      {"interpolation: spline", "'interpolation'"},
      {"support: -3dots", "'support'"},
      {"points: 1x40", "'points'"},
      {"threads: -1", "'threads'"},
      {"threads: 2.5", "'threads'"},
      {"search_radius: .nan", "'search_radius'"},
      {"max_frames: [1]", "'max_frames'"},
      {"overlay_every: -2", "'overlay_every'"},
      {"source: {a: 1}", "'source'"},
      {"[unclosed", "not YAML"},
      {"- a\n- b", "map"},
  };
  for (const auto& [yaml, field] : cases) {
    const std::string e = config_error(yaml);
    EXPECT_NE(e.find(field), std::string::npos) << yaml << " -> " << e;
    EXPECT_NE(e.find("run.yaml"), std::string::npos) << e;
    EXPECT_EQ(e.find('\n'), std::string::npos) << e;
  }
}

TEST(Percentile, OrderStatistics) {
  EXPECT_DOUBLE_EQ(percentile({3, 1, 2}, 50), 2);
  EXPECT_DOUBLE_EQ(percentile({1, 2, 3, 4}, 100), 4);
  EXPECT_DOUBLE_EQ(percentile({1, 2, 3, 4}, 0), 1);
  EXPECT_DOUBLE_EQ(percentile({0, 10}, 99), 9.9);
  EXPECT_TRUE(std::isnan(percentile({}, 50)));
}

// A uniform strain ramp: frame k carries e_xx = k * 2e-3 / (n - 1) (e_yy = -0.3 e_xx), written as PNGs.
constexpr double kStrain = 2e-3;
void write_ramp(const fs::path& dir, int n, int odd_size_frame = -1) {
  const dct::Specimen s = dct::parse_specimen("uniform:size=480x360,pattern=random,radius=5,gap=5,seed=3");
  for (int k = 0; k < n; ++k) {
    const double e = kStrain * k / (n - 1);
    const auto def = dct::make_uniform({240, 180}, e, -0.3 * e);
    dct::RenderOptions r = s.render;
    if (k == odd_size_frame) r.width = 400;
    ASSERT_TRUE(cv::imwrite((dir / fmt::format("f_{:03d}.png", k)).string(), dct::render(s.dots, *def, r)));
  }
}

LiveConfig ramp_config(const fs::path& out) {
  LiveConfig c = parse_live_config("backend: cpu-seq\nsupport: 60dots\npoints: 8x8\n", "test");
  c.output = out.string();
  return c;
}

TEST(RunLive, MeasuresEachFrameAsItComesAgainstTheClosedForm) {
  const auto dir = test::fresh_test_dir("dtflop_live");
  constexpr int n = 5;
  write_ramp(dir, n);
  const LiveConfig c = ramp_config(dir / "out");
  auto src = sources::open_source(sources::parse_source_spec("images:" + (dir / "f_%03d.png").string()));
  auto backend = dct::make_backend(c.backend, c.pipeline);
  int seen = 0;
  const LiveReport rep = run_live(c, *src, *backend, [&](const FrameRecord& r, const dct::FrameOutput&, const cv::Mat&) {
    ++seen;
    // Its CSV is on disk when the frame is reported: written as measured, not at the end.
    EXPECT_TRUE(fs::exists(dir / "out" / fmt::format("frame_{:06d}.csv", seen))) << r.sequence;
  });
  EXPECT_TRUE(rep.stopped_because.empty()) << rep.stopped_because;
  ASSERT_EQ(rep.frames.size(), static_cast<std::size_t>(n - 1));  // the first is the reference
  for (const auto& r : rep.frames) {
    const double e = kStrain * static_cast<double>(r.sequence) / (n - 1);
    EXPECT_NEAR(r.mean_exx, e, 50e-6) << "frame " << r.sequence;
    EXPECT_NEAR(r.mean_eyy, -0.3 * e, 50e-6) << "frame " << r.sequence;
    EXPECT_EQ(r.valid_points, 64);
    EXPECT_GE(r.latency_s, r.process_s);
  }
  EXPECT_EQ(rep.source.dropped, 0u);
  std::ifstream log(dir / "out" / "frames.csv");
  int lines = 0;
  for (std::string line; std::getline(log, line);) ++lines;
  EXPECT_EQ(lines, n);  // header + one row per measured frame
}

TEST(RunLive, AFrameOfAnotherSizeStopsTheRunKeepingWhatWasMeasured) {
  const auto dir = test::fresh_test_dir("dtflop_live");
  write_ramp(dir, 5, 3);
  const LiveConfig c = ramp_config(dir / "out");
  auto src = sources::open_source(sources::parse_source_spec("images:" + (dir / "f_%03d.png").string()));
  auto backend = dct::make_backend(c.backend, c.pipeline);
  const LiveReport rep = run_live(c, *src, *backend);
  EXPECT_NE(rep.stopped_because.find("400x360"), std::string::npos) << rep.stopped_because;
  ASSERT_EQ(rep.frames.size(), 2u);  // frames 1 and 2
  EXPECT_TRUE(fs::exists(dir / "out" / "frame_000002.csv"));
  EXPECT_FALSE(fs::exists(dir / "out" / "frame_000003.csv"));
}

TEST(LiveCli, EndToEndOnAnImageSequence) {
  const auto dir = test::fresh_test_dir("dtflop_live");
  write_ramp(dir, 4);
  {
    std::ofstream y(dir / "run.yaml");
    y << "backend: cpu-par\nthreads: 1\nsupport: 60dots\npoints: 8x8\noverlay_every: 2\n";
  }
  const auto r = test::run_dtflop(fmt::format("live dct --config {} --source 'images:{}?fps=30&paced=1' -o {}",
                                              (dir / "run.yaml").string(), (dir / "f_%03d.png").string(),
                                              (dir / "out").string()));
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("3 frames measured"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("latency per frame"), std::string::npos) << r.out;
  std::ifstream in(dir / "out" / "summary.json");
  const auto js = nlohmann::json::parse(in);
  EXPECT_EQ(js["frames_measured"], 3);
  EXPECT_EQ(js["frames_dropped"], 0);
  EXPECT_TRUE(js.contains("keeps_up"));  // paced at 30 fps: judged against the period
  // Overlays on frames 1 and 3 (every 2nd), each a colour image of the frame's size.
  for (int k : {1, 3}) {
    const cv::Mat o = cv::imread((dir / "out" / fmt::format("frame_{:06d}_e_xx.png", k)).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(o.empty()) << k;
    EXPECT_EQ(o.channels(), 3);
    EXPECT_GE(o.cols, 480);
  }
  EXPECT_FALSE(fs::exists(dir / "out" / "frame_000002_e_xx.png"));
}

TEST(LiveCli, BadInputIsOneLineAndExitTwo) {
  const auto dir = test::fresh_test_dir("dtflop_live");
  {
    std::ofstream y(dir / "bad.yaml");
    y << "polarity: sideways\n";
    std::ofstream g(dir / "good.yaml");
    g << "output: " << (dir / "out").string() << "\n";
  }
  const auto bad = test::run_dtflop(fmt::format("live dct --config {} --source device:0", (dir / "bad.yaml").string()));
  EXPECT_EQ(bad.status, 2);
  EXPECT_NE(bad.err.find("'polarity'"), std::string::npos) << bad.err;
  EXPECT_EQ(test::count_lines(bad.err), 1) << bad.err;
  const auto pipe = test::run_dtflop(
      fmt::format("live dct --config {} --source 'gst:nosuchelement_dtflop ! appsink'", (dir / "good.yaml").string()));
  EXPECT_EQ(pipe.status, 2);
  EXPECT_NE(pipe.err.find("does not parse"), std::string::npos) << pipe.err;
  const auto missing = test::run_dtflop(
      fmt::format("live dct --config {} --source file:{}", (dir / "good.yaml").string(), (dir / "none.avi").string()));
  EXPECT_EQ(missing.status, 2);
  EXPECT_NE(missing.err.find("no video file"), std::string::npos) << missing.err;
}

#ifdef DTFLOP_HAVE_VIEWER
// Headless Chromium's DOM of `url` after `ms` of the page's own time.
std::string dom_of(const std::string& url, const fs::path& dir, int ms) {
  const std::string cmd = fmt::format(
      "chromium --headless --no-sandbox --disable-gpu --user-data-dir={} --virtual-time-budget={} --dump-dom {} >{} "
      "2>/dev/null",
      (dir / "profile").string(), ms, url, (dir / "dom.html").string());
  EXPECT_EQ(std::system(cmd.c_str()), 0);
  fs::remove_all(dir / "profile");
  return test::slurp(dir / "dom.html");
}

// The frame the page's image shows (its src attribute; the page's script names the URL too).
long frame_shown(const std::string& dom) {
  const std::string key = "src=\"field.png?frame=";
  const auto at = dom.find(key);
  if (at == std::string::npos) return -1;
  long v = -1;
  std::istringstream(dom.substr(at + key.size(), 20)) >> v;
  return v;
}

TEST(LiveCli, ViewerInHeadlessChromiumShowsTheFieldUpdating) {
  if (std::system("command -v chromium >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "chromium is missing: install it (scripts/setup.sh --sanitize does)";
  const auto dir = test::fresh_test_dir("dtflop_live");
  write_ramp(dir, 24);
  {
    std::ofstream y(dir / "run.yaml");
    y << "backend: cpu-seq\nsupport: 60dots\npoints: 8x8\n";
  }
  const int port = 20000 + ::getpid() % 20000;
  const std::string url = fmt::format("http://127.0.0.1:{}/", port);
  // Paced at 3 frames/s: 8 s of frames, then the viewer stays 30 s (the test ends it sooner).
  const std::string cmd = fmt::format(
      "{}/dtflop live dct --config {} --source 'images:{}?fps=3&paced=1' -o {} --serve {} --serve-linger 30 "
      ">{} 2>&1 & echo $! >{}",
      DTFLOP_BINARY_DIR, (dir / "run.yaml").string(), (dir / "f_%03d.png").string(), (dir / "out").string(), port,
      (dir / "live.log").string(), (dir / "pid").string());
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const int pid = std::stoi(test::slurp(dir / "pid"));
  long first = -1;
  std::string dom;
  for (int i = 0; i < 40 && first < 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
    dom = dom_of(url, dir, 1500);
    first = frame_shown(dom);
  }
  ASSERT_GE(first, 1) << dom << test::slurp(dir / "live.log");
  EXPECT_NE(dom.find("frames/s"), std::string::npos) << dom;
  EXPECT_NE(dom.find("deadline margin"), std::string::npos) << dom;
  EXPECT_NE(dom.find("e_xx [microstrain]"), std::string::npos) << dom;
  // A while later the page shows a later frame: the image updates.
  long later = first;
  for (int i = 0; i < 20 && later <= first; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    later = frame_shown(dom_of(url, dir, 1500));
  }
  EXPECT_GT(later, first);
  // A screenshot: the field in its diverging colours (a strongly red or blue pixel) on the page.
  const std::string shot = fmt::format(
      "chromium --headless --no-sandbox --disable-gpu --hide-scrollbars --user-data-dir={} --virtual-time-budget=2000 "
      "--window-size=900,700 --screenshot={} {} >/dev/null 2>&1",
      (dir / "profile").string(), (dir / "shot.png").string(), url);
  EXPECT_EQ(std::system(shot.c_str()), 0);
  ::kill(pid, SIGTERM);
  const cv::Mat png = cv::imread((dir / "shot.png").string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(png.empty());
  EXPECT_EQ(png.size(), cv::Size(900, 700));
  int coloured = 0;
  for (int y = 0; y < png.rows; ++y)
    for (int x = 0; x < png.cols; ++x) {
      const cv::Vec3b p = png.at<cv::Vec3b>(y, x);
      coloured += std::abs(int{p[2]} - int{p[0]}) > 80;  // red against blue
    }
  EXPECT_GT(coloured, 500) << "no field colours in the screenshot";
}
#endif

}  // namespace
}  // namespace dtflop::live
