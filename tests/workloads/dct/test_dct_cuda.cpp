// The cuda backend against cpu-seq (float64) on fresh random specimens: the same dots, the
// same matches, centroids and fields within float32 rounding; labelling against OpenCV's;
// every statistic written; counts as declared. Skips without a device.
#include <algorithm>
#include <array>
#include <map>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <random>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "model/errors.hpp"
#include "tests/support/gpu.hpp"
#include "workloads/dct/backend.hpp"
#include "workloads/dct/specimen.hpp"
#include "workloads/dct/workload.hpp"
#if DTFLOP_HAVE_CUDA
#include "workloads/dct/analysis.hpp"
#include "workloads/dct/cuda_kernels.hpp"
#endif

namespace dtflop::dct {
namespace {

// A fresh seed per run (so that every run tries new specimens), or DTFLOP_DCT_SEED to rerun
// one: failures name the seed (SCOPED_TRACE in the tests below).
std::uint64_t fresh_seed() {
  if (const char* fixed = std::getenv("DTFLOP_DCT_SEED")) return std::strtoull(fixed, nullptr, 10);
  static std::random_device rd;
  const std::uint64_t s = (static_cast<std::uint64_t>(rd()) << 32) ^ rd();
  return s % 1000000007ULL;
}

std::string seed_note(std::uint64_t seed) {
  return fmt::format("specimen seed {} (rerun it with DTFLOP_DCT_SEED={})", seed, seed);
}

struct Case {
  std::string spec;
  PipelineOptions opt;
};

// Returns the largest strain difference over the points both estimated.
double compare_frames(const std::string& what, const cv::Mat& ref, const cv::Mat& def, const PipelineOptions& opt);
double compare(const Case& c) {
  const Specimen s = parse_specimen(c.spec);
  return compare_frames(c.spec, s.reference_image(), s.deformed_image(), c.opt);
}

double compare_frames(const std::string& what, const cv::Mat& ref, const cv::Mat& def, const PipelineOptions& opt) {
  SCOPED_TRACE(what);
  const Case c{what, opt};
  auto cpu = make_backend("cpu-seq", c.opt);
  auto gpu = make_backend("cuda", c.opt);
  cpu->set_reference(ref);
  gpu->set_reference(ref);
  const double not_compared = std::numeric_limits<double>::infinity();
  EXPECT_EQ(cpu->reference_dots().size(), gpu->reference_dots().size());
  if (cpu->reference_dots().size() != gpu->reference_dots().size()) return not_compared;
  for (std::size_t j = 0; j < cpu->reference_dots().size(); ++j) {
    EXPECT_NEAR(cpu->reference_dots()[j].x, gpu->reference_dots()[j].x, 2e-4);
    EXPECT_NEAR(cpu->reference_dots()[j].y, gpu->reference_dots()[j].y, 2e-4);
    EXPECT_EQ(cpu->reference_dots()[j].area, gpu->reference_dots()[j].area);
  }
  // The frame through the pinned buffer and through pageable memory: same result.
  cv::Mat pinned = gpu->frame_buffer(def.size(), def.type());
  def.copyTo(pinned);
  const FrameOutput a = cpu->process(def);
  const FrameOutput b = gpu->process(pinned);
  EXPECT_EQ(a.dots.size(), b.dots.size());
  if (a.dots.size() != b.dots.size()) return not_compared;
  EXPECT_EQ(a.stats.components, b.stats.components);
  EXPECT_EQ(a.stats.threshold, b.stats.threshold);
  EXPECT_EQ(a.stats.window_pixels, b.stats.window_pixels);
  EXPECT_EQ(a.stats.ring_pixels, b.stats.ring_pixels);
  EXPECT_EQ(a.stats.weighted_pixels, b.stats.weighted_pixels);
  EXPECT_EQ(a.matches.ref_to_def, b.matches.ref_to_def);
  std::vector<cv::Point2f> ref_points, hull;
  for (const auto& d : cpu->reference_positions()) ref_points.emplace_back(static_cast<float>(d.x), static_cast<float>(d.y));
  cv::convexHull(ref_points, hull);
  auto hull_distance = [&hull](Vec2 p) {
    return cv::pointPolygonTest(hull, cv::Point2f(static_cast<float>(p.x), static_cast<float>(p.y)), true);
  };
  double worst_u = 0, worst_e = 0;
  int compared = 0;
  for (std::size_t m = 0; m < a.fields.size(); ++m) {
    const auto& x = a.fields[m];
    const auto& y = b.fields[m];
    EXPECT_EQ(x.support, y.support);
    if (x.status != y.status) {
      // Only a point on a limit may differ: the conditioning limit, or (FE) the edge of the mesh,
      // the reference dots' convex hull: the backends' reference centroids differ by up to 2e-4 px
      // (above), so a point within 1e-3 px of the hull (the grid's first row and column lie on
      // the dots' bounding box) may lie in a triangle for one and in none for the other.
      const bool conditioning = x.status == PointStatus::ill_conditioned || y.status == PointStatus::ill_conditioned;
      const bool hull_edge = (x.status == PointStatus::outside_mesh || y.status == PointStatus::outside_mesh) &&
                             std::abs(hull_distance(cpu->points()[m])) < 1e-3;
      if (conditioning || hull_edge) continue;
      std::string why = fmt::format("point {}: cpu-seq {} ({} in its support), cuda {} ({})", m, to_string(x.status),
                                    x.support, to_string(y.status), y.support);
      if (opt.interp == Interp::fe) {  // FE: the share of the recovery's coefficients whose triangles were tracked
        const FeTable& t = cpu->fe_table();
        double kept = 0;
        for (int e = t.offsets[m]; e < t.offsets[m + 1]; ++e) {
          const int* v = &t.tri_dots[3 * static_cast<std::size_t>(t.support[e])];
          if (a.tracked[v[0]] && a.tracked[v[1]] && a.tracked[v[2]]) kept += t.coef[e];
        }
        why += fmt::format(", coefficients kept {:.9f}", kept);
      }
      ADD_FAILURE() << why << fmt::format(", {:.3e} px from the reference dots' hull", hull_distance(cpu->points()[m]));
      continue;
    }
    if (x.status != PointStatus::ok) continue;
    ++compared;
    for (auto [p, q] : {std::pair{x.ux, y.ux}, std::pair{x.uy, y.uy}}) worst_u = std::max(worst_u, std::abs(p - q));
    for (auto [p, q] : {std::pair{x.exx, y.exx}, std::pair{x.eyy, y.eyy}, std::pair{x.exy, y.exy}})
      worst_e = std::max(worst_e, std::abs(p - q));
  }
  std::printf("%s: %zu dots, %d points compared, max |du| %.2e px, max |de| %.2e\n", c.spec.c_str(), a.dots.size(),
              compared, worst_u, worst_e);
  EXPECT_GT(compared, static_cast<int>(a.fields.size()) / 2);
  EXPECT_LT(worst_u, 5e-4);  // float32 centroid sums and displacements
  // 2 microstrain. MLS in float32 costs ~1e-7 here (kernels.hpp, MlsPoint: the weighted fit
  // is factored, not solved through its normal equations, whose condition numbers reach 1e5
  // on the Gaussian 45 px case below); the rest is the float32 centroids.
  EXPECT_LT(worst_e, 2e-6);
  const FrameOutput c2 = gpu->process(def);
  EXPECT_EQ(c2.counts.host_memory, HostMemory::pageable);
  EXPECT_EQ(b.counts.host_memory, HostMemory::pinned);
  EXPECT_EQ(b.counts, cuda_counts(b.shape, HostMemory::pinned));
  for (std::size_t m = 0; m < b.fields.size(); ++m) {
    EXPECT_EQ(b.fields[m].status, c2.fields[m].status);
    if (b.fields[m].status == PointStatus::ok) {
      EXPECT_EQ(b.fields[m].exx, c2.fields[m].exx);  // deterministic
    }
  }
  return worst_e;
}

TEST(DctCuda, MatchesCpuSeqOnFreshSpecimens) {
  DTFLOP_REQUIRE_GPU();
  const std::uint64_t seed = fresh_seed();
  SCOPED_TRACE(seed_note(seed));
  RecordProperty("seed", std::to_string(seed));
  PipelineOptions o;
  o.mls.support = parse_support("40dots");
  o.points_x = 24;
  o.points_y = 18;
  double mls = 0, fe = 0;
  mls = std::max(mls, compare({fmt::format("uniform:size=900x700,pattern=random,radius=7,gap=6,noise=2,seed={}", seed), o}));
  mls = std::max(mls, compare({fmt::format("kirsch:size=1000x800,a=90,pattern=random,radius=6,gap=5,noise=1,blur=0.7,seed={}",
                                           seed + 1), o}));
  PipelineOptions light = o;
  light.analysis.polarity = Polarity::light_dots;
  light.analysis.method = ThresholdMethod::fixed;
  light.analysis.threshold = 100;
  light.layout = {64, 32, 64};
  mls = std::max(mls, compare({fmt::format("bending:size=800x600,pattern=random,radius=6,gap=6,polarity=light,bits=16,"
                                           "lighting=0.2,seed={}", seed + 2),
                               light}));
  PipelineOptions fe_opt = o;
  fe_opt.interp = Interp::fe;
  fe_opt.layout = {1024, 256, 256};
  fe_opt.analysis.roi = cv::Rect(40, 30, 700, 500);
  fe = compare({fmt::format("rotation:size=800x600,deg=0.4,pattern=random,radius=5,gap=5,seed={}", seed + 3), fe_opt});
  PipelineOptions radius = o;
  radius.mls.support = parse_support("45px");
  radius.mls.weight = Weight::gaussian;
  mls = std::max(mls, compare({fmt::format("translation:size=640x480,dx=1.3,dy=-0.6,pattern=random,radius=5,gap=4,noise=3,"
                                           "seed={}", seed + 4),
                               radius}));
  // One line per run, for the distribution over repeated runs (docs/PERFORMANCE.md).
  std::printf("DctCuda max |de| GPU - cpu-seq: MLS %.2e, FE %.2e (seed %llu)\n", mls, fe,
              static_cast<unsigned long long>(seed));
  RecordProperty("max_strain_difference_mls", fmt::format("{:.3e}", mls));
  RecordProperty("max_strain_difference_fe", fmt::format("{:.3e}", fe));
}

TEST(DctCuda, LabellingMatchesOpenCv) {
  DTFLOP_REQUIRE_GPU();
  // Random shapes, convex and not (discs, rings, L's, bars, specks), one per 40 px cell with
  // background between cells: the union-find labels the same 8-connected components as
  // OpenCV, with the same areas, in the same order.
  const std::uint64_t seed = fresh_seed();
  SCOPED_TRACE(seed_note(seed));
  std::mt19937 rng(static_cast<unsigned>(seed));
  cv::Mat img(521, 733, CV_8U, cv::Scalar(255));
  for (int cy = 0; cy + 40 <= img.rows; cy += 40)
    for (int cx = 0; cx + 40 <= img.cols; cx += 40) {
      const cv::Point c(cx + 20 + static_cast<int>(rng() % 5) - 2, cy + 20 + static_cast<int>(rng() % 5) - 2);
      switch (rng() % 6) {
        case 0: cv::circle(img, c, 3 + static_cast<int>(rng() % 10), cv::Scalar(0), cv::FILLED); break;
        case 1: cv::circle(img, c, 8 + static_cast<int>(rng() % 5), cv::Scalar(0), 2); break;  // ring
        case 2:
          cv::line(img, {c.x - 10, c.y - 10}, {c.x - 10, c.y + 10}, cv::Scalar(0), 2);
          cv::line(img, {c.x - 10, c.y + 10}, {c.x + 10, c.y + 10}, cv::Scalar(0), 2);
          break;
        case 3: cv::line(img, {c.x - 12, c.y + 8}, {c.x + 12, c.y - 8}, cv::Scalar(0), 1); break;  // 8-connected
        case 4: img.at<std::uint8_t>(c) = 0; break;
        default: {  // two specks touching at a corner: one 8-connected component
          img.at<std::uint8_t>(c) = 0;
          img.at<std::uint8_t>(c + cv::Point(1, 1)) = 0;
        }
      }
    }
  PipelineOptions o;
  o.analysis.method = ThresholdMethod::fixed;
  o.analysis.min_area = 1;
  o.analysis.max_area = 1 << 30;
  o.analysis.max_aspect = 1e9;
  o.analysis.min_fill = 0;
  o.analysis.reject_border = false;
  o.interp = Interp::fe;
  auto gpu = make_backend("cuda", o);
  auto cpu = make_backend("cpu-seq", o);
  cpu->set_reference(img);
  gpu->set_reference(img);
  cv::Mat labels, mask = img < 128;
  const int n = cv::connectedComponents(mask, labels, 8, CV_32S) - 1;
  const FrameOutput a = cpu->process(img), b = gpu->process(img);
  EXPECT_EQ(a.stats.components, n);
  EXPECT_EQ(b.stats.components, n);
  ASSERT_EQ(a.dots.size(), b.dots.size());
  for (std::size_t k = 0; k < a.dots.size(); ++k) EXPECT_EQ(a.dots[k].area, b.dots[k].area);
}

TEST(DctCuda, RejectsWhatItCannotDo) {
  DTFLOP_REQUIRE_GPU();
  PipelineOptions o;
  o.analysis.method = ThresholdMethod::adaptive;
  EXPECT_THROW(make_backend("cuda", o), InputError);
  o = PipelineOptions{};
  o.layout.block_points = 100;
  EXPECT_THROW(make_backend("cuda", o), InputError);
}

}  // namespace
}  // namespace dtflop::dct

