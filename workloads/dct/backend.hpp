// The DCT pipeline and its backends. A backend takes a reference frame once (finds its
// dots and builds the dot-to-point look-up table, seed 7.3) and then turns each deformed
// frame into displacement and strain fields:
//   cpu-seq  float64 reference: OpenCV threshold + sequential labelling, one thread
//   cpu-par  float64, OpenCV's parallel labelling, centroids and fields on `threads` threads
//   cuda     float32 on the device: frame upload, threshold, labelling, centroids,
//            displacements and MLS/FE; centroids, displacements and the look-up table stay
//            in device buffers; the matching runs on the host (k-d tree)
// Every backend reports the frame's measured shape and its CostCounts (counts.hpp).
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "model/cost_counts.hpp"
#include "workloads/dct/analysis.hpp"
#include "workloads/dct/counts.hpp"
#include "workloads/dct/fields.hpp"
#include "workloads/dct/tracking.hpp"

namespace dtflop::dct {

struct PipelineOptions {
  AnalysisOptions analysis;
  MatchOptions match;
  Interp interp = Interp::mls;
  MlsOptions mls;
  double fe_max_gap = 2.5;        // FE: nearest dot farther than this x median spacing: invalid
  int points_x = 32, points_y = 32;
  double points_inset = 0;        // px inside the reference dots' bounding box
  std::vector<Vec2> points;       // explicit points (reference frame); overrides the grid
  bool follow = true;             // predict each frame's dots from the previous frame
  int threads = 0;                // cpu-par: 0 = all hardware threads
  CudaLayout layout;              // cuda
  bool pinned_frames = true;      // cuda: stage frames through pinned host memory
};

struct FrameOutput {
  std::vector<DotObservation> dots;     // found in this frame
  AnalysisStats stats;
  Matches matches;
  std::vector<Vec2> displacement;       // per reference dot (valid where tracked)
  std::vector<std::uint8_t> tracked;    // per reference dot
  std::vector<FieldValue<double>> fields;  // per point
  FrameShape shape;
  CostCounts counts;
  std::map<std::string, double> seconds;  // per stage, host clock (cuda: device events too)
};

class Backend {
 public:
  virtual ~Backend() = default;
  virtual std::string name() const = 0;
  // Finds the reference dots and builds the look-up table. Throws InputError when the image
  // holds no usable dots.
  virtual void set_reference(const cv::Mat& image) = 0;
  // One deformed frame. Throws InputError for a frame that does not fit the reference.
  virtual FrameOutput process(const cv::Mat& frame) = 0;
  // A frame-sized buffer the backend uploads from fastest (pinned host memory for cuda), for
  // a camera or a renderer to write frames into. Valid until the next call.
  virtual cv::Mat frame_buffer(cv::Size size, int type) { return cv::Mat(size, type); }

  const std::vector<DotObservation>& reference_dots() const { return ref_dots_; }
  const std::vector<Vec2>& reference_positions() const { return ref_pos_; }
  const std::vector<Vec2>& points() const { return points_; }
  const PipelineOptions& options() const { return opt_; }
  const MlsTable& mls_table() const { return mls_; }
  const FeTable& fe_table() const { return fe_; }

 protected:
  explicit Backend(PipelineOptions o) : opt_(std::move(o)) {}
  // Shared host steps: accept the reference dots and build the tables.
  void accept_reference(const cv::Mat& image, std::vector<DotObservation> dots, const AnalysisStats& st);
  // Matching with the sequence prediction; fills out.matches, displacement, tracked.
  void track(const std::vector<Vec2>& found, FrameOutput& out);
  void check_frame(const cv::Mat& frame) const;

  PipelineOptions opt_;
  cv::Size size_;
  int depth_ = 0;
  std::vector<DotObservation> ref_dots_;
  std::vector<Vec2> ref_pos_;
  std::vector<Vec2> points_;
  MlsTable mls_;
  FeTable fe_;
  double match_radius_ = 0;
  std::vector<Vec2> last_disp_;
  std::vector<std::uint8_t> last_tracked_;
};

// "cpu-seq", "cpu-par", "cuda". Throws InputError for an unknown name or a cuda backend
// where dtflop was built without CUDA or no device is usable (with the reason).
std::unique_ptr<Backend> make_backend(const std::string& name, const PipelineOptions& o);
std::vector<std::string> backend_names();
// Empty when the cuda backend can run here; otherwise why not.
std::string cuda_unavailable_reason();

#ifdef DTFLOP_HAVE_CUDA
std::unique_ptr<Backend> make_cuda_backend(const PipelineOptions& o);  // cuda_backend.cpp
std::string cuda_device_check();                                     // cuda_backend.cpp
#endif

}  // namespace dtflop::dct
