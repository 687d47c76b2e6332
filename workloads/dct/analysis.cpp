#include "workloads/dct/analysis.hpp"

#include <algorithm>
#include <array>
#include <stdexcept>
#include <chrono>
#include <mutex>

#include <fmt/format.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "kernels/histogram.hpp"
#include "model/errors.hpp"
#include "workloads/dct/kernels.hpp"

namespace dtflop::dct {

std::string to_string(ThresholdMethod m) {
  switch (m) {
    case ThresholdMethod::fixed: return "fixed";
    case ThresholdMethod::otsu: return "otsu";
    case ThresholdMethod::adaptive: return "adaptive";
  }
  return "?";
}

ThresholdMethod threshold_method_from_string(const std::string& s) {
  if (s == "fixed") return ThresholdMethod::fixed;
  if (s == "otsu") return ThresholdMethod::otsu;
  if (s == "adaptive") return ThresholdMethod::adaptive;
  throw InputError(fmt::format("threshold method '{}' is unknown; use fixed, otsu or adaptive", s));
}

cv::Rect effective_roi(const AnalysisOptions& o, cv::Size image) {
  if (o.roi.area() == 0) return {0, 0, image.width, image.height};
  return o.roi & cv::Rect(0, 0, image.width, image.height);
}

void validate(const AnalysisOptions& o, cv::Size image) {
  if (image.width < 1 || image.height < 1) throw InputError("the image is empty");
  if (o.roi.area() > 0) {
    const cv::Rect r = effective_roi(o, image);
    if (r.area() == 0)
      throw InputError(fmt::format("region of interest {}x{}+{}+{} lies outside the {}x{} image", o.roi.width,
                                   o.roi.height, o.roi.x, o.roi.y, image.width, image.height));
  }
  if (o.min_area < 1 || o.max_area < o.min_area)
    throw InputError(fmt::format("dot area filter [{}, {}] px is empty; need 1 <= min <= max", o.min_area,
                                 o.max_area));
  if (!(o.max_aspect >= 1) || !(o.min_fill >= 0 && o.min_fill <= 1))
    throw InputError("shape filter needs max aspect >= 1 and min fill within [0, 1]");
  if (o.margin < 0 || o.margin > 8) throw InputError(fmt::format("centroid margin {} px must lie in 0..8", o.margin));
  if (o.method == ThresholdMethod::fixed && !(o.threshold >= 0 && o.threshold <= 255))
    throw InputError(fmt::format("fixed threshold {} is outside 0..255 (8-bit scale)", o.threshold));
  if (o.method == ThresholdMethod::adaptive && (o.adaptive_block < 3 || o.adaptive_block % 2 == 0))
    throw InputError(fmt::format("adaptive block {} must be odd and >= 3", o.adaptive_block));
}

double otsu_threshold(const std::array<std::int64_t, 256>& h) {
  // Between-class variance maximised over t; class 0 = bins <= t. First maximum wins.
  double total = 0, sum = 0;
  for (int i = 0; i < 256; ++i) {
    total += static_cast<double>(h[i]);
    sum += i * static_cast<double>(h[i]);
  }
  double w0 = 0, s0 = 0, best = -1;
  int t = 0;
  for (int i = 0; i < 256; ++i) {
    w0 += static_cast<double>(h[i]);
    s0 += i * static_cast<double>(h[i]);
    const double w1 = total - w0;
    if (w0 == 0 || w1 == 0) continue;
    const double m0 = s0 / w0, m1 = (sum - s0) / w1;
    const double v = w0 * w1 * (m0 - m1) * (m0 - m1);
    if (v > best) {
      best = v;
      t = i;
    }
  }
  return t;
}

cv::Mat threshold_image(const cv::Mat& image, const AnalysisOptions& o, double* used) {
  AnalysisBuffers b;
  threshold_into(image, o, b, used);
  return b.mask;
}

void threshold_into(const cv::Mat& image, const AnalysisOptions& o, AnalysisBuffers& buf, double* used,
                    int threads) {
  const bool dark = o.polarity == Polarity::dark_dots;
  const bool wide = image.depth() == CV_16U;
  cv::Mat& mask = buf.mask;
  double T = 0;  // native: dark dots are v <= T, light dots v > T
  if (o.method == ThresholdMethod::adaptive) {
    cv::Mat img8;
    if (wide) {
      image.convertTo(buf.wide, CV_8U, 1.0 / 257);
      img8 = buf.wide;
    } else {
      img8 = image;
    }
    cv::adaptiveThreshold(img8, mask, 255, cv::ADAPTIVE_THRESH_MEAN_C, dark ? cv::THRESH_BINARY_INV : cv::THRESH_BINARY,
                          o.adaptive_block, dark ? o.adaptive_c : -o.adaptive_c);
    if (used) *used = -1;
    return;
  }
  // Work in a stripe of rows a thread (one stripe on one thread).
  const int n = std::max(1, threads);
  const auto stripes = [threads](int count, const auto& body) {
    if (threads <= 1 || count <= 1) {
      for (int s = 0; s < count; ++s) body(s);
      return;
    }
    cv::parallel_for_(
        cv::Range(0, count), [&](const cv::Range& r) { for (int s = r.start; s < r.end; ++s) body(s); }, count);
  };
  if (o.method == ThresholdMethod::otsu) {
    // The counts in each stripe, the stripes' added.
    const auto counts = wide ? kernels::count_rows(image.ptr<std::uint16_t>(0), image.step1(), image.cols, image.rows,
                                                   n, stripes)
                             : kernels::count_rows(image.ptr<std::uint8_t>(0), image.step1(), image.cols, image.rows,
                                                   n, stripes);
    const double t = otsu_threshold(counts);
    T = wide ? t * 257 + 256 : t;
  } else {
    T = wide ? std::floor(o.threshold * 257) : std::floor(o.threshold);
  }
  if (wide) {
    // Straight into the 8-bit mask, a stripe of rows a thread, as cv::threshold's binary modes
    // decide (a dot pixel: dark v <= T, light v > T): no 16-bit mask to write, read and convert
    // on one thread.
    mask.create(image.size(), CV_8U);
    if (T < 0 || T >= 65535) {  // every pixel above T, or none
      mask.setTo((T < 0) != dark ? 255 : 0);
    } else {  // OpenCV's vectorised comparison, 255 where it holds; T is whole
      const auto compare_rows = [&](const cv::Range& r) {
        cv::compare(image.rowRange(r.start, r.end), cv::Scalar(static_cast<std::uint16_t>(T)),
                    mask.rowRange(r.start, r.end), dark ? cv::CMP_LE : cv::CMP_GT);
      };
      if (n > 1) cv::parallel_for_(cv::Range(0, image.rows), compare_rows, n);
      else compare_rows(cv::Range(0, image.rows));
    }
  } else {
    cv::threshold(image, mask, T, 255, dark ? cv::THRESH_BINARY_INV : cv::THRESH_BINARY);
  }
  if (used) *used = T;
}

namespace {

// Sets OpenCV's thread count for a frame and restores it on scope exit; where it already is the
// frame's, neither. cv::setNumThreads rebuilds OpenCV's thread pool (a TBB arena in Debian's
// build) even for the count it has: on a lent H200's 16-thread host that was 112 us of a 0.36 MP
// cpu-par frame's 961 us analysis, twice a frame, work the cpu-pixel probe (which sets the count
// once) does not do (docs/PERFORMANCE.md).
class ThreadScope {
 public:
  explicit ThreadScope(int n) : old_(cv::getNumThreads()), n_(n) {
    if (n_ != old_) cv::setNumThreads(n_);
  }
  ~ThreadScope() {
    if (n_ != old_) cv::setNumThreads(old_);
  }
  ThreadScope(const ThreadScope&) = delete;
  ThreadScope& operator=(const ThreadScope&) = delete;