namespace dtflop::dct {
namespace {

// Every block layout the workload allows (its cuda parameters block-pixels, block-points and
// block-dots: multiples of 32 in 32..1024), one parameter at a time with the others at their
// defaults, and a few mixed ones, on MLS and FE: the same dots, matches and fields as cpu-seq
// in float64, within the tolerance of the tests above (compare_frames).
TEST(DctCuda, EveryAllowedLayoutMatchesCpuSeq) {
  DTFLOP_REQUIRE_GPU();
  const std::uint64_t seed = fresh_seed();
  SCOPED_TRACE(seed_note(seed));
  const auto& w = workload();
  const auto& b = w.backend("cuda");
  const nlohmann::json base = {{"size", "640x480"}, {"dots", 150}, {"radius", 6}, {"points", "16x12"},
                               {"support", 30}, {"specimen-seed", static_cast<std::int64_t>(seed % 2147483647)}};
  const Specimen sp = specimen_of(w.validate(base, b));
  const cv::Mat ref = sp.reference_image(), def = sp.deformed_image();
  std::vector<nlohmann::json> layouts;
  for (const char* p : {"block-pixels", "block-points", "block-dots"}) {
    const auto* spec = w.find_param(p);
    ASSERT_NE(spec, nullptr) << p;
    int allowed = 0;
    for (int v = static_cast<int>(spec->min); v <= static_cast<int>(spec->max); ++v) {
      nlohmann::json g = base;
      g[p] = v;
      try {
        (void)w.validate(g, b);
      } catch (const InputError&) {
        continue;  // not a layout the workload allows
      }
      ++allowed;
      layouts.push_back({{p, v}});
    }
    EXPECT_EQ(allowed, 32) << p;  // 32, 64, ..., 1024
  }
  layouts.push_back({{"block-pixels", 32}, {"block-points", 1024}, {"block-dots", 32}});
  layouts.push_back({{"block-pixels", 1024}, {"block-points", 32}, {"block-dots", 1024}});
  layouts.push_back({{"block-pixels", 96}, {"block-points", 160}, {"block-dots", 224}});
  // A block size the workload allows may still be more than a kernel's registers let a block run
  // on this GPU (the fields kernel ran at most 768 on an H100): the backend refuses it before any
  // frame, saying so. Refusals must be the largest sizes only, and every size up to 256 must run.
  double worst = 0;
  std::map<std::string, int> smallest_refused, largest_run;
  int refused = 0;
  for (const auto& l : layouts)
    for (const char* interp : {"mls", "fe"}) {
      nlohmann::json g = base;
      for (const auto& [k, v] : l.items()) g[k] = v;
      g["interp"] = interp;
      const auto c = w.validate(g, b);
      try {
        worst = std::max(worst, compare_frames(fmt::format("{} {}", interp, l.dump()), ref, def, pipeline_options(c, "cuda")));
        if (l.size() == 1) largest_run[l.begin().key()] = std::max(largest_run[l.begin().key()], l.begin()->get<int>());
      } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("threads a block on this GPU"), std::string::npos) << e.what();
        ++refused;
        if (l.size() == 1) {
          auto [it, fresh] = smallest_refused.emplace(l.begin().key(), l.begin()->get<int>());
          if (!fresh) it->second = std::min(it->second, l.begin()->get<int>());
        }
      }
    }
  for (const auto& [p, v] : smallest_refused) {
    EXPECT_GT(v, 256) << p;
    EXPECT_LT(largest_run[p], v) << p << ": a size above a refused one ran";
    std::printf("%s: sizes from %d refused on this GPU\n", p.c_str(), v);
  }
  std::printf("%zu layouts x (mls, fe), %d refused: max |de| %.2e\n", layouts.size(), refused, worst);
}

