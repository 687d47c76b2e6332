// Stereo DCT on dots (library dtflop_stereo): the dots of the left and right views matched to
// each other, triangulated into 3D positions, and the out-of-plane displacement u_z with its
// gradient at the interpolation points.
//
// Matching (match_stereo) works on rectified coordinates (cv::stereoRectify of the calibrated
// pair), where a dot's partner lies on the same row. A row of dots on the plate holds many
// candidates, so the row alone does not decide: one seed dot near the middle tries each of its
// candidates in turn, and the matching is grown from it over the left dots' neighbours, each
// taking the candidate whose disparity is nearest its matched neighbours' (a plate is smooth:
// neighbouring dots differ little in disparity, dots of one row differ by the dot spacing). The
// seed candidate whose matching reaches most dots wins; a tie means the pattern repeats along the
// rows and every dot is reported ambiguous. A dot is left unmatched, with why, when nothing lies
// on its row, when two candidates fit its neighbours, when its right dot is claimed by another,
// or when no candidate fits its neighbours' disparity (off the surface).
//
// StereoPipeline runs a 2D DCT backend per camera (the left camera's fields are the in-plane
// fields, as the single-camera path gives them), matches the two reference frames once, and in
// each frame pairs the left and right dots through their own tracking, triangulates them, and
// gives u_z (mm, along the normal of the plane fitted to the reference points, toward the
// cameras) per dot and, by a weighted local quadratic fit in the plate's plane, u_z and its
// gradient (du_z/dx, du_z/dy along the plane's axes e1, e2; e1 is the left camera's x axis
// projected onto the plate) at each interpolation point.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "workloads/dct/backend.hpp"
#include "workloads/dct/stereo.hpp"

namespace dtflop::dct::stereo {

struct StereoMatchOptions {
  double epipolar_tolerance = 1.5;  // px: the most a partner may lie off its rectified row
  double disparity_tolerance = 0.3; // x the right dots' median spacing: the most a dot's disparity may
                                    // differ from its matched neighbours' mean
  int neighbours = 6;               // left neighbours a dot's disparity is predicted from
};

// Validates the options (finite, in range); throws InputError naming the one that is wrong.
void validate(const StereoMatchOptions& o);

enum class StereoLost : std::uint8_t {
  none = 0,
  nothing_on_row,    // no right dot lies within the epipolar tolerance of its row (in front of both cameras)
  ambiguous,         // two right dots fit its neighbours' disparity, or the pattern repeats along the rows
  claimed_by_other,  // its right dot was taken by two left dots
  off_surface,       // no candidate fits its matched neighbours' disparity (or none is matched near it)
  lost_left,         // per frame: the left camera's tracking lost it
  lost_right,        // per frame: the right camera's tracking lost its partner
  off_epipolar,      // per frame: its deformed pair lies farther off the row than the tolerance
};
std::string to_string(StereoLost r);

// The pair's rectification (cv::stereoRectify, zero disparity at infinity).
struct Rectification {
  cv::Matx33d R1, R2;
  cv::Matx34d P1, P2;
  bool vertical = false;  // the cameras are above one another: rows are columns
  double sign = 1;        // disparity (left - right along the rows) of a point in front is sign * positive
};
Rectification rectify(const Rig& rig);
// Rectified coordinates of left (right = false) or right image points.
std::vector<cv::Point2d> rectified(const Rig& rig, const Rectification& r, bool right,
                                   const std::vector<cv::Point2d>& points);

struct StereoMatches {
  std::vector<int> left_to_right;      // per left dot: right index or -1
  std::vector<StereoLost> lost;        // per left dot
  std::vector<double> row_offset_px;   // per left dot: right row - left row (rectified), NaN when unmatched
  std::vector<int> unmatched_right;    // right dots no left dot took
  int matched = 0;
  int seeds_tried = 0;                 // seed candidates grown
  int best_reach = 0, second_reach = 0;  // dots the best and second-best seed matchings reached
  std::string summary() const;         // "1500 of 1520 left dots matched; lost: 12 nothing on row, ..."
};

// Matches left dots to right dots (image pixels, distorted as seen). Throws InputError when a
// list is empty or the options are out of range.
StereoMatches match_stereo(const Rig& rig, const std::vector<cv::Point2d>& left, const std::vector<cv::Point2d>& right,
                           const StereoMatchOptions& o = {});

// One interpolation point's out-of-plane field.
struct UzValue {
  double uz = 0, duz_dx = 0, duz_dy = 0;  // mm; slopes along e1, e2 (mm/mm)
  PointStatus status = PointStatus::ok;
  int support = 0;  // dots that contributed
};

struct StereoFrame {
  FrameOutput left, right;                 // each camera's 2D pipeline
  std::vector<cv::Point3d> position;       // per left reference dot: deformed 3D position (NaN when not valid)
  std::vector<double> uz;                  // per left reference dot, mm (NaN when not valid)
  std::vector<StereoLost> why;             // per left reference dot (none: valid)
  std::vector<int> right_dot;              // per left reference dot: the right frame's dot index, or -1
  std::vector<UzValue> fields;             // per point of the left backend
  int triangulated = 0;
  std::map<std::string, double> seconds;   // "left: ...", "right: ...", "stereo"
};

class StereoPipeline {
 public:
  // Two backends of kind `backend` with options `o` (one per camera). The calibration must be
  // of the frames' size (checked at the reference).
  StereoPipeline(Rig rig, const std::string& backend, const PipelineOptions& o, StereoMatchOptions so = {});
  ~StereoPipeline();

