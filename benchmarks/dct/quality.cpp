// dct_quality: the DCT workload's measurement quality on images from the independent renderer
// (tests/workloads/dct/independent_renderer), which shares no code with workloads/dct.
//   dct_quality fields  [backend] [support] [interp] [seeds]  displacement / strain errors per deformation
//   dct_quality auto-support [backend] [seeds]                       the support suggestion applied: errors before / after
//   dct_quality fe-ratio [backend] [support] [seeds]                 FE / MLS strain error by distance from the hull
//   dct_quality fe-sd [support] [seeds]                              FE / MLS stated strain deviation, geometry only
//   dct_quality centroids [margin]                                   centroid error vs radius, blur, noise
//   dct_quality sigma [backend] [support] [interp] [runs]            stated vs observed deviation
//   dct_quality kirsch [backend] [seeds] [interp] [support...]       e_yy at the hole edge: bias and noise
//   dct_quality support-noise [backend]                              strain noise factor vs dots per support
// Results and how they were made: results/dct-quality/README.md.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "render.hpp"
#include "workloads/dct/backend.hpp"
#include "workloads/dct/support.hpp"
#include "workloads/dct/tracking.hpp"
#include "workloads/dct/uncertainty.hpp"

using namespace dtflop::dct;

namespace {

struct Errors {
  double u_rms = 0, exx = 0, eyy = 0, exy = 0, e_max = 0;
  int valid = 0, points = 0, interior = 0, interior_valid = 0;
  int covered = 0, covered_valid = 0;
  double inner = 0, inner_sse = 0;  // points over 200 px inside the hull: their strain error  // interior points inside the reference dots' convex hull
  std::map<std::string, int> invalid;  // interior points by reason
};

dct_indep::Params params(const std::string& deformation, std::uint64_t seed) {
  dct_indep::Params p;
  p.deformation = deformation;
  p.seed = seed;
  return p;
}

Errors measure(const dct_indep::Scene& s, const std::string& backend, const PipelineOptions& o, std::uint64_t noise_seed) {
  const cv::Mat ref = dct_indep::finish(dct_indep::render_clean(s, false), s.p.noise, noise_seed * 2);
  const cv::Mat def = dct_indep::finish(dct_indep::render_clean(s, true), s.p.noise, noise_seed * 2 + 1);
  auto b = make_backend(backend, o);
  b->set_reference(ref);
  const FrameOutput out = b->process(def);
  Errors e;
  double su = 0, sxx = 0, syy = 0, sxy = 0;
  const auto& pts = b->points();
  std::vector<cv::Point2f> refs, hull;
  for (const auto& d : s.dots) refs.emplace_back(static_cast<float>(d.x), static_cast<float>(d.y));
  cv::convexHull(refs, hull);
  for (std::size_t m = 0; m < pts.size(); ++m) {
    ++e.points;
    const dct_indep::P2 P{pts[m].x, pts[m].y};
    if (!s.field->material(P)) continue;
    ++e.interior;
    const auto& f = out.fields[m];
    const double hull_dist = cv::pointPolygonTest(hull, cv::Point2f(static_cast<float>(P.x), static_cast<float>(P.y)), true);
    const bool in_hull = hull_dist > 0.5;
    e.covered += in_hull;
    e.covered_valid += in_hull && f.status == PointStatus::ok;
    if (f.status != PointStatus::ok) {
      ++e.invalid[to_string(f.status)];
      continue;
    }
    ++e.interior_valid;
    ++e.valid;
    const dct_indep::P2 u = s.field->u(P);
    const dct_indep::Grad g = s.field->grad(P);
    su += (f.ux - u.x) * (f.ux - u.x) + (f.uy - u.y) * (f.uy - u.y);
    const double dxx = f.exx - dct_indep::gl_xx(g), dyy = f.eyy - dct_indep::gl_yy(g), dxy = f.exy - dct_indep::gl_xy(g);
    sxx += dxx * dxx;
    syy += dyy * dyy;
    sxy += dxy * dxy;
    e.e_max = std::max({e.e_max, std::abs(dxx), std::abs(dyy), std::abs(dxy)});
    if (hull_dist > 200) {
      e.inner += 1;
      e.inner_sse += dxx * dxx + dyy * dyy + dxy * dxy;
    }
  }
  if (e.valid) {
    e.u_rms = std::sqrt(su / (2 * e.valid));
    e.exx = std::sqrt(sxx / e.valid);
    e.eyy = std::sqrt(syy / e.valid);
    e.exy = std::sqrt(sxy / e.valid);
  }
  return e;
}

int fields(int argc, char** argv) {
  const std::string backend = argc > 2 ? argv[2] : "cpu-par";
  PipelineOptions o;
  if (argc > 3) o.mls.support = parse_support(argv[3]);
  if (argc > 4) o.interp = interp_from_string(argv[4]);
  const int seeds = argc > 5 ? std::stoi(argv[5]) : 1;
  if (argc > 6) o.mls.weight = weight_from_string(argv[6]);
  std::printf("| deformation | seed | valid / interior points | valid / covered | u RMS [px] | e_xx RMS | e_yy RMS | "
              "e_xy RMS | max |e| [microstrain] |\n|---|---|---|---|---|---|---|---|---|\n");
  for (const char* d : {"tension", "bending", "rotation"})
    for (int seed = 1; seed <= seeds; ++seed) {
      const dct_indep::Scene s = dct_indep::make_scene(params(d, seed));
      const Errors e = measure(s, backend, o, seed);
      std::printf("| %s | %d | %d / %d | %d / %d | %.4f | %.1f | %.1f | %.1f | %.1f |\n", d, seed, e.interior_valid,
                  e.interior, e.covered_valid, e.covered, e.u_rms, 1e6 * e.exx, 1e6 * e.eyy, 1e6 * e.exy, 1e6 * e.e_max);
      if (std::getenv("DCT_QUALITY_INNER"))
        std::fprintf(stderr, "  inner (>200 px inside the hull) strain RMS %.1f over %g points\n",
                     1e6 * std::sqrt(e.inner_sse / (3 * e.inner)), e.inner);
      for (const auto& [why, k] : e.invalid) std::fprintf(stderr, "  invalid: %d %s\n", k, why.c_str());
      std::fflush(stdout);
    }
  return 0;
}

// FE against MLS on the same images, by distance from the dots' convex hull: the strain error
// RMS (all three components) of each over the points both give, inside the hull, in bands
// 0-100 px, 100-200 px and over 200 px from it, and over all of them; FE / MLS per band.
int fe_ratio(int argc, char** argv) {
  const std::string backend = argc > 2 ? argv[2] : "cpu-par";
  const std::string support = argc > 3 ? argv[3] : Support{}.str();
  const int seeds = argc > 4 ? std::stoi(argv[4]) : 1;
  constexpr int kBands = 4;  // 0-100, 100-200, > 200, all
  const char* band_names[kBands] = {"0-100 px", "100-200 px", "> 200 px", "all"};
  std::printf("FE / MLS strain error RMS by distance from the hull, %s, %s\n", backend.c_str(), support.c_str());
  std::printf("| deformation | seed | band | points | MLS [microstrain] | FE [microstrain] | FE / MLS | stated FE / MLS |\n"
              "|---|---|---|---|---|---|---|---|\n");
  double worst = 0, worst_stated = 0;
  for (const char* d : {"tension", "bending", "rotation"})
    for (int seed = 1; seed <= seeds; ++seed) {
      const dct_indep::Scene s = dct_indep::make_scene(params(d, seed));
      const cv::Mat ref = dct_indep::finish(dct_indep::render_clean(s, false), s.p.noise, 2 * seed);
      const cv::Mat def = dct_indep::finish(dct_indep::render_clean(s, true), s.p.noise, 2 * seed + 1);
      std::vector<FieldValue<double>> f[2];
      std::vector<FieldSigma> sd[2];
      std::vector<Vec2> pts;
      for (int k = 0; k < 2; ++k) {
        PipelineOptions o;
        o.mls.support = parse_support(support);
        o.interp = k ? Interp::fe : Interp::mls;
        auto b = make_backend(backend, o);
        b->set_reference(ref);
        const FrameOutput out = b->process(def);
        f[k] = out.fields;
        sd[k] = frame_uncertainty(ref, def, *b, out).points;
        pts = b->points();
      }
      std::vector<cv::Point2f> refs, hull;
      for (const auto& q : s.dots) refs.emplace_back(static_cast<float>(q.x), static_cast<float>(q.y));
      cv::convexHull(refs, hull);
      double sse[2][kBands] = {}, var[2][kBands] = {};
      int n[kBands] = {};
      for (std::size_t m = 0; m < pts.size(); ++m) {
        const double dist = cv::pointPolygonTest(hull, cv::Point2f(static_cast<float>(pts[m].x), static_cast<float>(pts[m].y)), true);
        if (!(dist > 0.5) || f[0][m].status != PointStatus::ok || f[1][m].status != PointStatus::ok) continue;
        const dct_indep::Grad g = s.field->grad({pts[m].x, pts[m].y});
        const int band = dist <= 100 ? 0 : dist <= 200 ? 1 : 2;
        for (int k = 0; k < 2; ++k) {
          const auto& v = f[k][m];
          const double e = std::pow(v.exx - dct_indep::gl_xx(g), 2) + std::pow(v.eyy - dct_indep::gl_yy(g), 2) +
                           std::pow(v.exy - dct_indep::gl_xy(g), 2);
          sse[k][band] += e;
          sse[k][kBands - 1] += e;
          const auto& q = sd[k][m];
          const double vv = q.exx * q.exx + q.eyy * q.eyy + q.exy * q.exy;
          var[k][band] += vv;
          var[k][kBands - 1] += vv;
        }
        ++n[band];
        ++n[kBands - 1];
      }
      for (int b = 0; b < kBands; ++b) {
        if (!n[b]) continue;
        const double mls = std::sqrt(sse[0][b] / (3 * n[b])), fe = std::sqrt(sse[1][b] / (3 * n[b]));
        const double stated = std::sqrt(var[1][b] / var[0][b]);
        worst = std::max(worst, fe / mls);
        worst_stated = std::max(worst_stated, stated);
        std::printf("| %s | %d | %s | %d | %.1f | %.1f | %.2f | %.2f |\n", d, seed, band_names[b], n[b], 1e6 * mls,
                    1e6 * fe, fe / mls, stated);
      }
      std::fflush(stdout);
    }
  std::printf("worst FE / MLS: %.2f (stated deviations: %.2f)\n", worst, worst_stated);
  return 0;
}

// The strain noise FE and MLS propagate from the dots, from the geometry alone (no images):
// every dot's displacement given unit variance per axis, the stated deviation of e_xx, e_yy
// and e_xy (RMS over the three) at the 32x32 grid, FE / MLS by distance from the hull, over
// the independent renderer's patterns. Deterministic: the noise half of `fe-ratio`.
int fe_sd(int argc, char** argv) {
  const std::string support = argc > 2 ? argv[2] : Support{}.str();
  const int seeds = argc > 3 ? std::stoi(argv[3]) : 3;
  if (seeds < 1 || seeds > 1000) throw std::invalid_argument("fe-sd: seeds must be 1..1000; give a pattern count in that range");
  constexpr int kBands = 4;
  const char* band_names[kBands] = {"0-100 px", "100-200 px", "> 200 px", "all"};
  std::printf("FE / MLS stated strain deviation (unit dot variance) by distance from the hull, %s\n", support.c_str());
  std::printf("| seed | band | points | MLS | FE | FE / MLS |\n|---|---|---|---|---|---|\n");
  double worst = 0;
  for (int seed = 1; seed <= seeds; ++seed) {
    const dct_indep::Scene s = dct_indep::make_scene(params("none", static_cast<std::uint64_t>(seed)));
    std::vector<Vec2> ref;
    std::vector<cv::Point2f> refs, hull;
    for (const auto& q : s.dots) {
      ref.push_back({q.x, q.y});
      refs.emplace_back(static_cast<float>(q.x), static_cast<float>(q.y));
    }
    cv::convexHull(refs, hull);
    const std::vector<Vec2> pts = grid_points_over(ref, 32, 32, 0);
    MlsOptions o;
    o.support = parse_support(support);
    const MlsTable mt = build_mls_table(ref, pts, o);
    const FeTable ft = build_fe_table(ref, pts, PipelineOptions{}.fe_max_gap, o);
    const std::vector<std::uint8_t> tracked(ref.size(), 1);
    const std::vector<Vec2> var(ref.size(), Vec2{1, 1});
    const std::vector<Vec2> zero(ref.size(), Vec2{0, 0});
    const auto fm = evaluate_mls(mt, ref, zero, tracked, o);
    const auto ff = evaluate_fe(ft, zero, tracked);
    const auto sm = propagate_mls(mt, ref, tracked, var, o, fm);
    const auto sf = propagate_fe(ft, tracked, var, ff);
    double v[2][kBands] = {};
    int n[kBands] = {};
    for (std::size_t m = 0; m < pts.size(); ++m) {
      const double dist = cv::pointPolygonTest(hull, cv::Point2f(static_cast<float>(pts[m].x), static_cast<float>(pts[m].y)), true);
      if (!(dist > 0.5) || fm[m].status != PointStatus::ok || ff[m].status != PointStatus::ok) continue;
      const int band = dist <= 100 ? 0 : dist <= 200 ? 1 : 2;
      for (int k = 0; k < 2; ++k) {
        const FieldSigma& q = k ? sf[m] : sm[m];
        const double e = q.exx * q.exx + q.eyy * q.eyy + q.exy * q.exy;
        v[k][band] += e;
        v[k][kBands - 1] += e;
      }
      ++n[band];
      ++n[kBands - 1];
    }
    for (int b = 0; b < kBands; ++b) {
      if (!n[b]) continue;
      const double mls = std::sqrt(v[0][b] / (3 * n[b])), fe = std::sqrt(v[1][b] / (3 * n[b]));
      worst = std::max(worst, fe / mls);
      std::printf("| %d | %s | %d | %.3g | %.3g | %.2f |\n", seed, band_names[b], n[b], mls, fe, fe / mls);
    }
  }
  std::printf("worst FE / MLS: %.2f\n", worst);
  return 0;
}

// Centroid error: the reference image of each specimen analysed; every found dot matched to its
// true centre (nearest within 2 px).
int centroids(int margin) {
  std::printf("| radius [px] | blur [px] | noise [grey] | dots found | centroid RMS error [px] | max [px] |\n"
              "|---|---|---|---|---|---|\n");
  struct Case { double radius, blur, noise; };
  for (const Case c : {Case{4, 0, 1}, Case{5, 0, 1}, Case{7, 0, 0}, Case{7, 0, 1}, Case{7, 0, 2}, Case{7, 0, 4},
                       Case{7, 0.5, 1}, Case{7, 1, 1}, Case{7, 2, 1}, Case{10, 0, 1}, Case{14, 0, 1}}) {
    dct_indep::Params p = params("none", 11);
    p.radius = c.radius;
    p.blur = c.blur;
    p.noise = c.noise;
    p.min_gap = std::max(7.0, c.radius);
    p.dots = c.radius > 10 ? 300 : 500;
    const dct_indep::Scene s = dct_indep::make_scene(p);
    const cv::Mat img = dct_indep::finish(dct_indep::render_clean(s, false), p.noise, 5);
    AnalysisOptions ao;
    ao.margin = margin;
    const AnalysisResult r = analyze(img, ao, 2);
    std::vector<Vec2> truth;
    for (const auto& d : s.dots) truth.push_back({d.x, d.y});
    PointIndex idx(truth);
    double se = 0, mx = 0;
    int n = 0;
    std::vector<std::uint32_t> k;
    std::vector<double> d2;
    for (const auto& d : r.dots) {
      idx.knn({d.x, d.y}, 1, k, d2);
      if (d2.empty() || d2[0] > 4) continue;
      se += d2[0];
      mx = std::max(mx, std::sqrt(d2[0]));
      ++n;
    }
    std::printf("| %g | %g | %g | %d of %zu | %.4f | %.4f |\n", c.radius, c.blur, c.noise, n, s.dots.size(),
                n ? std::sqrt(se / (2 * n)) : NAN, mx);
    std::fflush(stdout);
  }
  return 0;
}

// Stated against observed: `runs` renders of one pattern under tension with fresh noise;
// per point the scatter of each value over the runs against the mean stated deviation.
int sigma(int argc, char** argv) {
  const std::string backend = argc > 2 ? argv[2] : "cpu-par";
  PipelineOptions o;
  if (argc > 3) o.mls.support = parse_support(argv[3]);
  if (argc > 4) o.interp = interp_from_string(argv[4]);
  const int runs = argc > 5 ? std::stoi(argv[5]) : 20;
  const dct_indep::Scene s = dct_indep::make_scene(params("tension", 3));
  const cv::Mat cref = dct_indep::render_clean(s, false), cdef = dct_indep::render_clean(s, true);
  const int n = o.points_x * o.points_y;
  std::vector<std::array<double, 5>> sum(n), sum2(n), stated(n);
  std::vector<int> cnt(n, 0);
  double noise = 0, csig = 0, cobs = 0;
  std::vector<Vec2> c1, c2;  // first dot's centroid per run
  for (int r = 0; r < runs; ++r) {
    const cv::Mat ref = dct_indep::finish(cref, 1, 1000 + 2 * r), def = dct_indep::finish(cdef, 1, 1001 + 2 * r);
    auto b = make_backend(backend, o);
    b->set_reference(ref);
    const FrameOutput out = b->process(def);
    const FrameUncertainty u = frame_uncertainty(ref, def, *b, out);
    noise += u.reference_noise.sigma / runs;
    c1.push_back({b->reference_dots()[0].x, b->reference_dots()[0].y});
    csig += u.reference_dots[0].x / runs;
    for (int m = 0; m < n; ++m) {
      const auto& f = out.fields[m];
      if (f.status != PointStatus::ok) continue;
      const double v[5] = {f.ux, f.uy, f.exx, f.eyy, f.exy};
      const auto& q = u.points[m];
      const double sd[5] = {q.ux, q.uy, q.exx, q.eyy, q.exy};
      for (int i = 0; i < 5; ++i) {
        sum[m][i] += v[i];
        sum2[m][i] += v[i] * v[i];
        stated[m][i] += sd[i] * sd[i];
      }
      ++cnt[m];
    }
  }
  {
    double mx = 0, vx = 0;
    for (auto c : c1) mx += c.x / runs;
    for (auto c : c1) vx += (c.x - mx) * (c.x - mx) / (runs - 1);
    cobs = std::sqrt(vx);
  }
  std::printf("noise estimate %.3f grey levels (rendered 1, plus rounding: %.3f)\n", noise, std::sqrt(1 + 1.0 / 12));
  std::printf("one dot's centroid: stated %.4f px, observed %.4f px over %d runs\n", csig, cobs, runs);
  const char* names[5] = {"u_x", "u_y", "e_xx", "e_yy", "e_xy"};
  for (int i = 0; i < 5; ++i) {
    double obs = 0, st = 0;
    int k = 0;
    for (int m = 0; m < n; ++m) {
      if (cnt[m] != runs) continue;
      const double mean = sum[m][i] / runs;
      obs += (sum2[m][i] - runs * mean * mean) / (runs - 1);
      st += stated[m][i] / runs;
      ++k;
    }
    std::printf("%s: stated %.4g, observed %.4g (RMS over %d points), ratio %.3f\n", names[i], std::sqrt(st / k),
                std::sqrt(obs / k), k, std::sqrt(st / obs));
  }
  return 0;
}

// Kirsch's plate (load along y, far-field strain 2e-3, hole radius 300 px, 2400 dots of
// radius 5 px): e_yy at the two ends of the hole's horizontal diameter, where the closed form
// gives 3 x 2e-3, over `seeds` noise draws of one pattern. Bias and noise apart, as the DIC
// Challenge 2.0 reports them: bias = mean over the draws - closed form (the smoothing of the
// concentration by the support, and the extrapolation to the edge), noise = the standard
// deviation over the draws.
struct KirschEdge {
  double truth = 0, mean = 0, bias = 0, noise = 0, rms = 0, rho = 0;  // rho: MLS support radius at the edge
  int draws = 0;
};

dct_indep::Params kirsch_params() {
  dct_indep::Params p = params("kirsch", 5);
  p.hole = 300;
  p.strain = 2e-3;
  p.radius = 5;
  p.min_gap = 5;
  p.dots = 2400;
  return p;
}

std::vector<KirschEdge> kirsch_edge(const std::string& backend, const std::vector<std::string>& supports, Interp interp,
                                    int seeds) {
  const dct_indep::Scene s = dct_indep::make_scene(kirsch_params());
  const cv::Mat cref = dct_indep::render_clean(s, false), cdef = dct_indep::render_clean(s, true);
  const double a = s.p.hole;
  const std::vector<Vec2> edges = {{s.centre.x + a, s.centre.y}, {s.centre.x - a, s.centre.y}};
  std::vector<KirschEdge> out(supports.size());
  std::vector<std::vector<double>> values(supports.size());
  for (int r = 0; r < seeds; ++r) {
    const cv::Mat ref = dct_indep::finish(cref, s.p.noise, 500 + 2 * r), def = dct_indep::finish(cdef, s.p.noise, 501 + 2 * r);
    for (std::size_t k = 0; k < supports.size(); ++k) {
      PipelineOptions o;
      o.interp = interp;
      o.mls.support = parse_support(supports[k]);
      o.analysis.max_area = 2000;  // the hole is one huge dark blob
      o.points = edges;
      auto b = make_backend(backend, o);
      b->set_reference(ref);
      const FrameOutput f = b->process(def);
      for (std::size_t m = 0; m < edges.size(); ++m)
        if (f.fields[m].status == PointStatus::ok) values[k].push_back(f.fields[m].eyy);
      if (interp == Interp::mls && r == 0) out[k].rho = 0.5 * (b->mls_table().rho[0] + b->mls_table().rho[1]);
    }
  }
  const double truth = dct_indep::gl_yy(s.field->grad({edges[0].x, edges[0].y}));  // 3 e0 + (3 e0)^2 / 2 + ...
  for (std::size_t k = 0; k < supports.size(); ++k) {
    KirschEdge& e = out[k];
    e.truth = truth;
    e.draws = static_cast<int>(values[k].size());
    if (e.draws < 2) continue;
    double sum = 0, sse = 0;
    for (double v : values[k]) sum += v, sse += (v - truth) * (v - truth);
    e.mean = sum / e.draws;
    e.bias = e.mean - truth;
    double var = 0;
    for (double v : values[k]) var += (v - e.mean) * (v - e.mean);
    e.noise = std::sqrt(var / (e.draws - 1));
    e.rms = std::sqrt(sse / e.draws);
  }
  return out;
}

int kirsch(int argc, char** argv) {
  const std::string backend = argc > 2 ? argv[2] : "cpu-par";
  const int seeds = argc > 3 ? std::stoi(argv[3]) : 10;
  const Interp interp = argc > 4 ? interp_from_string(argv[4]) : Interp::mls;
  std::vector<std::string> supports;
  for (int i = 5; i < argc; ++i) supports.push_back(argv[i]);
  if (supports.empty())
    supports = {"12dots", "20dots", "30dots", "45dots", "60dots", "90dots", "120dots", "150dots", "200dots", "300dots"};
  const auto r = kirsch_edge(backend, supports, interp, seeds);
  std::printf("Kirsch e_yy at the hole edge (closed form %.1f microstrain), %s, %s, 2 edge points x %d noise draws\n",
              1e6 * r[0].truth, backend.c_str(), to_string(interp).c_str(), seeds);
  std::printf("| support | radius [px] | values | mean [microstrain] | bias | noise (sd) | RMS error | bias [%%] | "
              "noise [%%] | RMS [%%] |\n|---|---|---|---|---|---|---|---|---|---|\n");
  for (std::size_t k = 0; k < r.size(); ++k)
    std::printf("| %s | %.1f | %d | %.1f | %.1f | %.1f | %.1f | %+.2f | %.2f | %.2f |\n", supports[k].c_str(), r[k].rho, r[k].draws,
                1e6 * r[k].mean, 1e6 * r[k].bias, 1e6 * r[k].noise, 1e6 * r[k].rms, 100 * r[k].bias / r[k].truth,
                100 * r[k].noise / r[k].truth, 100 * r[k].rms / r[k].truth);
  return 0;
}

// The noise half of the support suggestion (workloads/dct/support.hpp): uniform tension (the
// quadratic basis reproduces it, so the whole strain error is noise) at supports of n dots, on
// two dot densities; per n the support radius over the median dot spacing and the noise factor
// k = strain RMS error (per component) x spacing / displacement sd (per dot and axis, from the
// stated centroid deviations of both images).
int support_noise(int argc, char** argv) {
  const std::string backend = argc > 2 ? argv[2] : "cpu-par";
  std::printf("| pattern | dots per support | radius / spacing | spacing [px] | displacement sd [px] | strain RMS "
              "[microstrain] | noise factor |\n|---|---|---|---|---|---|---|\n");
  struct Pattern { int dots; double radius, gap; std::uint64_t seed; };
  for (const Pattern pat : {Pattern{500, 7, 7, 1}, Pattern{500, 7, 7, 2}, Pattern{1500, 5, 5, 3}}) {
    dct_indep::Params p = params("tension", pat.seed);
    p.dots = pat.dots;
    p.radius = pat.radius;
    p.min_gap = pat.gap;
    const dct_indep::Scene s = dct_indep::make_scene(p);
    const cv::Mat ref = dct_indep::finish(dct_indep::render_clean(s, false), p.noise, 2 * pat.seed);
    const cv::Mat def = dct_indep::finish(dct_indep::render_clean(s, true), p.noise, 2 * pat.seed + 1);
    for (int n : {12, 20, 30, 45, 60, 90, 120, 150, 200, 250, 300, 400}) {
      PipelineOptions o;
      o.mls.support = parse_support(std::to_string(n) + "dots");
      auto b = make_backend(backend, o);
      b->set_reference(ref);
      const FrameOutput out = b->process(def);
      const FrameUncertainty u = frame_uncertainty(ref, def, *b, out);
      double var = 0;
      int k = 0;
      for (std::size_t j = 0; j < out.tracked.size(); ++j) {
        const int d = out.matches.ref_to_def[j];
        if (!out.tracked[j] || d < 0) continue;
        const auto a = u.reference_dots[j], c = u.frame_dots[static_cast<std::size_t>(d)];
        var += 0.5 * (a.x * a.x + c.x * c.x + a.y * a.y + c.y * c.y);
        ++k;
      }
      const double sd = std::sqrt(var / k), spacing = median_spacing(b->reference_positions());
      double se = 0, rho = 0;
      int m = 0;
      for (std::size_t q = 0; q < out.fields.size(); ++q) {
        const auto& f = out.fields[q];
        if (f.status != PointStatus::ok) continue;
        const dct_indep::Grad g = s.field->grad({b->points()[q].x, b->points()[q].y});
        se += std::pow(f.exx - dct_indep::gl_xx(g), 2) + std::pow(f.eyy - dct_indep::gl_yy(g), 2) +
              std::pow(f.exy - dct_indep::gl_xy(g), 2);
        rho += b->mls_table().rho[q];
        ++m;
      }
      const double rms = std::sqrt(se / (3 * m));
      std::printf("| %d dots r=%g seed %llu | %d | %.2f | %.1f | %.5f | %.2f | %.3f |\n", pat.dots, pat.radius,
                  static_cast<unsigned long long>(pat.seed), n, rho / m / spacing, spacing, sd, 1e6 * rms,
                  rms * spacing / sd);
      std::fflush(stdout);
    }
  }
  return 0;
}

// The support suggestion applied (support.hpp): a first pass at the default support (32x32
// points) gives the noise, the dot spacing and the strain feature; the suggested support then
// measures the field again. Per deformation and pattern: the suggestion and the strain errors at
// the default and at the suggestion; for Kirsch's plate also e_yy at the hole edge at both
// (bias and noise over the noise draws).
struct Suggested {
  int dots = 0;
  double amplitude = 0, length = 0;
};
Suggested suggestion_for(const cv::Mat& ref, const cv::Mat& def, const std::string& backend, PipelineOptions o) {
  auto b = make_backend(backend, o);
  b->set_reference(ref);
  const FrameOutput out = b->process(def);
  const FrameUncertainty u = frame_uncertainty(ref, def, *b, out);
  const FrameSuggestion f = suggest_for_frame(*b, out, u, o.points_x, o.points_y);
  return {f.suggestion.dots, f.feature.amplitude, f.feature.length_px};
}

int auto_support(int argc, char** argv) {
  const std::string backend = argc > 2 ? argv[2] : "cpu-par";
  const int seeds = argc > 3 ? std::stoi(argv[3]) : 3;
  std::printf("| deformation | seed | feature [microstrain / px] | suggested | e_xx / e_yy / e_xy RMS at 200dots | "
              "max | at the suggestion | max |\n|---|---|---|---|---|---|---|---|\n");
  for (const char* d : {"tension", "bending", "rotation"})
    for (int seed = 1; seed <= seeds; ++seed) {
      const dct_indep::Scene s = dct_indep::make_scene(params(d, seed));
      const cv::Mat ref = dct_indep::finish(dct_indep::render_clean(s, false), s.p.noise, 2 * seed);
      const cv::Mat def = dct_indep::finish(dct_indep::render_clean(s, true), s.p.noise, 2 * seed + 1);
      const Suggested sg = suggestion_for(ref, def, backend, PipelineOptions{});
      PipelineOptions o;
      const Errors e0 = measure(s, backend, o, seed);
      o.mls.support = parse_support(std::to_string(sg.dots) + "dots");
      const Errors e1 = measure(s, backend, o, seed);
      std::printf("| %s | %d | %.0f / %.0f | %ddots | %.1f / %.1f / %.1f | %.1f | %.1f / %.1f / %.1f | %.1f |\n", d, seed,
                  1e6 * sg.amplitude, sg.length, sg.dots, 1e6 * e0.exx, 1e6 * e0.eyy, 1e6 * e0.exy, 1e6 * e0.e_max,
                  1e6 * e1.exx, 1e6 * e1.eyy, 1e6 * e1.exy, 1e6 * e1.e_max);
      std::fflush(stdout);
    }
  // Kirsch: the suggestion from the first draw's 32x32 field, then the hole edge at it.
  const dct_indep::Scene s = dct_indep::make_scene(kirsch_params());
  const cv::Mat ref = dct_indep::finish(dct_indep::render_clean(s, false), s.p.noise, 500);
  const cv::Mat def = dct_indep::finish(dct_indep::render_clean(s, true), s.p.noise, 501);
  PipelineOptions o;
  o.analysis.max_area = 2000;
  const Suggested sg = suggestion_for(ref, def, backend, o);
  const std::string sup = std::to_string(sg.dots) + "dots";
  const auto r = kirsch_edge(backend, {"200dots", sup}, Interp::mls, 10);
  std::printf("\nKirsch (feature %.0f microstrain over %.0f px): suggested %s; e_yy at the hole edge (%.0f microstrain), "
              "10 draws:\n| support | bias [%%] | noise [%%] | RMS [%%] |\n|---|---|---|---|\n",
              1e6 * sg.amplitude, sg.length, sup.c_str(), 1e6 * r[0].truth);
  for (std::size_t k = 0; k < r.size(); ++k)
    std::printf("| %s | %+.2f | %.2f | %.2f |\n", k ? sup.c_str() : "200dots", 100 * r[k].bias / r[k].truth,
                100 * r[k].noise / r[k].truth, 100 * r[k].rms / r[k].truth);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "";
  try {
    if (mode == "fields") return fields(argc, argv);
    if (mode == "sigma") return sigma(argc, argv);
    if (mode == "fe-ratio") return fe_ratio(argc, argv);
    if (mode == "fe-sd") return fe_sd(argc, argv);
    if (mode == "auto-support") return auto_support(argc, argv);
    if (mode == "kirsch") return kirsch(argc, argv);
    if (mode == "support-noise") return support_noise(argc, argv);
    if (mode == "centroids") return centroids(argc > 2 ? std::stoi(argv[2]) : AnalysisOptions{}.margin);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dct_quality: %s\n", e.what());
    return 2;
  }
  std::fprintf(stderr, "usage: dct_quality fields [backend] [support] [mls|fe] [seeds] [weight] | fe-ratio [backend] [support] [seeds] | fe-sd [support] [seeds] | auto-support [backend] [seeds] | "
                       "centroids [margin] | sigma [backend] [support] [mls|fe] [runs] | kirsch [backend] [seeds] [mls|fe] [support...] | "
                       "support-noise [backend]\n");
  return 2;
}