// The threshold and weight parameters on the device: a fixed level and each weight function
// through the workload's configuration, against cpu-seq.
TEST(DctCuda, ThresholdAndWeightParametersMatchCpuSeq) {
  DTFLOP_REQUIRE_GPU();
  const std::uint64_t seed = fresh_seed();
  SCOPED_TRACE(seed_note(seed));
  const auto& w = workload();
  const auto& b = w.backend("cuda");
  for (const char* weight : {"cubic", "quartic", "gaussian"})
    for (const char* threshold : {"otsu", "fixed"}) {
      const nlohmann::json g = {{"size", "700x500"}, {"dots", 150}, {"radius", 6}, {"points", "16x12"},
                                {"support-radius", 120}, {"weight", weight}, {"threshold", threshold},
                                {"specimen-seed", static_cast<std::int64_t>(seed % 2147483647)}};
      const auto c = w.validate(g, b);
      const Specimen sp = specimen_of(c);
      compare_frames(g.dump(), sp.reference_image(), sp.deformed_image(), pipeline_options(c, "cuda"));
    }
}

#if DTFLOP_HAVE_CUDA
// Otsu's kernel (one thread a bin, prefix sums, first maximum) gives the serial loop's threshold to
// the bit: on random frames of both depths, and on the histograms where the first maximum decides
// (spikes at 0 and at the top: every t between them splits them alike, so every t ties), one bin
// only (no t splits it: 0) and two adjacent bins.
TEST(DctCuda, OtsuKernelGivesTheSerialLoopsThreshold) {
  DTFLOP_REQUIRE_GPU();
  const int w = 257, h = 129;  // odd sizes: the histogram's tail
  std::mt19937 rng(7);
  std::vector<cv::Mat> frames;
  for (int depth : {CV_8U, CV_16U}) {
    const double top = depth == CV_8U ? 255 : 65535;
    for (int k = 0; k < 6; ++k) {  // two classes of random means and spreads
      cv::Mat m(h, w, depth);
      std::normal_distribution<double> dark(std::uniform_real_distribution<double>(0.1, 0.4)(rng) * top, 0.05 * top * (k + 1));
      std::normal_distribution<double> light(std::uniform_real_distribution<double>(0.6, 0.9)(rng) * top, 0.04 * top * (k + 1));
      std::bernoulli_distribution is_dark(0.1 + 0.13 * k);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          const double v = std::clamp(std::round(is_dark(rng) ? dark(rng) : light(rng)), 0.0, top);
          if (depth == CV_8U) m.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(v);
          else m.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(v);
        }
      frames.push_back(m);
    }
    cv::Mat spikes(h, w, depth, cv::Scalar(0));
    spikes.colRange(0, 128).setTo(top);  // spikes of 128 x h and 129 x h pixels
    frames.push_back(spikes.clone());
    spikes.colRange(0, 129).setTo(top);  // 129 x h and 128 x h
    frames.push_back(spikes.clone());
    cv::Mat even(2 * h, w + 1, depth, cv::Scalar(0));
    even.rowRange(0, h).setTo(top);  // equal spikes
    frames.push_back(even);
    frames.push_back(cv::Mat(h, w, depth, cv::Scalar(top / 3)));  // one bin
    cv::Mat two(h, w, depth, cv::Scalar(depth == CV_8U ? 100 : 100 * 257));
    two.rowRange(0, 40).setTo(depth == CV_8U ? 101 : 101 * 257);  // adjacent bins
    frames.push_back(two);
  }
  std::size_t max_bytes = 0;
  for (const auto& f : frames) max_bytes = std::max(max_bytes, f.total() * f.elemSize());
  void* d_img = nullptr;
  unsigned int* d_hist = nullptr;
  int* d_T = nullptr;
  ASSERT_EQ(cudaMalloc(&d_img, max_bytes), cudaSuccess);
  ASSERT_EQ(cudaMalloc(reinterpret_cast<void**>(&d_hist), 256 * sizeof(unsigned int)), cudaSuccess);
  ASSERT_EQ(cudaMalloc(reinterpret_cast<void**>(&d_T), sizeof(int)), cudaSuccess);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    SCOPED_TRACE(fmt::format("frame {} ({}-bit)", i, frames[i].depth() == CV_8U ? 8 : 16));
    const cv::Mat& f = frames[i];
    const bool wide = f.depth() == CV_16U;
    std::array<std::int64_t, 256> hist{};
    for (int y = 0; y < f.rows; ++y)
      for (int x = 0; x < f.cols; ++x) ++hist[wide ? f.at<std::uint16_t>(y, x) / 257 : f.at<std::uint8_t>(y, x)];
    const int t = static_cast<int>(otsu_threshold(hist));
    ASSERT_EQ(cudaMemcpy(d_img, f.data, f.total() * f.elemSize(), cudaMemcpyHostToDevice), cudaSuccess);
    gpu::launch_otsu(d_img, wide, f.cols, f.rows, d_hist, d_T, 256, nullptr);
    int T = -1;
    ASSERT_EQ(cudaMemcpy(&T, d_T, sizeof(int), cudaMemcpyDeviceToHost), cudaSuccess);
    EXPECT_EQ(T, wide ? t * 257 + 256 : t) << "the serial loop's t = " << t;
  }
  EXPECT_EQ(cudaFree(d_img), cudaSuccess);
  EXPECT_EQ(cudaFree(d_hist), cudaSuccess);
  EXPECT_EQ(cudaFree(d_T), cudaSuccess);
}
#endif

}  // namespace
}  // namespace dtflop::dct
