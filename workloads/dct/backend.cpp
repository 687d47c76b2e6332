#include "workloads/dct/backend.hpp"

#include "cuda/device.hpp"

#include <algorithm>
#include <chrono>
#include <thread>

#include <fmt/format.h>

#include "model/errors.hpp"

namespace dtflop::dct {
namespace {

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string rejection_summary(const AnalysisStats& st) {
  return fmt::format("threshold {:g}, {} components: {} rejected by area, {} by shape, {} at the border, {} "
                     "without contrast",
                     st.threshold, st.components, st.rejected_area, st.rejected_shape, st.rejected_border,
                     st.rejected_contrast);
}

}  // namespace

FrameShape PipelineState::frame_shape(const cv::Mat& frame, const AnalysisStats& stats,
                                     const MatchWork& work) const {
  FrameShape s;
  s.image_pixels = static_cast<std::int64_t>(frame.total());
  s.bytes_per_pixel = frame.depth() == CV_16U ? 2 : 1;
  s.roi_pixels = stats.roi_pixels;
  s.foreground_pixels = stats.foreground_pixels;
  s.components = stats.components;
  s.dots = static_cast<std::int64_t>(ref_pos_.size());
  s.window_pixels = stats.window_pixels;
  s.ring_pixels = stats.ring_pixels;
  s.weighted_pixels = stats.weighted_pixels;
  s.scanned_pixels = stats.scanned_pixels;
  s.margin = opt_.analysis.margin;
  s.points = static_cast<std::int64_t>(points_.size());
  s.support_entries = support_entries();
  s.tree_steps = work.tree_steps;
  s.match_steps = work.match_steps;
  s.interp = opt_.interp;
  s.weight = opt_.mls.weight;
  s.otsu = opt_.analysis.method == ThresholdMethod::otsu;
  s.adaptive = opt_.analysis.method == ThresholdMethod::adaptive;
  return s;
}

void PipelineState::check_frame(const cv::Mat& frame) const {
  if (ref_pos_.empty()) throw InputError("no reference frame was set before processing a frame");
  if (frame.empty()) throw InputError("the frame is empty (unreadable image?)");
  if (frame.size() != size_ || frame.depth() != depth_ || frame.channels() != 1)
    throw InputError(fmt::format("the frame is {}x{} {}-bit with {} channel(s) but the reference is {}x{} {}-bit grey; "
                                 "all frames must come from the same camera setting",
                                 frame.cols, frame.rows, frame.depth() == CV_16U ? 16 : 8, frame.channels(),
                                 size_.width, size_.height, depth_ == CV_16U ? 16 : 8));
}

void PipelineState::accept_reference(const cv::Mat& image, std::vector<DotObservation> dots, const AnalysisStats& st) {
  if (dots.empty())
    throw InputError(fmt::format("no dots were found in the reference image ({}); check the polarity (dark or "
                                 "light dots), the threshold and the area limits",
                                 rejection_summary(st)));
  const std::size_t need = opt_.interp == Interp::mls ? 6 : 3;
  if (dots.size() < need)
    throw InputError(fmt::format("only {} dot(s) were found in the reference image ({}); {} needs at least {}",
                                 dots.size(), rejection_summary(st), to_string(opt_.interp), need));
  size_ = image.size();
  depth_ = image.depth();
  ref_dots_ = std::move(dots);
  ref_pos_.clear();
  for (const auto& d : ref_dots_) ref_pos_.push_back({d.x, d.y});
  points_ = opt_.points.empty() ? grid_points_over(ref_pos_, opt_.points_x, opt_.points_y, opt_.points_inset)
                                : opt_.points;
  if (opt_.interp == Interp::mls) mls_ = build_mls_table(ref_pos_, points_, opt_.mls);
  else fe_ = build_fe_table(ref_pos_, points_, opt_.fe_max_gap, opt_.mls);
  // The matching radius depends on the reference alone: fix it once, not per frame.
  match_radius_ = opt_.match.search_radius > 0 ? opt_.match.search_radius : 0.4 * median_spacing(ref_pos_);
  last_disp_.assign(ref_pos_.size(), {});
  last_tracked_.assign(ref_pos_.size(), 0);
}

void PipelineState::track(const std::vector<Vec2>& found, FrameOutput& out) {
  std::vector<Vec2> predicted;
  if (opt_.follow) {
    predicted = ref_pos_;
    for (std::size_t j = 0; j < ref_pos_.size(); ++j)
      if (last_tracked_[j]) predicted[j] = {ref_pos_[j].x + last_disp_[j].x, ref_pos_[j].y + last_disp_[j].y};
  }
  MatchOptions mo = opt_.match;
  mo.search_radius = match_radius_;
  const auto t0 = std::chrono::steady_clock::now();
  out.matches = matcher_.match(ref_pos_, found, mo, predicted);
  out.seconds["matching"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (out.matches.matched < static_cast<int>(std::min<std::size_t>(ref_pos_.size(), 3)))
    throw InputError(fmt::format("the frame's dots cannot be matched to the reference: {}. The motion may exceed "
                                 "the search radius; pass a larger search radius or frames closer in time",
                                 out.matches.summary()));
  out.displacement.assign(ref_pos_.size(), {});
  out.tracked.assign(ref_pos_.size(), 0);
  for (std::size_t j = 0; j < ref_pos_.size(); ++j) {
    const int k = out.matches.ref_to_def[j];
    if (k < 0) continue;
    out.displacement[j] = {found[k].x - ref_pos_[j].x, found[k].y - ref_pos_[j].y};
    out.tracked[j] = 1;
  }
  last_disp_ = out.displacement;
  last_tracked_ = out.tracked;
}

namespace {

class CpuBackend final : public Backend {
 public:
  CpuBackend(const PipelineOptions& o, bool parallel)
      : Backend(o), parallel_(parallel), threads_(parallel ? cpu_threads(o) : 1) {}
  std::string name() const override { return parallel_ ? "cpu-par" : "cpu-seq"; }

  void set_reference(const cv::Mat& image) override {
    AnalysisResult r = analyze(image, options().analysis, threads_);
    state().accept_reference(image, std::move(r.dots), r.stats);
  }

  FrameOutput process(const cv::Mat& frame) override {
    PipelineState& st = state();
    st.check_frame(frame);
    const PipelineOptions& opt = st.options();
    FrameOutput out;
    double t0 = now();
    AnalysisResult r = analyze(frame, opt.analysis, threads_, &buffers_);
    double t1 = now();
    out.seconds["analysis"] = t1 - t0;
    out.seconds["analysis_setup"] = r.times.setup;
    out.seconds["analysis_threshold"] = r.times.threshold;
    out.seconds["analysis_labelling"] = r.times.labelling;
    out.seconds["analysis_windows"] = r.times.windows;
    out.dots = std::move(r.dots);
    out.stats = r.stats;
    std::vector<Vec2> found;
    found.reserve(out.dots.size());
    for (const auto& d : out.dots) found.push_back({d.x, d.y});
    st.track(found, out);
    double t2 = now();
    out.seconds["tracking"] = t2 - t1;
    out.fields = opt.interp == Interp::mls
                     ? evaluate_mls(st.mls_table(), st.reference_positions(), out.displacement, out.tracked, opt.mls,
                                    threads_)
                     : evaluate_fe(st.fe_table(), out.displacement, out.tracked, threads_);
    out.seconds["fields"] = now() - t2;
    out.seconds["total"] = now() - t0;
    out.shape = st.frame_shape(frame, r.stats, {out.matches.tree_steps, out.matches.match_steps});
    out.counts = cpu_counts(out.shape, threads_);
    return out;
  }

 private:
  bool parallel_;
  int threads_ = 1;
  AnalysisBuffers buffers_;  // the frames' mask and labels, reused (analysis.hpp)
};

std::unique_ptr<Backend> make_cpu_seq(const PipelineOptions& o) { return std::make_unique<CpuBackend>(o, false); }
std::unique_ptr<Backend> make_cpu_par(const PipelineOptions& o) { return std::make_unique<CpuBackend>(o, true); }
CostCounts cpu_seq_counts(const FrameShape& s, const PipelineOptions&) { return cpu_counts(s, 1); }
CostCounts cpu_par_counts(const FrameShape& s, const PipelineOptions& o) { return cpu_counts(s, cpu_threads(o)); }
std::string cpu_available() { return {}; }

std::unique_ptr<Backend> make_cuda(const PipelineOptions& o) {
  const std::string why = cuda_unavailable_reason();
  if (!why.empty()) throw InputError("the cuda backend cannot run here: " + why + "; use cpu-seq or cpu-par");
#ifdef DTFLOP_HAVE_CUDA
  return make_cuda_backend(o);
#else
  (void)o;
  return nullptr;  // not reached: cuda_unavailable_reason() says CUDA is missing
#endif
}
CostCounts cuda_frame_counts(const FrameShape& s, const PipelineOptions& o) {
  return cuda_counts(s, o.pinned_frames ? HostMemory::pinned : HostMemory::pageable);
}

}  // namespace

int cpu_threads(const PipelineOptions& o) {
  return o.threads > 0 ? o.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

const std::vector<BackendKind>& backend_kinds() {
  static const std::vector<BackendKind> kinds = {
      {"cpu-seq", "float64 reference: OpenCV threshold + sequential labelling, centroids, matching and fields on one "
                  "thread", false, make_cpu_seq, cpu_seq_counts, cpu_available},
      {"cpu-par", "float64: OpenCV's parallel labelling, centroids and fields on --threads threads", false,
       make_cpu_par, cpu_par_counts, cpu_available},
      {"cuda", "float32 on the device: frame upload, threshold, labelling, centroids, displacements and MLS/FE; "
               "matching on the host", true, make_cuda, cuda_frame_counts, cuda_unavailable_reason},
  };
  return kinds;
}

const BackendKind& backend_kind(const std::string& name) {
  for (const auto& k : backend_kinds())
    if (k.name == name) return k;
  std::string known;
  for (const auto& k : backend_kinds()) known += (known.empty() ? "" : ", ") + k.name;
  throw InputError(fmt::format("DCT backend '{}' is unknown; use one of {}", name, known));
}

std::vector<std::string> backend_names() {
  std::vector<std::string> out;
  for (const auto& k : backend_kinds()) out.push_back(k.name);
  return out;
}

std::string cuda_unavailable_reason() { return cuda::unavailable_reason(); }

std::unique_ptr<Backend> make_backend(const std::string& name, const PipelineOptions& o) {
  return backend_kind(name).make(o);
}

}  // namespace dtflop::dct
