// Stereo DCT (library dtflop_stereo, OpenCV calib3d): camera and stereo calibration from
// checkerboard views, calibration targets rendered from a known camera pair, and triangulation
// of matched dot centroids into 3D positions and the out-of-plane displacement u_z.
//
// Conventions: pixel centres at integer coordinates (as the specimen renderer, specimen.hpp);
// a camera maps a point X of its own frame to x = K * distort(X / X.z); the right camera's frame
// is x_right = R * x_left + T (OpenCV's stereoCalibrate), so the baseline is |T| in the
// checkerboard's length unit.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace dtflop::dct::stereo {

struct Camera {
  cv::Matx33d K = cv::Matx33d::eye();
  cv::Mat dist = cv::Mat::zeros(1, 5, CV_64F);  // k1 k2 p1 p2 k3
  cv::Size size;
};

struct Rig {
  Camera left, right;
  cv::Matx33d R = cv::Matx33d::eye();
  cv::Vec3d T;  // right = R left + T
  double baseline() const { return cv::norm(T); }
};

// A known pair: two cameras of focal length f px on an image of `size`, `baseline` apart
// along x, each turned by `convergence_deg` toward the other (so their axes cross in front),
// with radial distortion k1.
Rig make_rig(cv::Size size, double f, double baseline, double convergence_deg, double k1 = 0);

struct Board {
  enum class Target { checkerboard, circles };
  cv::Size inner;       // checkerboard: inner corners; circles: circles per row x rows
  double square = 1.0;  // side of a square, or the circles' pitch, in the length unit of T
  // circles: OpenCV's asymmetric grid (unambiguous under rotation): circle (row i, column j) at
  // ((2j + i mod 2) square / 2, i square / 2), dark discs of radius square / 8 ... square / 4.
  Target target = Target::checkerboard;
};

// The board's inner corners (circle centres) in its own plane (z = 0).
std::vector<cv::Point3f> board_corners(const Board& b);

// A view of the board: its pose in the left camera's frame.
struct Pose {
  cv::Vec3d rvec, tvec;
};

// Renders `camera`'s image of the board at `pose` (8-bit, white margin of one square around
// the squares or circles, grey 40/215 on 110; square edges are projected with cv::projectPoints
// every 1/8 side and circles as 128-gons, so the lens distortion bends them). Each pixel (pixel c
// covering [c - 1/2, c + 1/2]) is mixed by the area the outlines cover: exact along 32 lines
// per pixel row.
cv::Mat render_board(const Camera& camera, const Board& b, const Pose& pose_in_camera);

// A pose seen from the right camera of `rig`, given the pose in the left camera's frame.
Pose in_right(const Rig& rig, const Pose& left);

struct Calibration {
  Rig rig;
  double rms_left = 0, rms_right = 0;  // reprojection RMS of each camera's own calibration, px
  double rms_stereo = 0;               // stereoCalibrate's RMS, px
  double epipolar_rms = 0;             // RMS distance of right corners to their epipolar lines, px
  int views_used = 0;
  std::vector<std::string> notes;      // views where the board was not found, and verdicts
};

// Calibrates both cameras and the pair from image pairs of `b`. A pair is left out, with a note,
// where either image does not show the whole board, or where its board reprojects an outlier
// (5x the median view and over 0.25 px) in either camera's calibration or the pair's: a
// misdetected target. Throws InputError when fewer than 3 pairs are left, or the images differ
// in size.
Calibration calibrate(const std::vector<cv::Mat>& left, const std::vector<cv::Mat>& right, const Board& b);

// What the errors mean, one line each: a reprojection RMS under 0.1 px is good, up to 0.5 px
// usable, more a calibration to redo (blur, a moved board, too few or too similar views).
std::vector<std::string> judge(const Calibration& c);

// Writes / reads a calibration (OpenCV FileStorage, YAML). read_rig throws InputError for a
// missing or malformed file, non-finite values or a non-rotation R, and, with `expect`, images
// of another size than the calibration's.
void write_rig(const std::string& path, const Calibration& c);
Rig read_rig(const std::string& path, std::optional<cv::Size> expect = std::nullopt);

// 3D points (left camera frame) of matched image points in the two cameras (undistorted, then
// cv::triangulatePoints). Throws InputError when the lists differ in length.
std::vector<cv::Point3d> triangulate(const Rig& rig, const std::vector<cv::Point2d>& left,
                                     const std::vector<cv::Point2d>& right);

// The plane fitted (least squares) to reference points: its centroid, in-plane axes e1 (the left
// camera's x axis projected onto it) and e2, and its normal n, turned toward the left camera.
struct PlaneFrame {
  cv::Vec3d origin, e1, e2, n;
};
PlaneFrame fit_plane(const std::vector<cv::Point3d>& points);

// Out-of-plane displacement of each point: (deformed - reference) along the normal of the
// plane fitted to the reference points (least squares), oriented toward the left camera.
std::vector<double> out_of_plane(const std::vector<cv::Point3d>& reference, const std::vector<cv::Point3d>& deformed);

// The gradient of u_z over the plate, (du_z/ds1, du_z/ds2) along the plane's e1, e2, at each
// reference point: the least-squares plane through (s1, s2, u_z) of its `neighbours` nearest
// points (itself included). Throws InputError for lists of different lengths or fewer than
// `neighbours` >= 3 points.
std::vector<cv::Vec2d> out_of_plane_gradient(const std::vector<cv::Point3d>& reference, const std::vector<double>& uz,
                                             int neighbours = 9);

}  // namespace dtflop::dct::stereo
