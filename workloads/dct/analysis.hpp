// Image analysis of the DCT workload (seed 6.1.2, 7.1): threshold, connected-component
// labelling, filtering by area and shape, and the background-removed intensity-weighted
// centroid of eq. 7.1 of every kept dot. The CPU implementation here uses OpenCV for the
// threshold and the labelling; the CUDA backend has its own (cuda_backend.cpp, cuda_kernels.cu)
// with the same rules and the same per-dot arithmetic (kernels.hpp).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "workloads/dct/specimen.hpp"

namespace dtflop::dct {

enum class ThresholdMethod { fixed, otsu, adaptive };

struct AnalysisOptions {
  Polarity polarity = Polarity::dark_dots;
  ThresholdMethod method = ThresholdMethod::otsu;
  double threshold = 128;      // fixed threshold, 8-bit scale (x257 for 16-bit images)
  int adaptive_block = 51;     // adaptive: odd neighbourhood size, px
  double adaptive_c = 10;      // adaptive: offset from the local mean, 8-bit scale
  int min_area = 12;           // px; smaller components are noise (the seed's Area2)
  int max_area = 20000;        // px; larger ones are not dots (the seed's Area1)
  double max_aspect = 1.8;     // bounding box long side / short side
  double min_fill = 0.55;      // area / bounding-box area (a disc fills pi/4)
  int margin = 2;              // px of background around a dot that carry its edge's weight
  bool reject_border = true;   // drop dots whose window leaves the region of interest
  cv::Rect roi;                // region of interest; empty = the whole image
};

// Throws InputError with what to change.
void validate(const AnalysisOptions& o, cv::Size image);

// The region actually analysed: `roi` clipped, or the whole image.
cv::Rect effective_roi(const AnalysisOptions& o, cv::Size image);

enum class DotRejection : std::uint8_t { kept = 0, area, shape, border, no_contrast };

struct DotObservation {
  DotObservation() {}  // not an aggregate: see Vec2
  double x = 0, y = 0;   // centroid, image pixels
  double weight = 0;     // sum of the background-removed intensities
  int area = 0;          // labelled pixels
  cv::Rect box;          // labelled bounding box, image pixels
};

// What the analysis did, for the counts and for people.
struct AnalysisStats {
  std::int64_t roi_pixels = 0;
  std::int64_t components = 0;      // after labelling, before filtering
  std::int64_t foreground_pixels = 0;  // labelled pixels of all components (the mask's dot pixels)
  std::int64_t rejected_area = 0, rejected_shape = 0, rejected_border = 0, rejected_contrast = 0;
  std::int64_t window_pixels = 0;   // pixels of all kept dots' windows
  std::int64_t ring_pixels = 0;     // of which background-ring pixels
  std::int64_t weighted_pixels = 0; // of which weighted pixels
  std::int64_t scanned_pixels = 0;  // of which background pixels whose (2 margin + 1)^2 labels were read
  double threshold = 0;             // threshold used, native grey levels
};

// Where one analysis' time went, host clock, seconds: what the cpu-pixel probe's kinds of step
// price (docs/model.md 2.6), reported with a run so a store's frames can be read against them.
struct AnalysisTimes {
  double setup = 0;      // the lock on OpenCV's thread count and setting it
  double threshold = 0;  // the threshold (with Otsu, the histogram and its threshold) into the mask
  double labelling = 0;  // the 8-connected labelling with statistics
  double windows = 0;    // every component's filters and centroid window
};

struct AnalysisResult {
  std::vector<DotObservation> dots;  // in raster order of each dot's first pixel
  AnalysisStats stats;
  AnalysisTimes times;
};

// The frame-sized images of one analysis (the mask, a 16-bit frame's 8-bit copy for the adaptive
// threshold, and the labels). A pipeline keeps one across frames, as a camera's would: frames of one size then
// reuse them instead of allocating ~5-7 bytes per pixel each frame. (Allocations above glibc's
// 32 MiB mmap limit, the labels of a frame over 8 MP, come fresh from the kernel every time:
// on the 2-vCPU VM their page faults added ~2 ns a pixel to frames over 8 MP and nothing
// below; docs/PERFORMANCE.md, DCT calibration.)
struct AnalysisBuffers {
  cv::Mat wide;    // 16-bit frames with the adaptive threshold: the 8-bit copy
  cv::Mat mask;    // 8-bit mask, 255 = dot pixel
  cv::Mat labels;  // 32-bit component labels
  cv::Mat stats, centroids;
};

// `threads` = 1: sequential (OpenCV's sequential labelling, one thread); > 1: OpenCV's
// parallel labelling and centroids on `threads` threads. `buffers`: the images to reuse (null:
// allocated for this call).
AnalysisResult analyze(const cv::Mat& image, const AnalysisOptions& o, int threads = 1,
                       AnalysisBuffers* buffers = nullptr);

// The binary mask (255 = dot pixel) and the threshold used, for inspection and tests.
// Runs `work` with OpenCV's thread count (process-wide) at `threads`, under the lock the analysis
// holds for it, and restores the count after; the count is set only where it differs (setting it
// rebuilds OpenCV's thread pool). The fields' parallel loops run in it, so that cpu-par with
// --threads k below the CPUs there are runs them on the k threads its counts price.
void with_opencv_threads(int threads, const std::function<void()>& work);

cv::Mat threshold_image(const cv::Mat& image, const AnalysisOptions& o, double* used = nullptr);
// The same into `b.mask` (b.wide holds a 16-bit frame's 8-bit copy for the adaptive threshold);
// Otsu's histogram, and a 16-bit frame's comparison, in a stripe of rows a thread on `threads`
// threads (OpenCV's, set by the caller).
void threshold_into(const cv::Mat& image, const AnalysisOptions& o, AnalysisBuffers& b, double* used = nullptr,
                    int threads = 1);

// Otsu's threshold of an 8- or 16-bit image, from a 256-bin histogram of the 8-bit scale
// (16-bit values are divided by 257 first), in native grey levels. Shared with the device.
double otsu_threshold(const std::array<std::int64_t, 256>& hist);

std::string to_string(ThresholdMethod m);
ThresholdMethod threshold_method_from_string(const std::string& s);

}  // namespace dtflop::dct