 private:
  int old_, n_;
};

std::mutex opencv_threads_mutex;  // cv::setNumThreads is process-wide

}  // namespace

void with_opencv_threads(int threads, const std::function<void()>& work) {
  std::unique_lock lock(opencv_threads_mutex);
  ThreadScope scope(std::max(1, threads));
  work();
}

namespace {

template <class Img>
void centroid_of(const cv::Mat& img, const cv::Mat& labels, cv::Rect roi, int id, cv::Rect box, bool dark,
                 int margin, DotObservation& out, DotRejection& why, AnalysisStats& st, std::int64_t& first) {
  const kernels::WindowCentroid c =
      kernels::centroid_window(img.ptr<Img>(roi.y) + roi.x, img.step1(), labels.ptr<int>(0), labels.step1(),
                               roi.width, roi.height, id, box.x, box.y, box.width, box.height, margin, dark);
  st.window_pixels += c.window;
  st.ring_pixels += c.ring;
  st.weighted_pixels += c.weighted;
  st.scanned_pixels += c.scanned;
  first = c.first;
  if (!c.kept) {
    why = DotRejection::no_contrast;
    return;
  }
  out.x = roi.x + c.x;
  out.y = roi.y + c.y;
  out.weight = c.weight;
  why = DotRejection::kept;
}

}  // namespace

AnalysisResult analyze(const cv::Mat& image, const AnalysisOptions& o, int threads, AnalysisBuffers* buffers) {
  if (image.empty() || image.channels() != 1 || (image.depth() != CV_8U && image.depth() != CV_16U))
    throw InputError("the image must be one-channel 8- or 16-bit grey (convert colour images first)");
  validate(o, image.size());
  const cv::Rect roi = effective_roi(o, image.size());
  const cv::Mat view = image(roi);
  AnalysisResult r;
  r.stats.roi_pixels = roi.area();
  const bool dark = o.polarity == Polarity::dark_dots;

  using Clock = std::chrono::steady_clock;
  const auto seconds = [](Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double>(b - a).count();
  };
  const auto t0 = Clock::now();
  std::unique_lock lock(opencv_threads_mutex);
  ThreadScope scope(std::max(1, threads));
  AnalysisBuffers local;
  AnalysisBuffers& buf = buffers ? *buffers : local;
  const auto t1 = Clock::now();
  threshold_into(view, o, buf, &r.stats.threshold, threads);
  const auto t2 = Clock::now();
  const cv::Mat& mask = buf.mask;
  const cv::Mat& labels = buf.labels;
  const cv::Mat& stats = buf.stats;
  const int n =
      cv::connectedComponentsWithStats(mask, buf.labels, buf.stats, buf.centroids, 8, CV_32S, cv::CCL_DEFAULT);
  const auto t3 = Clock::now();
  r.stats.components = n - 1;
  for (int id = 1; id < n; ++id) r.stats.foreground_pixels += stats.at<int>(id, cv::CC_STAT_AREA);

  struct Item {
    DotObservation d;
    DotRejection why = DotRejection::kept;
    std::int64_t first = -1;
    AnalysisStats st;
  };
  std::vector<Item> items(static_cast<std::size_t>(std::max(0, n - 1)));
  const int grow = o.margin + kRingWidth;
  auto work = [&](const cv::Range& range) {
    for (int id = range.start; id < range.end; ++id) {
      Item& it = items[static_cast<std::size_t>(id - 1)];
      const int area = stats.at<int>(id, cv::CC_STAT_AREA);
      const cv::Rect box(stats.at<int>(id, cv::CC_STAT_LEFT), stats.at<int>(id, cv::CC_STAT_TOP),
                         stats.at<int>(id, cv::CC_STAT_WIDTH), stats.at<int>(id, cv::CC_STAT_HEIGHT));
      it.d.area = area;
      it.d.box = box + roi.tl();
      if (area < o.min_area || area > o.max_area) { it.why = DotRejection::area; continue; }
      const double lo = std::min(box.width, box.height), hi = std::max(box.width, box.height);
      if (hi > o.max_aspect * lo || area < o.min_fill * box.area()) { it.why = DotRejection::shape; continue; }
      if (o.reject_border && (box.x - grow < 0 || box.y - grow < 0 || box.x + box.width + grow > roi.width ||
                              box.y + box.height + grow > roi.height)) {
        it.why = DotRejection::border;
        continue;
      }
      if (image.depth() == CV_8U)
        centroid_of<std::uint8_t>(image, labels, roi, id, box, dark, o.margin, it.d, it.why, it.st, it.first);
      else
        centroid_of<std::uint16_t>(image, labels, roi, id, box, dark, o.margin, it.d, it.why, it.st, it.first);
    }
  };
  if (threads > 1) cv::parallel_for_(cv::Range(1, n), work);
  else work(cv::Range(1, n));
  const auto t4 = Clock::now();
  r.times = {seconds(t0, t1), seconds(t1, t2), seconds(t2, t3), seconds(t3, t4)};

  std::vector<const Item*> kept;
  for (const auto& it : items) {
    switch (it.why) {
      case DotRejection::kept: kept.push_back(&it); break;
      case DotRejection::area: ++r.stats.rejected_area; break;
      case DotRejection::shape: ++r.stats.rejected_shape; break;
      case DotRejection::border: ++r.stats.rejected_border; break;
      case DotRejection::no_contrast: ++r.stats.rejected_contrast; break;
    }
    r.stats.window_pixels += it.st.window_pixels;
    r.stats.ring_pixels += it.st.ring_pixels;
    r.stats.weighted_pixels += it.st.weighted_pixels;
    r.stats.scanned_pixels += it.st.scanned_pixels;
  }
  std::sort(kept.begin(), kept.end(), [](const Item* a, const Item* b) { return a->first < b->first; });
  r.dots.reserve(kept.size());
  for (const Item* it : kept) r.dots.push_back(it->d);
  return r;
}

}  // namespace dtflop::dct
