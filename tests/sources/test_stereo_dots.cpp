// Stereo DCT on dots against a known camera pair. The views come from the independent camera
// renderer (tests/workloads/dct/independent_renderer/camera.hpp: cv::projectPoints and exact
// pixel coverage, no dtflop code): checkerboard views calibrate the pair, dot-plate views before
// and after a known out-of-plane motion are matched, triangulated and compared with the motion.
#include <cmath>
#include <cstdio>
#include <random>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "camera.hpp"
#include "model/errors.hpp"
#include "tests/support/temp_dir.hpp"
#include "workloads/dct/stereo_dots.hpp"

namespace dtflop::dct::stereo {
namespace {

using dct_indep::CameraModel;
using dct_indep::CameraPair;
using dct_indep::PlatePose;

// 1280x960, f = 1600 px, 200 mm baseline, converging 11.3 deg, k1 = -0.05 (as test_stereo).
CameraPair truth() { return dct_indep::make_pair({1280, 960}, 1600, 200, 11.3, -0.05); }
const double kFov = 1280.0 / 1600 * 1000;  // field of view across at 1 m, mm

Rig as_rig(const CameraPair& p) {
  Rig r;
  r.left = {p.left.K, p.left.dist.clone(), p.left.size};
  r.right = {p.right.K, p.right.dist.clone(), p.right.size};
  r.R = p.R;
  r.T = p.T;
  return r;
}

// The plate: 300 x 220 mm centred on its origin, ~1 m out between the cameras, turned a little.
PlatePose plate_pose() { return {cv::Vec3d(0.08, -0.12, 0.03), cv::Vec3d(100, 0, 1000)}; }

std::vector<cv::Point2d> random_dots(int count, double r, double gap, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(-150, 150), uy(-110, 110);
  std::vector<cv::Point2d> c;
  for (int tries = 0; static_cast<int>(c.size()) < count && tries < 200000; ++tries) {
    const cv::Point2d p{ux(rng), uy(rng)};  // braces: x drawn before y on every compiler
    bool ok = true;
    for (const auto& q : c)
      if (cv::norm(p - q) < 2 * r + gap) {
        ok = false;
        break;
      }
    if (ok) c.push_back(p);
  }
  return c;
}

PipelineOptions options() {
  PipelineOptions o;
  o.points_x = o.points_y = 12;
  o.points_inset = 20;
  o.mls.support = parse_support("40dots");
  o.mls.support_at_most_found = false;
  o.threads = 2;
  return o;
}

// The independent renderer's shapes of render_board's circle grid: a white card from (-1, -1)
// to (cols + 0.5, (rows - 1) / 2 + 1) pitches, its edges cut 16 times, and discs of radius 0.2
// pitch at OpenCV's asymmetric grid's centres.
std::vector<dct_indep::Shape> circle_board_shapes(const Board& b) {
  dct_indep::Shape card;
  card.level = 215;
  const double x0 = -b.square, y0 = -b.square, x1 = (b.inner.width + 0.5) * b.square,
               y1 = ((b.inner.height - 1) * 0.5 + 1) * b.square;
  constexpr int n = 16;
  for (int i = 0; i < n; ++i) card.outline.emplace_back(x0 + (x1 - x0) * i / n, y0, 0);
  for (int i = 0; i < n; ++i) card.outline.emplace_back(x1, y0 + (y1 - y0) * i / n, 0);
  for (int i = 0; i < n; ++i) card.outline.emplace_back(x1 - (x1 - x0) * i / n, y1, 0);
  for (int i = 0; i < n; ++i) card.outline.emplace_back(x0, y1 - (y1 - y0) * i / n, 0);
  std::vector<cv::Point2d> centres;
  for (int i = 0; i < b.inner.height; ++i)
    for (int j = 0; j < b.inner.width; ++j) centres.emplace_back((2 * j + i % 2) * b.square / 2, i * b.square / 2);
  std::vector<dct_indep::Shape> out = {card};
  for (auto& d : dct_indep::dot_shapes(centres, 0.2 * b.square, 40)) out.push_back(std::move(d));
  return out;
}

// render_board (dtflop's calibration views) against the independent renderer's exact pixel
// coverage of the same board, pose and camera, with and without lens distortion: no outline
// grows, shrinks or loses a partial pixel column or row. (Rendered with cv::fillPoly on an 8x8
// supersampled image before, every outline grew by half a supersampled pixel, fillPoly's spans
// holding both ends: checkerboard pixels differed by -40..17 grey levels, the mean by -0.15.)
TEST(RenderBoard, AgreesWithTheIndependentRenderersExactCoverage) {
  const Board checkers{{9, 6}, 30.0};
  Board circles{{4, 11}, 40.0};
  circles.target = Board::Target::circles;
  for (const double k1 : {0.0, -0.05}) {
    const CameraPair pair = dct_indep::make_pair({640, 480}, 800, 200, 0, k1);
    const Camera cam{pair.left.K, pair.left.dist.clone(), pair.left.size};
    for (const Board* board : {&checkers, static_cast<const Board*>(&circles)}) {
      const bool grid = board->target == Board::Target::circles;
      const auto shapes = grid ? circle_board_shapes(*board)
                               : dct_indep::checkerboard_shapes(board->inner, board->square, 215, 40);
      // The board's middle, in its own units.
      const cv::Vec3d middle = grid ? cv::Vec3d(1.75 * board->square, 2.5 * board->square, 0)
                                    : cv::Vec3d(4 * board->square, 2.5 * board->square, 0);
      for (int i = 0; i < 3; ++i) {
        Pose p;
        p.rvec = cv::Vec3d(0.1 * i, -0.15 + 0.1 * i, 0.05 + 0.2 * i);
        cv::Matx33d R;
        cv::Rodrigues(p.rvec, R);
        p.tvec = cv::Vec3d(3.3 * i, -2.1 * i, 620) - R * middle;
        const cv::Mat mine = render_board(cam, *board, p);
        const cv::Mat exact = dct_indep::render_view(pair.left, {p.rvec, p.tvec}, shapes, 110);
        ASSERT_EQ(mine.size(), exact.size());
        cv::Mat d;
        cv::subtract(mine, exact, d, cv::noArray(), CV_64F);
        // A pixel differs only by the 32 lines per row render_board samples its coverage along,
        // the squares' cuts (8 per side against 16) and both images' rounding to 8 bits: within
        // 2 grey levels, the mean within 0.01.
        double lo = 0, hi = 0;
        cv::minMaxLoc(d, &lo, &hi);
        const double mean = cv::mean(d)[0];
        const std::string what = fmt::format("{}, k1 {}, pose {}", grid ? "circles" : "checkerboard", k1, i);
        EXPECT_GE(lo, -2) << what;
        EXPECT_LE(hi, 2) << what;
        EXPECT_NEAR(mean, 0, 0.01) << what;
        std::printf("%s: difference %.0f..%.0f grey levels, mean %.4f\n", what.c_str(), lo, hi, mean);
      }
    }
  }
}

TEST(StereoMatch, AGridOnATiltedPlateIsMatchedDotForDotAndTheRestSayWhy) {
  const CameraPair pair = truth();
  const Rig rig = as_rig(pair);
  std::vector<cv::Point2d> grid;
  for (int y = -8; y <= 8; ++y)
    for (int x = -14; x <= 14; ++x) grid.emplace_back(12.0 * x, 12.0 * y);
  PlatePose pose = plate_pose();
  pose.rvec = cv::Vec3d(0.1, 0.45, 0.0);  // turned 26 deg about y: disparity changes across the plate
  const auto L = dct_indep::project(pair.left, pose, grid);
  const auto R = dct_indep::project(pair.right, dct_indep::right_pose(pair, pose), grid);
  // The right view sees a window of the plate only: dots left of x = 300 px are not in it.
  std::vector<cv::Point2d> Rseen;
  std::vector<int> truth_index;
  for (std::size_t i = 0; i < R.size(); ++i)
    if (R[i].x > 300) {
      Rseen.push_back(R[i]);
      truth_index.push_back(static_cast<int>(i));
    }
  const StereoMatches m = match_stereo(rig, L, Rseen);
  std::printf("%s\n", m.summary().c_str());
  int right = 0, wrong = 0;
  for (std::size_t i = 0; i < L.size(); ++i) {
    const int j = m.left_to_right[i];
    if (j < 0) {
      EXPECT_NE(m.lost[i], StereoLost::none);
      continue;
    }
    (truth_index[static_cast<std::size_t>(j)] == static_cast<int>(i) ? right : wrong)++;
    EXPECT_LT(std::abs(m.row_offset_px[i]), 1e-6);
  }
  EXPECT_EQ(wrong, 0);
  EXPECT_EQ(right, static_cast<int>(Rseen.size()));  // every dot both cameras see
  EXPECT_EQ(m.matched, right);
  EXPECT_GT(m.best_reach, m.second_reach);
}

TEST(StereoMatch, ARowPatternThatRepeatsBeyondBothViewsIsAmbiguous) {
  // One row of evenly spaced dots, seen whole by neither camera: any shift fits as well.
  const CameraPair pair = truth();
  std::vector<cv::Point2d> row;
  for (int x = -100; x <= 100; ++x) row.emplace_back(10.0 * x, 0);
  const PlatePose pose{cv::Vec3d(0, 0, 0), cv::Vec3d(100, 0, 1000)};
  auto in_view = [](std::vector<cv::Point2d> v) {
    std::erase_if(v, [](const cv::Point2d& p) { return p.x < 100 || p.x > 1180; });
    return v;
  };
  const auto L = in_view(dct_indep::project(pair.left, pose, row));
  const auto R = in_view(dct_indep::project(pair.right, dct_indep::right_pose(pair, pose), row));
  const StereoMatches m = match_stereo(as_rig(pair), L, R);
  std::printf("%s\n", m.summary().c_str());
  EXPECT_EQ(m.matched, 0);
  for (StereoLost r : m.lost) EXPECT_EQ(r, StereoLost::ambiguous);
}

TEST(StereoMatch, BadInputIsRefused) {
  const Rig rig = as_rig(truth());
  EXPECT_THROW(match_stereo(rig, {}, {{1, 2}}), InputError);
  StereoMatchOptions o;
  o.epipolar_tolerance = std::nan("");
  EXPECT_THROW(match_stereo(rig, {{1, 2}}, {{1, 2}}, o), InputError);
  o = {};
  o.disparity_tolerance = 0.7;
  EXPECT_THROW(validate(o), InputError);
  // A calibration of another image size than the frames'.
  StereoPipeline p(rig, "cpu-seq", options());
  const cv::Mat small(480, 640, CV_8U, cv::Scalar(200));
  EXPECT_THROW(p.set_reference(small, small), InputError);
  EXPECT_THROW(p.set_reference(cv::Mat(960, 1280, CV_8U, cv::Scalar(200)), small), InputError);
}

// The whole chain on rendered views: calibrate from checkerboard views, then u_z of known motions.
// Measured (noiseless 16-bit renders, 283 dots of 6.4 px radius, 40-dot supports): u_z RMS
// 0.0035 mm per dot under rigid 0.5 mm + tilt 2e-3 (1/227,000 of the field of view) and 0.0024 mm
// under a 0.8 mm bulge; the gradient within 6e-5 (tilt) and 3.3e-4 (bulge, peak slope 8e-3).
TEST(StereoDots, UzOfRenderedMotionsThroughARenderedCalibrationMatchesTheTruth) {
  const CameraPair pair = truth();
  // Calibration views: a 9x6 checkerboard of 30 mm squares at 20 poses around the plate.
  const Board board{{9, 6}, 30.0};
  const auto cb = dct_indep::checkerboard_shapes(board.inner, board.square, 215, 40);
  cv::RNG rng(11);
  std::vector<cv::Mat> Lc, Rc;
  for (int i = 0; i < 20; ++i) {
    PlatePose p;
    // One draw per declarator: the order of a call's arguments is the compiler's, and the views must not be.
    const double rx = rng.uniform(-0.5, 0.5), ry = rng.uniform(-0.5, 0.5), rz = rng.uniform(-0.2, 0.2);
    p.rvec = cv::Vec3d(rx, ry, rz);
    cv::Matx33d Rm;
    cv::Rodrigues(p.rvec, Rm);
    const double cx = 100 + rng.uniform(-60.0, 60.0), cy = rng.uniform(-50.0, 50.0), cz = rng.uniform(850.0, 1150.0);
    const cv::Vec3d centre(cx, cy, cz);
    p.tvec = centre - Rm * cv::Vec3d(4 * board.square, 2.5 * board.square, 0);
    Lc.push_back(dct_indep::render_view(pair.left, p, cb, 110));
    Rc.push_back(dct_indep::render_view(pair.right, dct_indep::right_pose(pair, p), cb, 110));
  }
  const Calibration cal = calibrate(Lc, Rc, board);
  for (const auto& n : cal.notes) std::printf("%s\n", n.c_str());
  std::printf("calibrated: fx %.3f / %.3f px, baseline %.4f mm\n", cal.rig.left.K(0, 0), cal.rig.right.K(0, 0),
              cal.rig.baseline());
  EXPECT_NEAR(cal.rig.left.K(0, 0), 1600, 1.6);
  EXPECT_NEAR(cal.rig.baseline(), 200, 0.2);

  // The dot plate: ~300 random dots of radius 4 mm (6.4 px), dark on light, 16-bit, noiseless.
  const auto centres = random_dots(320, 4, 5, 3);
  const auto dots = dct_indep::dot_shapes(centres, 4, 40);
  const PlatePose pose = plate_pose();
  const PlatePose rpose = dct_indep::right_pose(pair, pose);
  const cv::Mat L0 = dct_indep::render_view(pair.left, pose, dots, 200, CV_16U);
  const cv::Mat R0 = dct_indep::render_view(pair.right, rpose, dots, 200, CV_16U);

  StereoPipeline sp(cal.rig, "cpu-par", options());
  sp.set_reference(L0, R0);
  std::printf("reference: %s\n", sp.reference_matches().summary().c_str());
  const auto& lref = sp.left().reference_positions();
  // Each measured left dot's true plate dot: the nearest projected centre (within 1 px).
  const auto L0true = dct_indep::project(pair.left, pose, centres);
  std::vector<int> dot_of(lref.size(), -1);
  for (std::size_t i = 0; i < lref.size(); ++i)
    for (std::size_t k = 0; k < L0true.size(); ++k)
      if (std::hypot(L0true[k].x - lref[i].x, L0true[k].y - lref[i].y) < 1) dot_of[i] = static_cast<int>(k);
  // Every dot both cameras see whole is matched, and matched to its own right dot.
  const auto R0true = dct_indep::project(pair.right, rpose, centres);
  const auto& rref = sp.right().reference_positions();
  int wrong = 0;
  for (std::size_t i = 0; i < lref.size(); ++i) {
    const int j = sp.reference_matches().left_to_right[i];
    if (j < 0 || dot_of[i] < 0) continue;
    const auto& t = R0true[static_cast<std::size_t>(dot_of[i])];
    wrong += std::hypot(t.x - rref[static_cast<std::size_t>(j)].x, t.y - rref[static_cast<std::size_t>(j)].y) > 1;
  }
  EXPECT_EQ(wrong, 0);
  EXPECT_GE(sp.reference_matches().matched, static_cast<int>(0.95 * static_cast<double>(centres.size())));

  // Motions toward the cameras (u along -Z of the plate) with closed forms: w(X, Y).
  struct Motion {
    const char* name;
    double w0, slope, bulge;  // w = w0 + slope X + bulge exp(-(X^2 + Y^2) / (2 60^2))
    double gradient_rms;      // bound on the gradient's RMS error (the bulge's peaks are smoothed by the fit)
  };
  cv::Matx33d Rp;
  cv::Rodrigues(pose.rvec, Rp);
  const auto dir = test::fresh_test_dir("dtflop_stereo_dots");
  for (const Motion& m : {Motion{"rigid + tilt", 0.5, 2e-3, 0, 2e-4}, Motion{"bulge", 0, 0, 0.8, 1e-3}}) {
    auto w = [&](double X, double Y) { return m.w0 + m.slope * X + m.bulge * std::exp(-(X * X + Y * Y) / 7200.0); };
    const dct_indep::Displacement u = [&](double X, double Y) { return cv::Vec3d(0, 0, -w(X, Y)); };
    const cv::Mat L1 = dct_indep::render_view(pair.left, pose, dots, 200, CV_16U, u);
    const cv::Mat R1 = dct_indep::render_view(pair.right, rpose, dots, 200, CV_16U, u);
    const StereoFrame f = sp.process(L1, R1);
    double se = 0, worst = 0;
    int n = 0;
    for (std::size_t i = 0; i < lref.size(); ++i) {
      if (!std::isfinite(f.uz[i]) || dot_of[i] < 0) continue;
      const auto& c = centres[static_cast<std::size_t>(dot_of[i])];
      const double e = f.uz[i] - w(c.x, c.y);
      se += e * e;
      worst = std::max(worst, std::abs(e));
      ++n;
    }
    const double rms = std::sqrt(se / n);
    // At the points: u_z and its gradient along the plate axes e1, e2 (the truth's gradient,
    // a 3D vector in the plate, projected on them).
    double sep = 0, seg = 0;
    int np = 0;
    const PlaneFrame& pf = sp.plane();
    for (std::size_t p = 0; p < f.fields.size(); ++p) {
      if (f.fields[p].status != PointStatus::ok) continue;
      const auto& pt = sp.points()[p];
      const cv::Point2d X = dct_indep::on_plate(pair.left, pose, {pt.x, pt.y});
      const double h = 1e-3;
      const cv::Vec3d g = Rp * cv::Vec3d((w(X.x + h, X.y) - w(X.x - h, X.y)) / (2 * h),
                                         (w(X.x, X.y + h) - w(X.x, X.y - h)) / (2 * h), 0);
      sep += std::pow(f.fields[p].uz - w(X.x, X.y), 2);
      seg += std::pow(f.fields[p].duz_dx - g.dot(pf.e1), 2) + std::pow(f.fields[p].duz_dy - g.dot(pf.e2), 2);
      ++np;
    }
    std::printf("%s: %d dots triangulated, u_z RMS error %.5f mm (max %.5f) = 1/%.0f of the %.0f mm field of view; "
                "at %d points u_z RMS %.5f mm, gradient RMS %.2e\n",
                m.name, n, rms, worst, kFov / rms, kFov, np, std::sqrt(sep / np), std::sqrt(seg / (2 * np)));
    EXPECT_GE(n, static_cast<int>(0.9 * static_cast<double>(centres.size()))) << m.name;
    EXPECT_LT(rms, kFov / 20000) << m.name;
    EXPECT_GE(np, 100) << m.name;
    EXPECT_LT(std::sqrt(sep / np), kFov / 20000) << m.name;
    EXPECT_LT(std::sqrt(seg / (2 * np)), m.gradient_rms) << m.name;
    // The tables: every left reference dot a row, the fields with u_z columns.
    write_stereo_dots_csv(dir / "dots.csv", sp, f);
    write_stereo_fields_csv(dir / "fields.csv", sp.points(), f.left.fields, f.fields);
  }
}

}  // namespace
}  // namespace dtflop::dct::stereo
