// Image analysis against the renderer's truth: centroid accuracy (the 0.01 px and
// 0.05 px targets), polarity, bit depth, lighting, region of interest and the filters.
#include <cmath>
#include <cstdio>
#include <algorithm>
#include <random>
#include <numeric>
#include <stdexcept>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "kernels/component_records.hpp"
#include "kernels/dot_centroid.hpp"
#include "kernels/histogram.hpp"
#include "model/errors.hpp"
#include "workloads/dct/analysis.hpp"
#include "workloads/dct/specimen.hpp"
#include "workloads/dct/tracking.hpp"

namespace dtflop::dct {
namespace {

struct Errors {
  double rms = 0, max = 0;
  int found = 0, missing = 0;
};

// Each true centre's nearest found dot (within 2 px); missing ones counted.
Errors compare(const std::vector<Vec2>& truth, const std::vector<DotObservation>& found) {
  std::vector<Vec2> f;
  for (const auto& d : found) f.push_back({d.x, d.y});
  Errors e;
  if (f.empty()) { e.missing = static_cast<int>(truth.size()); return e; }
  PointIndex idx(f);
  std::vector<std::uint32_t> k;
  std::vector<double> d2;
  double s = 0;
  for (const auto& t : truth) {
    idx.knn(t, 1, k, d2);
    if (std::sqrt(d2[0]) > 2) { ++e.missing; continue; }
    s += d2[0];
    e.max = std::max(e.max, std::sqrt(d2[0]));
    ++e.found;
  }
  e.rms = e.found ? std::sqrt(s / e.found) : 0;
  return e;
}

Specimen random_specimen(double radius, std::uint64_t seed, const std::string& kind = "uniform") {
  Specimen s = parse_specimen(fmt::format("{}:size=480x360,pattern=random,radius={},gap={},seed={}", kind, radius,
                                          radius, seed));
  return s;
}

TEST(DctCentroids, NoiselessRadius10IsWithinOneHundredthPixel) {
  for (std::uint64_t seed : {11u, 12u}) {
    for (double radius : {10.0, 13.7}) {
      Specimen s = random_specimen(radius, seed);
      const auto r = analyze(s.deformed_image(), AnalysisOptions{});
      const Errors e = compare(s.deformed_centres(), r.dots);
      EXPECT_EQ(e.missing, 0);
      EXPECT_EQ(r.dots.size(), s.dots.size());
      EXPECT_LE(e.rms, 0.01) << "radius " << radius << " seed " << seed;
      std::printf("centroid RMS error, radius %.1f px, seed %d: %.5f px (max %.5f)\n", radius, static_cast<int>(seed), e.rms, e.max);
      RecordProperty("rms_px_r" + std::to_string(static_cast<int>(radius)), std::to_string(e.rms));
    }
  }
}

TEST(DctCentroids, NoiseOfTwoGreyLevelsStaysWithinFiveHundredths) {
  Specimen s = random_specimen(10, 21);
  s.render.noise_sigma = 2;
  const auto r = analyze(s.deformed_image(), AnalysisOptions{});
  const Errors e = compare(s.deformed_centres(), r.dots);
  EXPECT_EQ(e.missing, 0);
  EXPECT_LE(e.rms, 0.05);
  std::printf("centroid RMS error with noise 2: %.5f px\n", e.rms);
  EXPECT_GT(e.rms, 0.0);  // noise does move the centroids: the test can fail
}

TEST(DctCentroids, LightDotsSixteenBitsBlurAndLighting) {
  Specimen s = random_specimen(10, 31);
  s.render.polarity = Polarity::light_dots;
  s.render.bit_depth = 16;
  s.render.blur_sigma = 1.0;
  s.render.lighting = 0.3;
  const cv::Mat img = s.deformed_image();
  ASSERT_EQ(img.depth(), CV_16U);
  AnalysisOptions o;
  o.polarity = Polarity::light_dots;
  o.margin = 4;  // blur spreads the edge: weight a wider band
  const auto r = analyze(img, o);
  const Errors e = compare(s.deformed_centres(), r.dots);
  EXPECT_EQ(e.missing, 0);
  EXPECT_LE(e.rms, 0.02);
  // Wrong polarity finds the background, not the dots.
  const auto wrong = analyze(img, AnalysisOptions{});
  EXPECT_LT(wrong.dots.size(), s.dots.size() / 4);
}

TEST(DctCentroids, ThresholdMethodsAgreeOnCleanImages) {
  Specimen s = random_specimen(8, 41);
  const cv::Mat img = s.deformed_image();
  for (auto m : {ThresholdMethod::fixed, ThresholdMethod::otsu, ThresholdMethod::adaptive}) {
    AnalysisOptions o;
    o.method = m;
    o.threshold = 120;
    o.adaptive_block = 61;
    const auto r = analyze(img, o);
    const Errors e = compare(s.deformed_centres(), r.dots);
    EXPECT_EQ(e.missing, 0) << to_string(m);
    EXPECT_LE(e.rms, 0.02) << to_string(m);
  }
  // Our Otsu (shared with the device) matches OpenCV's on 8-bit images.
  cv::Mat ref;
  const double cv_t = cv::threshold(img, ref, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  double ours = 0;
  AnalysisOptions o;
  threshold_image(img, o, &ours);
  EXPECT_EQ(ours, cv_t);
}

TEST(DctCentroids, SequentialAndParallelAgreeExactly) {
  Specimen s = random_specimen(6, 51);
  s.render.noise_sigma = 3;
  const cv::Mat img = s.deformed_image();
  const auto a = analyze(img, AnalysisOptions{}, 1);
  const auto b = analyze(img, AnalysisOptions{}, 4);
  ASSERT_EQ(a.dots.size(), b.dots.size());
  for (std::size_t i = 0; i < a.dots.size(); ++i) {
    EXPECT_EQ(a.dots[i].x, b.dots[i].x);
    EXPECT_EQ(a.dots[i].y, b.dots[i].y);
  }
  EXPECT_EQ(a.stats.window_pixels, b.stats.window_pixels);
}

TEST(DctFilters, AreaShapeBorderAndRoi) {
  // A Kirsch hole is one huge dark blob: the area filter (the seed's Area1) removes it.
  Specimen s = parse_specimen("kirsch:size=400x400,a=90,radius=5,pitch=18");
  const cv::Mat img = s.reference_image();
  const auto r = analyze(img, AnalysisOptions{});
  EXPECT_EQ(r.dots.size(), s.dots.size());
  EXPECT_EQ(r.stats.rejected_area, 1);
  AnalysisOptions small;
  small.max_area = 50;  // dots are ~79 px
  EXPECT_EQ(analyze(img, small).dots.size(), 0u);
  // Specks (Area2) and a line (shape).
  cv::Mat dirty = img.clone();
  cv::circle(dirty, {8, 200}, 1, cv::Scalar(0), cv::FILLED);
  cv::line(dirty, {5, 390}, {120, 392}, cv::Scalar(0), 3);
  const auto rd = analyze(dirty, AnalysisOptions{});
  EXPECT_EQ(rd.dots.size(), s.dots.size());
  EXPECT_GE(rd.stats.rejected_area + rd.stats.rejected_shape, 3) << rd.stats.rejected_area << " " << rd.stats.rejected_shape << " " << rd.stats.rejected_border << " " << rd.stats.components;
  // A region of interest keeps the dots wholly inside it, in image coordinates.
  AnalysisOptions roi;
  roi.roi = cv::Rect(0, 0, 210, 400);
  const auto rr = analyze(img, roi);
  EXPECT_GT(rr.dots.size(), 0u);
  EXPECT_LT(rr.dots.size(), s.dots.size());
  for (const auto& d : rr.dots) EXPECT_LT(d.x, 210 - 5);
  EXPECT_GT(rr.stats.rejected_border, 0) << rr.stats.components << " " << rr.stats.rejected_area << " " << rr.stats.rejected_shape;
  AnalysisOptions bad;
  bad.roi = cv::Rect(1000, 1000, 10, 10);
  EXPECT_THROW(analyze(img, bad), InputError);
  bad = AnalysisOptions{};
  bad.min_area = 10;
  bad.max_area = 5;
  EXPECT_THROW(analyze(img, bad), InputError);
  EXPECT_THROW(analyze(cv::Mat(10, 10, CV_32F), AnalysisOptions{}), InputError);
}

// Otsu's counts in stripes of rows (cpu-par counts a stripe a thread) against OpenCV's histogram of
// the same region, for 8- and 16-bit frames, a region that is not the whole frame, any stripe count.
TEST(DctThreshold, StripedCountsMatchOpenCvsHistogram) {
  std::mt19937 rng(7);
  for (const int depth : {CV_8U, CV_16U}) {
    cv::Mat frame(203, 157, depth);
    cv::randu(frame, 0, depth == CV_8U ? 256 : 65536);
    const cv::Mat view = frame(cv::Rect(5, 9, 131, 187));  // rows not contiguous
    cv::Mat eight;
    view.convertTo(eight, CV_8U, depth == CV_8U ? 1.0 : 1.0 / 257);
    // convertTo rounds; the count truncates v / 257: build the reference by truncation.
    if (depth == CV_16U)
      for (int y = 0; y < view.rows; ++y)
        for (int x = 0; x < view.cols; ++x) eight.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(view.at<std::uint16_t>(y, x) / 257);
    cv::Mat ref;
    const int channels[] = {0}, bins[] = {256};
    const float range[] = {0, 256};
    const float* ranges[] = {range};
    cv::calcHist(&eight, 1, channels, cv::Mat(), ref, 1, bins, ranges);
    for (const int stripes : {1, 2, 5, 187, 400}) {
      const auto serial = [](int n, const auto& body) {
        for (int k = n - 1; k >= 0; --k) body(k);  // any order
      };
      const auto counts = depth == CV_8U ? kernels::count_rows(view.ptr<std::uint8_t>(0), view.step1(), view.cols,
                                                               view.rows, stripes, serial)
                                         : kernels::count_rows(view.ptr<std::uint16_t>(0), view.step1(), view.cols,
                                                               view.rows, stripes, serial);
      for (int v = 0; v < 256; ++v)
        ASSERT_EQ(counts[static_cast<std::size_t>(v)], static_cast<std::int64_t>(ref.at<float>(v)))
            << "depth " << depth << ", " << stripes << " stripes, grey level " << v;
    }
  }
  // A 16-bit frame goes straight into the 8-bit mask, stripe by stripe: OpenCV's binary threshold of
  // the 16-bit frame, converted, for both polarities, fixed and Otsu, on one thread and three.
  {
    cv::Mat frame(121, 97, CV_16U);
    cv::randu(frame, 0, 65536);
    const cv::Mat view = frame(cv::Rect(3, 4, 90, 113));
    for (const auto polarity : {Polarity::dark_dots, Polarity::light_dots})
      for (const auto method : {ThresholdMethod::fixed, ThresholdMethod::otsu})
        for (const int threads : {1, 3}) {
          AnalysisOptions o;
          o.polarity = polarity;
          o.method = method;
          o.threshold = 100.4;
          AnalysisBuffers b;
          double used = -1;
          threshold_into(view, o, b, &used, threads);
          cv::Mat wide, ref;
          cv::threshold(view, wide, used, 255,
                        polarity == Polarity::dark_dots ? cv::THRESH_BINARY_INV : cv::THRESH_BINARY);
          wide.convertTo(ref, CV_8U);
          ASSERT_EQ(b.mask.type(), CV_8U);
          EXPECT_EQ(cv::countNonZero(b.mask != ref), 0)
              << to_string(method) << ", " << threads << " threads, threshold " << used;
          EXPECT_GT(cv::countNonZero(b.mask), 0);
        }
  }
  // The threshold on several threads is the one on one thread, and OpenCV's Otsu.
  Specimen s = random_specimen(6, 52);
  s.render.noise_sigma = 3;
  const cv::Mat img = s.deformed_image();
  cv::Mat mask;
  const double cv_t = cv::threshold(img, mask, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  for (const int threads : {1, 2, 3}) {
    AnalysisBuffers b;
    double t = -1;
    threshold_into(img, AnalysisOptions{}, b, &t, threads);
    EXPECT_EQ(t, cv_t) << threads << " threads";
  }
}

// The window routine reads labels unchecked where the window's neighbourhoods stay inside the
// region and checked at its edge: both give the same centroid for a window inside, and every
// margin the workload allows finds a noiseless dot's centre.
TEST(DctCentroids, EveryMarginAndBothLabelReadsAgree) {
  for (const int margin : {0, 1, 2, 3, 5, 8}) {
    Specimen s = parse_specimen("uniform:size=300x240,pattern=grid,pitch=60,radius=9,strain=0");
    const cv::Mat img = s.reference_image();
    AnalysisOptions o;
    o.margin = margin;
    const auto r = analyze(img, o);
    const Errors e = compare(s.reference_centres(), r.dots);
    EXPECT_EQ(e.missing, 0) << "margin " << margin;
    EXPECT_LE(e.max, 0.02) << "margin " << margin;

    AnalysisBuffers b;
    threshold_into(img, o, b);
    const int n = cv::connectedComponentsWithStats(b.mask, b.labels, b.stats, b.centroids, 8, CV_32S);
    ASSERT_GT(n, 1);
    const int* labels = b.labels.ptr<int>(0);
    const std::size_t stride = b.labels.step1();
    const auto at = [labels, stride](int x, int y) {
      const int l = labels[static_cast<std::size_t>(y) * stride + static_cast<std::size_t>(x)];
      return l == 0 ? -1 : l;
    };
    const auto checked = [&](int x, int y) { return x < 0 || y < 0 || x >= img.cols || y >= img.rows ? -1 : at(x, y); };
    for (int id = 1; id < n; ++id) {
      const int grow = margin + kernels::kRingWidth;
      const int x0 = b.stats.at<int>(id, cv::CC_STAT_LEFT) - grow, y0 = b.stats.at<int>(id, cv::CC_STAT_TOP) - grow;
      const int x1 = x0 + b.stats.at<int>(id, cv::CC_STAT_WIDTH) + 2 * grow;
      const int y1 = y0 + b.stats.at<int>(id, cv::CC_STAT_HEIGHT) + 2 * grow;
      ASSERT_TRUE(x0 - margin >= 0 && y0 - margin >= 0 && x1 + margin <= img.cols && y1 + margin <= img.rows);
      const auto fast = kernels::centroid_window(img.ptr<std::uint8_t>(0), img.step1(), labels, stride, img.cols,
                                                 img.rows, id, b.stats.at<int>(id, cv::CC_STAT_LEFT),
                                                 b.stats.at<int>(id, cv::CC_STAT_TOP),
                                                 b.stats.at<int>(id, cv::CC_STAT_WIDTH),
                                                 b.stats.at<int>(id, cv::CC_STAT_HEIGHT), margin, true);
      const auto slow = kernels::detail::centroid_window_in<-1, true>(checked, img.ptr<std::uint8_t>(0), img.step1(),
                                                                      img.cols, id, x0, y0, x1, y1, margin);
      ASSERT_TRUE(fast.kept);
      EXPECT_EQ(fast.x, slow.x) << "margin " << margin << ", dot " << id;
      EXPECT_EQ(fast.y, slow.y) << "margin " << margin << ", dot " << id;
      EXPECT_EQ(fast.scanned, slow.scanned);
      EXPECT_EQ(fast.ring, slow.ring);
      EXPECT_EQ(fast.weighted, slow.weighted);
    }
  }
}

// The cuda backend's order of a frame's dots (kernels/component_records.hpp): sort_by_key gives what
// a stable comparison sort gives, for keys of one to four bytes, repeated keys and a subset of the
// records; a key beyond its passes' range is refused.
TEST(DctRecords, SortByKeyIsAStableSortOfTheKeys) {
  std::mt19937 rng(5);
  for (int largest : {0, 1, 200, 70'000, 24'000'000, 2'147'483'647}) {
    std::uniform_int_distribution<int> u(0, largest);
    std::vector<int> key(3000);
    for (int& k : key) k = u(rng);
    for (int i = 0; i + 10 < 3000; i += 10) key[i + 5] = key[i];  // equal keys keep their order
    std::vector<int> items, scratch;
    for (int i = 0; i < 3000; ++i)
      if (rng() % 4 != 0) items.push_back(i);  // the kept records only
    std::vector<int> want = items;
    std::stable_sort(want.begin(), want.end(), [&](int a, int b) { return key[a] < key[b]; });
    kernels::sort_by_key(items, key.data(), kernels::radix_passes(std::int64_t{largest} + 1), scratch);
    EXPECT_EQ(items, want) << "largest key " << largest;
  }
  std::vector<int> none, scratch;
  kernels::sort_by_key(none, nullptr, 2, scratch);
  EXPECT_TRUE(none.empty());
  std::vector<int> key = {3, -1}, items = {0, 1};
  EXPECT_THROW(kernels::sort_by_key(items, key.data(), 1, scratch), std::logic_error);
  key = {3, 256};
  EXPECT_THROW(kernels::sort_by_key(items, key.data(), 1, scratch), std::logic_error);  // 256 needs 2 bytes
  EXPECT_NO_THROW(kernels::sort_by_key(items, key.data(), 2, scratch));
  EXPECT_EQ(items, (std::vector<int>{0, 1}));
}

TEST(DctRecords, RadixPassesAreTheKeysBytes) {
  EXPECT_EQ(kernels::radix_passes(0), 0);
  EXPECT_EQ(kernels::radix_passes(1), 0);
  EXPECT_EQ(kernels::radix_passes(2), 1);
  EXPECT_EQ(kernels::radix_passes(256), 1);
  EXPECT_EQ(kernels::radix_passes(257), 2);
  EXPECT_EQ(kernels::radix_passes(640 * 480), 3);
  EXPECT_EQ(kernels::radix_passes(std::int64_t{1} << 24), 3);
  EXPECT_EQ(kernels::radix_passes((std::int64_t{1} << 24) + 1), 4);
  EXPECT_EQ(kernels::record_steps(1000, 640 * 480), 5000);
}

// order_records against the rule written out: every record tallied by its status and pixels, the
// kept ones (status 0) handed on in the order of their roots, and the steps it declares.
TEST(DctRecords, OrderRecordsTalliesEveryRecordAndHandsOnTheKeptInRootOrder) {
  std::mt19937 rng(11);
  for (std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{37}, std::size_t{2500}}) {
    const std::int64_t limit = 1'000'000;  // a 1000 x 1000 region: 3 passes
    std::vector<int> status(n), area(n), root(n), pixels(3 * n);
    std::uniform_int_distribution<int> st(0, 9), a(1, 400), px(0, 300);
    std::vector<int> roots(limit);
    std::iota(roots.begin(), roots.end(), 0);
    std::shuffle(roots.begin(), roots.end(), rng);
    for (std::size_t k = 0; k < n; ++k) {
      const int s = st(rng);
      status[k] = s < 5 ? 0 : s - 4;  // half kept, the rest one of the four rejections (5: contrast too)
      area[k] = a(rng);
      root[k] = roots[k];  // distinct, as a labelling's roots are
      for (int j = 0; j < 3; ++j) pixels[3 * k + j] = px(rng);
    }
    kernels::RecordTally want;
    std::vector<int> kept;
    for (std::size_t k = 0; k < n; ++k) {
      want.area += area[k];
      ++want.by_status[std::min(status[k], 4)];
      want.window_pixels += pixels[3 * k];
      want.ring_pixels += pixels[3 * k + 1];
      want.weighted_pixels += pixels[3 * k + 2];
      if (status[k] == 0) kept.push_back(static_cast<int>(k));
    }
    std::sort(kept.begin(), kept.end(), [&](int x, int y) { return root[x] < root[y]; });
    kernels::RecordTally got;
    std::vector<int> order, scratch, emitted;
    const kernels::RecordColumns cols{status.data(), area.data(), root.data(), pixels.data(), n};
    const std::int64_t steps =
        kernels::order_records(cols, limit, got, order, scratch, [&](int k) { emitted.push_back(k); });
    EXPECT_EQ(emitted, kept) << n << " records";
    EXPECT_EQ(steps, static_cast<std::int64_t>(n) * 5);
    EXPECT_EQ(got.records, static_cast<std::int64_t>(n));
    EXPECT_EQ(got.area, want.area);
    for (int s = 0; s < 5; ++s) EXPECT_EQ(got.by_status[s], want.by_status[s]) << "status " << s;
    EXPECT_EQ(got.window_pixels, want.window_pixels);
    EXPECT_EQ(got.ring_pixels, want.ring_pixels);
    EXPECT_EQ(got.weighted_pixels, want.weighted_pixels);
  }
}

}  // namespace
}  // namespace dtflop::dct

// The fields' parallel loops run with OpenCV's thread count at the backend's (cpu-par --threads
// k), set only where it differs, and the count the process had is back after.
TEST(DctThreads, WorkRunsWithTheGivenOpenCvThreadCountAndTheCountIsRestored) {
  const int before = cv::getNumThreads();
  int inside = -1;
  dtflop::dct::with_opencv_threads(1, [&] { inside = cv::getNumThreads(); });
  EXPECT_EQ(inside, 1);
  EXPECT_EQ(cv::getNumThreads(), before);
  dtflop::dct::with_opencv_threads(before, [&] { inside = cv::getNumThreads(); });
  EXPECT_EQ(inside, before);
  EXPECT_EQ(cv::getNumThreads(), before);
  // A count below one runs on one thread, as the analysis does.
  dtflop::dct::with_opencv_threads(0, [&] { inside = cv::getNumThreads(); });
  EXPECT_EQ(inside, 1);
  EXPECT_EQ(cv::getNumThreads(), before);
}