  // Finds the dots of both reference frames, matches them, triangulates the reference. Throws
  // InputError for frames of another size than the calibration's, of different sizes, or with
  // fewer than 6 stereo-matched dots (naming why the others were lost).
  void set_reference(const cv::Mat& left, const cv::Mat& right);
  // One pair of deformed frames. Throws InputError for frames that do not fit the reference.
  StereoFrame process(const cv::Mat& left, const cv::Mat& right);

  const Rig& rig() const { return rig_; }
  Backend& left() { return *left_; }
  Backend& right() { return *right_; }
  const Backend& left() const { return *left_; }
  const Backend& right() const { return *right_; }
  const StereoMatches& reference_matches() const { return ref_match_; }
  const std::vector<cv::Point3d>& reference_positions() const { return ref3d_; }  // per left ref dot (NaN: unmatched)
  const PlaneFrame& plane() const { return plane_; }
  const std::vector<Vec2>& points() const { return left_->points(); }

 private:
  Rig rig_;
  StereoMatchOptions so_;
  Rectification rect_;
  std::unique_ptr<Backend> left_, right_;
  StereoMatches ref_match_;
  std::vector<cv::Point3d> ref3d_;
  PlaneFrame plane_;
  std::vector<cv::Vec2d> ref_plane_;               // per left ref dot: plate coordinates (s1, s2), mm
  std::vector<std::vector<std::int32_t>> support_; // per point: support dots (left ref indices)
  std::vector<cv::Vec2d> point_plane_;             // per point: plate coordinates
  std::vector<double> rho_;                        // per point: support radius, mm
  double uz_gap_ = 0;
};

// The fields CSV of a stereo frame: dtflop fields' columns (without the deviations) and
// u_z_mm, du_z_dx, du_z_dy, u_z_status, u_z_support.
inline constexpr const char* kStereoCsvHeader =
    "x_px,y_px,u_x_px,u_y_px,e_xx_microstrain,e_yy_microstrain,e_xy_microstrain,valid,status,support,"
    "u_z_mm,du_z_dx,du_z_dy,u_z_status,u_z_support";
void write_stereo_fields_csv(const std::filesystem::path& path, const std::vector<Vec2>& points,
                             const std::vector<FieldValue<double>>& fields, const std::vector<UzValue>& uz);

// The stereo dots table: one row per left reference dot (matched or lost, with why): its right
// partner, both reference and deformed centroids, reference and deformed 3D positions (mm, left
// camera frame), u_z and the rectified row offset; then one row per right reference dot no left
// dot took.
inline constexpr const char* kStereoDotsCsvHeader =
    "left_id,right_id,status,reason,x_left_ref_px,y_left_ref_px,x_right_ref_px,y_right_ref_px,X_ref_mm,Y_ref_mm,"
    "Z_ref_mm,x_left_px,y_left_px,x_right_px,y_right_px,X_mm,Y_mm,Z_mm,u_z_mm,row_offset_ref_px";
void write_stereo_dots_csv(const std::filesystem::path& path, const StereoPipeline& p, const StereoFrame& f);

}  // namespace dtflop::dct::stereo
