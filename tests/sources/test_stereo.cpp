// Stereo calibration and triangulation against a known camera pair: checkerboard views
// rendered with cv::projectPoints from the pair, calibrated back (focal length and baseline
// within 0.1%), and out-of-plane motions with closed forms (rigid w, tilt, bulge) triangulated
// from projected dot centres.
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "model/errors.hpp"
#include "tests/support/temp_dir.hpp"
#include "workloads/dct/stereo.hpp"

namespace dtflop::dct::stereo {
namespace {

// 1280x960, f = 1600 px, 200 mm baseline, converging 11.3 deg (axes cross ~1 m out), k1 = -0.05.
Rig truth() { return make_rig({1280, 960}, 1600, 200, 11.3, -0.05); }
const Board kBoard{{9, 6}, 30.0};

// Poses of the board around (100, 0, 1000) mm, tilted up to ~30 deg: seen by both cameras.
std::vector<Pose> poses(int n) {
  cv::RNG rng(7);
  std::vector<Pose> out;
  for (int i = 0; i < n; ++i) {
    Pose p;
    // One draw per statement: the order a function's arguments are evaluated in is the compiler's
    // (gcc and clang differ), and the views must not.
    const double rx = rng.uniform(-0.5, 0.5), ry = rng.uniform(-0.5, 0.5), rz = rng.uniform(-0.2, 0.2);
    p.rvec = cv::Vec3d(rx, ry, rz);
    // The board's centre (4 x 2.5 squares from its origin) at the aim point.
    cv::Matx33d R;
    cv::Rodrigues(p.rvec, R);
    const double cx = 100 + rng.uniform(-60.0, 60.0), cy = rng.uniform(-50.0, 50.0), cz = rng.uniform(850.0, 1150.0);
    const cv::Vec3d centre(cx, cy, cz);
    p.tvec = centre - R * cv::Vec3d(4 * kBoard.square, 2.5 * kBoard.square, 0);
    out.push_back(p);
  }
  return out;
}

// The board `b` seen by both cameras of `rig` at the first `n` of poses(): left and right images.
struct Views {
  std::vector<cv::Mat> left, right;
};
Views views(const Rig& rig, const Board& b, int n) {
  Views v;
  for (const Pose& p : poses(n)) {
    v.left.push_back(render_board(rig.left, b, p));
    v.right.push_back(render_board(rig.right, b, in_right(rig, p)));
  }
  return v;
}

// A plate of dots facing the pair at ~1 m; its points in the left frame.
std::vector<cv::Point3d> plate() {
  std::vector<cv::Point3d> p;
  for (int y = -5; y <= 5; ++y)
    for (int x = -5; x <= 5; ++x) p.emplace_back(100 + 20.0 * x, 20.0 * y, 1000);
  return p;
}

std::vector<cv::Point2d> project(const Camera& c, const std::vector<cv::Point3d>& X, const cv::Matx33d& R,
                                 const cv::Vec3d& T) {
  cv::Vec3d rvec;
  cv::Rodrigues(R, rvec);
  std::vector<cv::Point2d> x;
  cv::projectPoints(X, rvec, T, c.K, c.dist, x);
  return x;
}

TEST(Stereo, CalibrationRecoversFocalLengthAndBaselineWithinATenthOfAPercent) {
  const Rig rig = truth();
  auto [L, R] = views(rig, kBoard, 20);
  const Calibration c = calibrate(L, R, kBoard);
  EXPECT_GE(c.views_used, 12);
  for (const auto& n : c.notes) std::printf("%s\n", n.c_str());
  std::printf("K_left fx %.3f fy %.3f cx %.3f cy %.3f k1 %.5f; K_right fx %.3f fy %.3f cx %.3f cy %.3f k1 %.5f; T %.3f %.3f %.3f\n",
              c.rig.left.K(0, 0), c.rig.left.K(1, 1), c.rig.left.K(0, 2), c.rig.left.K(1, 2), c.rig.left.dist.at<double>(0),
              c.rig.right.K(0, 0), c.rig.right.K(1, 1), c.rig.right.K(0, 2), c.rig.right.K(1, 2), c.rig.right.dist.at<double>(0),
              c.rig.T[0], c.rig.T[1], c.rig.T[2]);
  for (const Camera* cam : {&c.rig.left, &c.rig.right}) {
    EXPECT_NEAR(cam->K(0, 0), 1600, 1.6) << "fx";
    EXPECT_NEAR(cam->K(1, 1), 1600, 1.6) << "fy";
  }
  EXPECT_NEAR(c.rig.baseline(), 200, 0.2);
  EXPECT_LT(c.rms_stereo, 0.1);
  EXPECT_LT(c.epipolar_rms, 0.1);
  // The rotation between the cameras: the convergence angle.
  cv::Vec3d r;
  cv::Rodrigues(c.rig.R, r);
  EXPECT_NEAR(cv::norm(r) * 180 / CV_PI, 11.3, 0.05);

  // The calibrated pair triangulates a bulge of the plate (seen through the true pair) within
  // 1/20,000 of the field of view.
  const auto X0 = plate();
  std::vector<cv::Point3d> X1;
  auto bulge = [](const cv::Point3d& p) { return 0.8 * std::exp(-((p.x - 100) * (p.x - 100) + p.y * p.y) / 5000.0); };
  for (const auto& p : X0) X1.emplace_back(p.x, p.y, p.z - bulge(p));
  const auto uz = out_of_plane(triangulate(c.rig, project(rig.left, X0, cv::Matx33d::eye(), {0, 0, 0}),
                                           project(rig.right, X0, rig.R, rig.T)),
                               triangulate(c.rig, project(rig.left, X1, cv::Matx33d::eye(), {0, 0, 0}),
                                           project(rig.right, X1, rig.R, rig.T)));
  double se = 0;
  for (std::size_t i = 0; i < uz.size(); ++i) se += std::pow(uz[i] - bulge(X0[i]), 2);
  EXPECT_LT(std::sqrt(se / static_cast<double>(uz.size())), 1280.0 / 1600 * 1000 / 20000);

  // Written and read back; a calibration of another image size is refused.
  const auto dir = test::fresh_test_dir("dtflop_stereo");
  write_rig((dir / "rig.yaml").string(), c);
  const Rig back = read_rig((dir / "rig.yaml").string(), cv::Size(1280, 960));
  EXPECT_DOUBLE_EQ(back.baseline(), c.rig.baseline());
  EXPECT_THROW(read_rig((dir / "rig.yaml").string(), cv::Size(1920, 1080)), InputError);
  EXPECT_THROW(read_rig((dir / "none.yaml").string()), InputError);
}

TEST(Stereo, CircleGridCalibrationRecoversFocalLengthAndBaseline) {
  const Rig rig = truth();
  const Board circles{{4, 11}, 30.0, Board::Target::circles};  // 4 x 11 asymmetric: 105 x 150 mm
  auto [L, R] = views(rig, circles, 20);
  const Calibration c = calibrate(L, R, circles);
  for (const auto& n : c.notes) std::printf("%s\n", n.c_str());
  EXPECT_GE(c.views_used, 12);
  for (const Camera* cam : {&c.rig.left, &c.rig.right}) {
    EXPECT_NEAR(cam->K(0, 0), 1600, 1.6) << "fx";
    EXPECT_NEAR(cam->K(1, 1), 1600, 1.6) << "fy";
  }
  EXPECT_NEAR(c.rig.baseline(), 200, 0.2);
}

// A view whose board is found but wrongly (here the left image mirrored: every corner found, in
// an order no pose of the board gives) is left out with a note, and the rest calibrate as well
// as without it.
TEST(Stereo, AViewWithAMisdetectedTargetIsLeftOut) {
  const Rig rig = truth();
  auto [L, R] = views(rig, kBoard, 12);
  cv::flip(L[3].clone(), L[3], 1);
  const Calibration c = calibrate(L, R, kBoard);
  for (const auto& n : c.notes) std::printf("%s\n", n.c_str());
  EXPECT_EQ(c.views_used, 11);
  bool said = false;
  for (const auto& n : c.notes) said = said || (n.rfind("view 4: ", 0) == 0 && n.find("misdetected") != std::string::npos);
  EXPECT_TRUE(said);
  for (const Camera* cam : {&c.rig.left, &c.rig.right}) {
    EXPECT_NEAR(cam->K(0, 0), 1600, 1.6) << "fx";
    EXPECT_NEAR(cam->K(1, 1), 1600, 1.6) << "fy";
  }
  EXPECT_LT(c.rms_stereo, 0.1);
}

TEST(Stereo, TooFewViewsAreRefused) {
  const Rig rig = truth();
  auto [L, R] = views(rig, kBoard, 2);
  EXPECT_THROW(calibrate(L, R, kBoard), InputError);
}

TEST(Stereo, TriangulatedOutOfPlaneMotionMatchesTheClosedForms) {
  const Rig rig = truth();
  const auto X0 = plate();
  const double fov = 1280.0 / 1600 * 1000;  // field of view across at the plate, mm
  // Closed forms: the plate faces -z (toward the cameras), so u_z = -dz.
  struct Motion {
    const char* name;
    double (*w)(const cv::Point3d&);
  };
  const Motion motions[] = {
      {"rigid", [](const cv::Point3d&) { return 0.5; }},
      {"tilt", [](const cv::Point3d& p) { return 1e-3 * (p.x - 100); }},
      {"bulge", [](const cv::Point3d& p) { return 0.8 * std::exp(-((p.x - 100) * (p.x - 100) + p.y * p.y) / 5000.0); }},
  };
  for (const auto& m : motions) {
    std::vector<cv::Point3d> X1;
    for (const auto& p : X0) X1.emplace_back(p.x, p.y, p.z - m.w(p));
    const auto L0 = project(rig.left, X0, cv::Matx33d::eye(), {0, 0, 0});
    const auto R0 = project(rig.right, X0, rig.R, rig.T);
    const auto L1 = project(rig.left, X1, cv::Matx33d::eye(), {0, 0, 0});
    const auto R1 = project(rig.right, X1, rig.R, rig.T);
    const auto uz = out_of_plane(triangulate(rig, L0, R0), triangulate(rig, L1, R1));
    double se = 0;
    for (std::size_t i = 0; i < uz.size(); ++i) se += std::pow(uz[i] - m.w(X0[i]), 2);
    const double rms = std::sqrt(se / static_cast<double>(uz.size()));
    EXPECT_LT(rms, fov / 20000) << m.name << ": u_z RMS " << rms << " mm";
  }
}

TEST(Stereo, GradientOfUzMatchesATiltAndARigidMotion) {
  const Rig rig = truth();
  const auto X0 = plate();
  for (const double slope : {0.0, 1e-3}) {
    std::vector<cv::Point3d> X1;
    for (const auto& p : X0) X1.emplace_back(p.x, p.y, p.z - 0.3 - slope * (p.x - 100));  // w = 0.3 + slope (x - 100)
    const auto P0 = triangulate(rig, project(rig.left, X0, cv::Matx33d::eye(), {0, 0, 0}), project(rig.right, X0, rig.R, rig.T));
    const auto P1 = triangulate(rig, project(rig.left, X1, cv::Matx33d::eye(), {0, 0, 0}), project(rig.right, X1, rig.R, rig.T));
    const auto g = out_of_plane_gradient(P0, out_of_plane(P0, P1));
    ASSERT_EQ(g.size(), X0.size());
    for (const auto& v : g) {
      EXPECT_NEAR(v[0], slope, 2e-6);  // e1 is the x axis on this plate
      EXPECT_NEAR(v[1], 0.0, 2e-6);
    }
  }
  EXPECT_THROW(out_of_plane_gradient(X0, {1.0, 2.0}), InputError);
}

TEST(Stereo, MismatchedPointListsAreRefused) {
  EXPECT_THROW(triangulate(truth(), {{1, 2}}, {}), InputError);
}

}  // namespace
}  // namespace dtflop::dct::stereo
