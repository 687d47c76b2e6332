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

// What every backend shares once a reference is set: the options, the reference dots, the
// interpolation points, the look-up tables, the matching radius and the previous frame's
// displacements (for following a sequence). Backends hold one and reach it through
// Backend::state(); its data changes only through its own steps.
class PipelineState {
 public:
  explicit PipelineState(PipelineOptions o) : opt_(std::move(o)) {}

  // Accepts the reference dots found in `image` and builds the tables. Throws InputError when
  // there are too few dots for the interpolation (with what the filters rejected).
  void accept_reference(const cv::Mat& image, std::vector<DotObservation> dots, const AnalysisStats& st);
  // Matching with the sequence prediction; fills out.matches, displacement, tracked.
  void track(const std::vector<Vec2>& found, FrameOutput& out);
  // Throws InputError for a frame that does not fit the reference (or comes before one).
  void check_frame(const cv::Mat& frame) const;

  const PipelineOptions& options() const { return opt_; }
  cv::Size size() const { return size_; }
  const std::vector<DotObservation>& reference_dots() const { return ref_dots_; }
  const std::vector<Vec2>& reference_positions() const { return ref_pos_; }
  const std::vector<Vec2>& points() const { return points_; }
  const MlsTable& mls_table() const { return mls_; }
  const FeTable& fe_table() const { return fe_; }
  double match_radius() const { return match_radius_; }
  // Support entries of the table (MLS: support dots; FE: recovery triangles), summed over the
  // points: what the field stage reads per frame.
  std::int64_t support_entries() const { return opt_.interp == Interp::mls ? mls_.entries() : fe_.entries(); }
  // The shape of a frame analysed into `stats` and matched with `work`, against this reference:
  // what the frame's counts are computed from (counts.hpp).
  FrameShape frame_shape(const cv::Mat& frame, const AnalysisStats& stats, const MatchWork& work) const;

 private:
  PipelineOptions opt_;
  cv::Size size_;
  int depth_ = 0;
  std::vector<DotObservation> ref_dots_;
  std::vector<Vec2> ref_pos_;
  std::vector<Vec2> points_;
  MlsTable mls_;
  FeTable fe_;
  double match_radius_ = 0;
  Matcher matcher_;  // its buffers kept from frame to frame
  std::vector<Vec2> last_disp_;
  std::vector<std::uint8_t> last_tracked_;
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
  // Whether the next frames time their device stages (a GPU backend: events between its copies and
  // kernels, FrameOutput::seconds "device_*"). Off by default: ten event records cost a frame about
  // 16 us of host time on a lent H200's host, 5% of a frame of a thousand dots
  // (docs/PERFORMANCE.md, "Device stage times on request").
  virtual void time_device_stages(bool) {}

  const std::vector<DotObservation>& reference_dots() const { return state_.reference_dots(); }
  const std::vector<Vec2>& reference_positions() const { return state_.reference_positions(); }
  const std::vector<Vec2>& points() const { return state_.points(); }
  const PipelineOptions& options() const { return state_.options(); }
  const MlsTable& mls_table() const { return state_.mls_table(); }
  const FeTable& fe_table() const { return state_.fe_table(); }
  FrameShape frame_shape(const cv::Mat& frame, const AnalysisStats& stats, const MatchWork& work) const {
    return state_.frame_shape(frame, stats, work);
  }

 protected:
  explicit Backend(PipelineOptions o) : state_(std::move(o)) {}
  PipelineState& state() { return state_; }
  const PipelineState& state() const { return state_; }

 private:
  PipelineState state_;
};

// The backends, declared once: what each is (name, description, whether it needs a GPU), how
// to make its pipeline, its exact counts of one frame of a given shape, and why it cannot run
// here (empty when it can). make_backend(), backend_names() and the DCT workload's backend
// list (workload.hpp) all read this list.
struct BackendKind {
  std::string name;
  std::string description;
  bool needs_gpu = false;
  std::unique_ptr<Backend> (*make)(const PipelineOptions& o) = nullptr;
  CostCounts (*frame_counts)(const FrameShape& s, const PipelineOptions& o) = nullptr;
  std::string (*unavailable)() = nullptr;
};
const std::vector<BackendKind>& backend_kinds();
// Throws InputError naming the known backends when `name` is unknown.
const BackendKind& backend_kind(const std::string& name);
// The CPU threads a cpu-par pipeline uses for `o` (o.threads, or every hardware thread).
int cpu_threads(const PipelineOptions& o);

// "cpu-seq", "cpu-par", "cuda". Throws InputError for an unknown name, or a cuda backend
// where dtflop was built without CUDA or no device is usable (with the reason).
std::unique_ptr<Backend> make_backend(const std::string& name, const PipelineOptions& o);
std::vector<std::string> backend_names();
// Empty when the cuda backend can run here; otherwise why not.
std::string cuda_unavailable_reason();

#ifdef DTFLOP_HAVE_CUDA
std::unique_ptr<Backend> make_cuda_backend(const PipelineOptions& o);  // cuda_backend.cpp
#endif

}  // namespace dtflop::dct
