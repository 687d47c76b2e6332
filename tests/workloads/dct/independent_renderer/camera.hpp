// Views of a plate through a camera, for checking stereo DCT. Independent of workloads/dct: the
// geometry is OpenCV's cv::projectPoints (pinhole, radial and tangential distortion), the
// pixels are the exact area of each pixel covered by the projected outlines (polygons clipped
// against the pixel's square), so the rendered image holds no convention of dtflop's own.
//
// The plate frame: X, Y in the plate (mm), Z its normal. A view is the plate posed in the
// camera's frame (X_camera = R(rvec) X_plate + tvec). Shapes are outlines on the plate (dots as
// 128-gons, squares with edges cut 16 times so that lens distortion bends them), each moved by a
// displacement field u(X, Y) (mm, plate frame; u_z off the plate) before projection.
#pragma once

#include <functional>
#include <vector>

#include <opencv2/core.hpp>

namespace dct_indep {

struct CameraModel {
  cv::Matx33d K = cv::Matx33d::eye();
  cv::Mat dist = cv::Mat::zeros(1, 5, CV_64F);
  cv::Size size;
};

// A converging pair: focal length f px, principal points at the image centres, the right camera
// `baseline` mm along the left one's x axis, turned about y by `convergence_deg` toward the
// left one, radial distortion k1 on both. R, T as OpenCV's stereoCalibrate: x_right = R x_left + T.
struct CameraPair {
  CameraModel left, right;
  cv::Matx33d R;
  cv::Vec3d T;
};
CameraPair make_pair(cv::Size size, double f, double baseline_mm, double convergence_deg, double k1);

struct PlatePose {
  cv::Vec3d rvec, tvec;  // plate -> left camera
};
// The same plate seen from the right camera.
PlatePose right_pose(const CameraPair& pair, const PlatePose& left);

using Displacement = std::function<cv::Vec3d(double X, double Y)>;  // mm, plate frame

struct Shape {
  std::vector<cv::Point3d> outline;  // plate frame (Z = 0), mm, in order
  double level = 0;                  // grey level inside
};

// Dots of radius r (mm) at the centres given, each a 128-gon.
std::vector<Shape> dot_shapes(const std::vector<cv::Point2d>& centres, double r, double level);
// A checkerboard of inner corners inner.width x inner.height, squares `square` mm, the first
// inner corner at the plate origin, on a white card of one square's margin.
std::vector<Shape> checkerboard_shapes(cv::Size inner, double square, double white, double black);

// The view (CV_8UC1 or CV_16UC1 by `depth`: 8-bit levels, times 257 for 16) of `shapes` on a
// `background`, painted in order, each shape's outline moved by `u` (none: not moved).
cv::Mat render_view(const CameraModel& cam, const PlatePose& pose, const std::vector<Shape>& shapes,
                    double background, int depth = CV_8U, const Displacement& u = {});

// The image of plate points (after the displacement u, when given) in the camera: cv::projectPoints.
std::vector<cv::Point2d> project(const CameraModel& cam, const PlatePose& pose, const std::vector<cv::Point2d>& plate,
                                 const Displacement& u = {});
// The plate point (X, Y) (Z = 0, undeformed) seen at image point p: the camera's ray met with
// the plate's plane.
cv::Point2d on_plate(const CameraModel& cam, const PlatePose& pose, cv::Point2d p);

}  // namespace dct_indep
