// Stereo DCT speed on two 24 MP streams (Google Benchmark), without cameras: the two views of a
// dot plate are rendered in memory by the independent camera renderer (tests/workloads/dct/
// independent_renderer/camera.hpp) from a known pair, before and after a 0.5 mm out-of-plane
// bulge, and each iteration measures one pair of frames: both cameras' 2D pipelines (threshold,
// labelling, centroids, tracking, fields), the left-right pairing, triangulation and u_z with its
// gradient at the points. Cases: Stereo24MP/<backend> (cpu-par, cuda). Counters: pairs per second,
// dots, dots triangulated, each camera's and the stereo stage's time per pair, and the u_z RMS
// error against the bulge (mm) so a fast run is also seen to be right.
//   bench_dct_stereo --benchmark_filter=Stereo24MP
#include <cmath>
#include <map>
#include <memory>
#include <random>
#include <string>

#include <benchmark/benchmark.h>
#include <opencv2/calib3d.hpp>

#include "camera.hpp"
#include "workloads/dct/stereo_dots.hpp"

namespace dtflop::dct::stereo {
namespace {

// A 24 MP pair (6000 x 4000, f = 7000 px), 300 mm apart, converging 17 deg, k1 = -0.03; a
// 600 x 400 mm plate 1 m out with 1600 random dots of radius 3 mm (21 px).
struct StereoScene {
  dct_indep::CameraPair pair;
  dct_indep::PlatePose pose;
  std::vector<cv::Point2d> centres;
  cv::Mat L0, R0, L1, R1;
  double bulge = 0.5;
};

const StereoScene& scene() {
  static std::unique_ptr<StereoScene> s;
  if (s) return *s;
  s = std::make_unique<StereoScene>();
  s->pair = dct_indep::make_pair({6000, 4000}, 7000, 300, 17, -0.03);
  s->pose = {cv::Vec3d(0.05, -0.15, 0.02), cv::Vec3d(150, 0, 1000)};
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> ux(-290, 290), uy(-190, 190);
  const double dmin = 2 * 3 + 5;
  const int gw = static_cast<int>(600 / dmin) + 2, gh = static_cast<int>(400 / dmin) + 2;
  std::vector<std::vector<int>> grid(static_cast<std::size_t>(gw * gh));
  for (int tries = 0; s->centres.size() < 1600 && tries < 400000; ++tries) {
    const cv::Point2d p{ux(rng), uy(rng)};  // braces: x drawn before y on every compiler
    const int cx = static_cast<int>((p.x + 300) / dmin), cy = static_cast<int>((p.y + 200) / dmin);
    bool ok = true;
    for (int j = std::max(0, cy - 1); j <= std::min(gh - 1, cy + 1) && ok; ++j)
      for (int i = std::max(0, cx - 1); i <= std::min(gw - 1, cx + 1) && ok; ++i)
        for (int k : grid[static_cast<std::size_t>(j * gw + i)])
          if (cv::norm(s->centres[static_cast<std::size_t>(k)] - p) < dmin) ok = false;
    if (!ok) continue;
    grid[static_cast<std::size_t>(cy * gw + cx)].push_back(static_cast<int>(s->centres.size()));
    s->centres.push_back(p);
  }
  const auto dots = dct_indep::dot_shapes(s->centres, 3, 40);
  const auto rpose = dct_indep::right_pose(s->pair, s->pose);
  const double b = s->bulge;
  const dct_indep::Displacement u = [b](double X, double Y) {
    return cv::Vec3d(0, 0, -b * std::exp(-(X * X + Y * Y) / (2 * 120.0 * 120.0)));
  };
  s->L0 = dct_indep::render_view(s->pair.left, s->pose, dots, 200);
  s->R0 = dct_indep::render_view(s->pair.right, rpose, dots, 200);
  s->L1 = dct_indep::render_view(s->pair.left, s->pose, dots, 200, CV_8U, u);
  s->R1 = dct_indep::render_view(s->pair.right, rpose, dots, 200, CV_8U, u);
  return *s;
}

Rig rig_of(const dct_indep::CameraPair& p) {
  Rig r;
  r.left = {p.left.K, p.left.dist.clone(), p.left.size};
  r.right = {p.right.K, p.right.dist.clone(), p.right.size};
  r.R = p.R;
  r.T = p.T;
  return r;
}

void BM_Stereo24MP(benchmark::State& state, const std::string& backend) {
  const StereoScene& sc = scene();
  PipelineOptions o;
  o.mls.support = parse_support("60dots");
  o.mls.support_at_most_found = false;
  o.points_x = 64;
  o.points_y = 32;
  std::unique_ptr<StereoPipeline> p;
  try {
    p = std::make_unique<StereoPipeline>(rig_of(sc.pair), backend, o);
    p->set_reference(sc.L0, sc.R0);
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  // Frames from the buffers the backend uploads from fastest (pinned memory for cuda).
  cv::Mat L = p->left().frame_buffer(sc.L1.size(), sc.L1.type()), R = p->right().frame_buffer(sc.R1.size(), sc.R1.type());
  sc.L1.copyTo(L);
  sc.R1.copyTo(R);
  StereoFrame f;
  std::map<std::string, double> sum;
  for (auto _ : state) {
    f = p->process(L, R);
    benchmark::DoNotOptimize(f.fields.data());
    for (const auto& [k, v] : f.seconds)
      if (k == "left" || k == "right" || k == "stereo") sum[k] += v;
  }
  const double n = static_cast<double>(state.iterations());
  for (const auto& [k, v] : sum) state.counters[k + "_ms"] = 1e3 * v / n;
  state.counters["pairs_per_s"] = benchmark::Counter(1, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["dots"] = static_cast<double>(p->left().reference_dots().size());
  state.counters["triangulated"] = f.triangulated;
  // u_z against the bulge at the dots' true plate positions (nearest projected centre).
  const auto truth = dct_indep::project(sc.pair.left, sc.pose, sc.centres);
  const auto& lref = p->left().reference_positions();
  double se = 0;
  int m = 0;
  for (std::size_t i = 0; i < lref.size(); ++i) {
    if (!std::isfinite(f.uz[i])) continue;
    for (std::size_t k = 0; k < truth.size(); ++k)
      if (std::hypot(truth[k].x - lref[i].x, truth[k].y - lref[i].y) < 1) {
        const auto& c = sc.centres[k];
        se += std::pow(f.uz[i] - sc.bulge * std::exp(-(c.x * c.x + c.y * c.y) / (2 * 120.0 * 120.0)), 2);
        ++m;
        break;
      }
  }
  state.counters["uz_rms_mm"] = m ? std::sqrt(se / m) : std::nan("");
}

BENCHMARK_CAPTURE(BM_Stereo24MP, cuda, std::string("cuda"))->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
BENCHMARK_CAPTURE(BM_Stereo24MP, cpu_par, std::string("cpu-par"))->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

}  // namespace
}  // namespace dtflop::dct::stereo

BENCHMARK_MAIN();
