// Live stereo: the stereo keys of the run configuration, tuned.json applied, frames of two
// sources paired (drops counted), and `dtflop live dct --source2 --calibration` end to end on
// image sequences rendered by the independent camera renderer, u_z against the rendered bulge.
#include <algorithm>
#include <cmath>
#include <fstream>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "camera.hpp"
#include "model/errors.hpp"
#include "sources/live.hpp"
#include "tests/cli/run_cli.hpp"
#include "tests/support/temp_dir.hpp"

namespace dtflop::live {
namespace {

namespace fs = std::filesystem;

TEST(LiveStereoConfig, StereoKeysAreReadAndBadOnesRefusedNamingTheKey) {
  const LiveConfig c = parse_live_config(
      "source: images:L_%03d.png\nsource2: images:R_%03d.png\ncalibration: rig.yaml\npair: timestamp\n"
      "pair_tolerance_ms: 8\nepipolar_tolerance: 2\ntuned: tuned.json\n",
      "run.yaml");
  EXPECT_EQ(c.source2, "images:R_%03d.png");
  EXPECT_EQ(c.calibration, "rig.yaml");
  EXPECT_TRUE(c.pair_by_timestamp);
  EXPECT_DOUBLE_EQ(c.pair_tolerance_s, 0.008);
  EXPECT_DOUBLE_EQ(c.epipolar_tolerance, 2);
  EXPECT_EQ(c.tuned, "tuned.json");
  for (const auto& [yaml, key] : std::vector<std::pair<std::string, std::string>>{
           {"pair: frame", "'pair'"},
           {"pair_tolerance_ms: -1", "'pair_tolerance_ms'"},
           {"epipolar_tolerance: 0", "'epipolar_tolerance'"},
           {"source2: images:R_%03d.png", "'calibration'"},
           {"tuned: [a]", "'tuned'"}}) {
    try {
      parse_live_config(yaml, "run.yaml");
      ADD_FAILURE() << yaml << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << yaml << " -> " << e.what();
    }
  }
}

TEST(LiveStereoConfig, TunedValuesReplaceTheDefaultsButNotTheKeysTheFileNamed) {
  LiveConfig c = parse_live_config("weight: quartic\npolarity: light\narea: [20, 400]\n", "run.yaml");
  dct::PipelineOptions t;
  t.mls.weight = dct::Weight::gaussian;
  t.mls.support = dct::parse_support("80dots");
  t.points_x = 48;
  t.analysis.polarity = dct::Polarity::dark_dots;
  t.analysis.min_area = 1;
  apply_tuned(c, "cpu-seq", t);
  EXPECT_EQ(c.backend, "cpu-seq");
  EXPECT_EQ(c.pipeline.mls.weight, dct::Weight::quartic);  // the file named it
  EXPECT_EQ(c.pipeline.mls.support.dots, 80);                // tuned
  EXPECT_EQ(c.pipeline.points_x, 48);                        // tuned
  EXPECT_EQ(c.pipeline.analysis.polarity, dct::Polarity::light_dots);  // describes the images
  EXPECT_EQ(c.pipeline.analysis.min_area, 20);
  LiveConfig d = parse_live_config("backend: cpu-par\n", "run.yaml");
  d.tuned = "tuned.json";
  EXPECT_THROW(apply_tuned(d, "cpu-seq", t), InputError);  // two backends named
}

// The pair and the plate of test_stereo_dots, as image sequences: frame k bulged by 0.3 k mm.
struct Rendered {
  dct_indep::CameraPair pair = dct_indep::make_pair({1280, 960}, 1600, 200, 11.3, -0.05);
  dct_indep::PlatePose pose{cv::Vec3d(0.08, -0.12, 0.03), cv::Vec3d(100, 0, 1000)};
  static double w(double X, double Y, int k) { return 0.3 * k * std::exp(-(X * X + Y * Y) / 7200.0); }
};

void write_rig_file(const Rendered& r, const fs::path& path, cv::Size size) {
  dct::stereo::Calibration c;
  c.rig.left = {r.pair.left.K, r.pair.left.dist.clone(), size};
  c.rig.right = {r.pair.right.K, r.pair.right.dist.clone(), size};
  c.rig.R = r.pair.R;
  c.rig.T = r.pair.T;
  dct::stereo::write_rig(path.string(), c);
}

TEST(LiveStereoCli, TwoImageSequencesGiveUzOfTheRenderedBulge) {
  const auto dir = test::fresh_test_dir("dtflop_live_stereo");
  const Rendered r;
  std::vector<cv::Point2d> centres;
  for (int y = -6; y <= 6; ++y)
    for (int x = -9; x <= 9; ++x) centres.emplace_back(14.0 * x + 3.0 * std::sin(1.7 * y + x), 14.0 * y + 3.0 * std::cos(x + 0.3 * y));
  const auto dots = dct_indep::dot_shapes(centres, 4, 40);
  const auto rpose = dct_indep::right_pose(r.pair, r.pose);
  for (int k = 0; k < 4; ++k) {
    const dct_indep::Displacement u = [k](double X, double Y) { return cv::Vec3d(0, 0, -Rendered::w(X, Y, k)); };
    cv::imwrite((dir / fmt::format("L_{:03d}.png", k)).string(), dct_indep::render_view(r.pair.left, r.pose, dots, 200, CV_16U, u));
    cv::imwrite((dir / fmt::format("R_{:03d}.png", k)).string(), dct_indep::render_view(r.pair.right, rpose, dots, 200, CV_16U, u));
  }
  write_rig_file(r, dir / "rig.yaml", {1280, 960});
  write_rig_file(r, dir / "rig_small.yaml", {640, 480});
  {
    std::ofstream y(dir / "run.yaml");
    y << "backend: cpu-par\nthreads: 1\nsupport: 40dots\npoints: 10x10\n";
  }
  const std::string base = fmt::format("live dct --config {} --source 'images:{}' --source2 'images:{}'",
                                       (dir / "run.yaml").string(), (dir / "L_%03d.png").string(),
                                       (dir / "R_%03d.png").string());
  const auto run = test::run_dtflop(fmt::format("{} --calibration {} -o {}", base, (dir / "rig.yaml").string(),
                                                (dir / "out").string()));
  ASSERT_EQ(run.status, 0) << run.out << run.err;
  EXPECT_NE(run.out.find("3 frames measured"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("unpaired frames dropped: 0 of the first source, 0 of the second"), std::string::npos) << run.out;
  std::ifstream in(dir / "out" / "summary.json");
  const auto js = nlohmann::json::parse(in);
  EXPECT_EQ(js["stereo"]["unpaired_dropped_first"], 0);
  // The last frame's u_z at the points against the bulge (0.9 mm at the centre).
  std::ifstream csv(dir / "out" / "frame_000003.csv");
  std::string line;
  std::getline(csv, line);
  EXPECT_NE(line.find("u_z_mm,du_z_dx,du_z_dy"), std::string::npos) << line;
  double se = 0;
  int n = 0;
  while (std::getline(csv, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
    if (f.size() < 14 || f[13] != "ok") continue;
    const cv::Point2d X = dct_indep::on_plate(r.pair.left, r.pose, {std::stod(f[0]), std::stod(f[1])});
    se += std::pow(std::stod(f[10]) - Rendered::w(X.x, X.y, 3), 2);
    ++n;
  }
  ASSERT_GE(n, 40);
  EXPECT_LT(std::sqrt(se / n), 800.0 / 20000) << "u_z RMS over " << n << " points";
  EXPECT_TRUE(fs::exists(dir / "out" / "frame_000003_dots3d.csv"));

  // Bad input: one line, exit 2.
  const auto small = test::run_dtflop(fmt::format("{} --calibration {} -o {}", base, (dir / "rig_small.yaml").string(),
                                                  (dir / "out2").string()));
  EXPECT_EQ(small.status, 2);
  EXPECT_NE(small.err.find("640x480"), std::string::npos) << small.err;
  // The error is one line (after the line naming the sources, printed as they open).
  EXPECT_EQ(std::count(small.err.begin(), small.err.end(), '\n') - (small.err.find("dtflop live dct:") == 0 ? 1 : 0), 1)
      << small.err;
  const auto nocal = test::run_dtflop(fmt::format("{} -o {}", base, (dir / "out3").string()));
  EXPECT_EQ(nocal.status, 2);
  EXPECT_NE(nocal.err.find("calibration"), std::string::npos) << nocal.err;

  // `dtflop fields` on the same image files, the left camera's and the right one's: the same
  // stereo pipeline, so the same columns and the same values as the live run's (the pattern
  // starts at L_000, the reference, so live frame 3 is fields frame 4).
  const std::string fields = fmt::format(
      "fields --backend cpu-par --threads 1 --support 40dots --points 10x10 --no-overlays --reference {} --frames {} "
      "--reference2 {} --frames2 {}",
      (dir / "L_000.png").string(), (dir / "L_%03d.png").string(), (dir / "R_000.png").string(),
      (dir / "R_%03d.png").string());
  const auto f = test::run_dtflop(fmt::format("{} --calibration {} -o {}", fields, (dir / "rig.yaml").string(),
                                              (dir / "fields").string()));
  ASSERT_EQ(f.status, 0) << f.out << f.err;
  EXPECT_NE(f.out.find("stereo reference:"), std::string::npos) << f.out;
  EXPECT_EQ(test::slurp(dir / "fields" / "frame_0004.csv"), test::slurp(dir / "out" / "frame_000003.csv"));
  EXPECT_EQ(test::slurp(dir / "fields" / "frame_0004_dots3d.csv"), test::slurp(dir / "out" / "frame_000003_dots3d.csv"));
  EXPECT_TRUE(fs::exists(dir / "fields" / "frame_0004_dots.csv"));
  // ... and its bad input, as live mode's: one line, exit 2.
  const std::pair<std::string, std::string> bad_fields[] = {
      {fmt::format("{} --calibration {}", fields, (dir / "rig_small.yaml").string()), "640x480"},
      {fields, "calibration"},
      {fmt::format("fields --reference {} --frames {} --reference2 {} --frames2 {} --calibration {}",
                   (dir / "L_000.png").string(), (dir / "L_%03d.png").string(), (dir / "R_000.png").string(),
                   (dir / "R_001.png").string(), (dir / "rig.yaml").string()),
       "pairs"},
      {fmt::format("fields --reference {} --frames {} --calibration {}", (dir / "L_000.png").string(),
                   (dir / "L_001.png").string(), (dir / "rig.yaml").string()),
       "no second camera"},
  };
  for (const auto& [args, says] : bad_fields) {
    const auto b = test::run_dtflop(fmt::format("{} -o {}", args, (dir / "fields_bad").string()));
    EXPECT_EQ(b.status, 2) << args;
    EXPECT_NE(b.err.find(says), std::string::npos) << args << ": " << b.err;
    EXPECT_EQ(test::count_lines(b.err), 1) << b.err;
  }
}

TEST(LiveStereoCli, TunedJsonSetsTheBackendAndIsValidated) {
  const auto dir = test::fresh_test_dir("dtflop_live_tuned");
  const Rendered r;
  std::vector<cv::Point2d> centres;
  for (int y = -6; y <= 6; ++y)
    for (int x = -9; x <= 9; ++x) centres.emplace_back(14.0 * x + 2.0 * std::sin(1.3 * y), 14.0 * y);
  const auto dots = dct_indep::dot_shapes(centres, 4, 40);
  for (int k = 0; k < 2; ++k)
    cv::imwrite((dir / fmt::format("L_{:03d}.png", k)).string(),
                dct_indep::render_view(r.pair.left, r.pose, dots, 200, CV_8U, [k](double, double) {
                  return cv::Vec3d(0.1 * k, 0, 0);
                }));
  std::ofstream(dir / "tuned.json") << R"({"schema": "dtflop.tuned", "workload": "dct", "backend": "cpu-seq", "config": {}})";
  std::ofstream(dir / "rbe.json") << R"({"schema": "dtflop.tuned", "workload": "rbe", "backend": "cpu-seq", "config": {}})";
  std::ofstream(dir / "badkey.json")
      << R"({"schema": "dtflop.tuned", "workload": "dct", "backend": "cpu-seq", "config": {"no_such_key": 3}})";
  for (const char* t : {"tuned", "rbe", "badkey"}) {
    std::ofstream(dir / fmt::format("{}.yaml", t)) << fmt::format("support: 40dots\npoints: 8x8\ntuned: {}\n",
                                                                  (dir / fmt::format("{}.json", t)).string());
  }
  const auto ok = test::run_dtflop(fmt::format("live dct --config {} --source 'images:{}' -o {}",
                                               (dir / "tuned.yaml").string(), (dir / "L_%03d.png").string(),
                                               (dir / "out").string()));
  ASSERT_EQ(ok.status, 0) << ok.out << ok.err;
  EXPECT_NE(ok.err.find("on backend cpu-seq"), std::string::npos) << ok.err;
  for (const char* t : {"rbe", "badkey"}) {
    const auto bad = test::run_dtflop(fmt::format("live dct --config {} --source 'images:{}' -o {}",
                                                  (dir / fmt::format("{}.yaml", t)).string(),
                                                  (dir / "L_%03d.png").string(), (dir / "out_bad").string()));
    EXPECT_EQ(bad.status, 2) << t;
    EXPECT_NE(bad.err.find("tuned"), std::string::npos) << bad.err;
    EXPECT_EQ(test::count_lines(bad.err), 1) << bad.err;
  }
}

}  // namespace
}  // namespace dtflop::live
