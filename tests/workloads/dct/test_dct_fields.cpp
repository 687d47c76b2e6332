// MLS and FE on exact dot displacements: reproduction of the fields their bases contain,
// the status of points that cannot be estimated, and the look-up table.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <set>
#include <utility>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "model/errors.hpp"
#include "workloads/dct/fields.hpp"
#include "workloads/dct/specimen.hpp"

namespace dtflop::dct {
namespace {

std::vector<Vec2> random_dots(int n, std::uint64_t seed) {
  const auto d = random_pattern({0, 0, 600, 500, {}, 0}, 3, 4, n, seed);
  std::vector<Vec2> p;
  for (const auto& x : d) p.push_back(x.centre);
  return p;
}

// A quadratic displacement field with its exact derivatives.
struct Quadratic {
  double c[2][6];
  Vec2 u(Vec2 p) const {
    const double b[6] = {1, p.x, p.y, p.x * p.x, p.y * p.y, p.x * p.y};
    Vec2 r{};
    for (int i = 0; i < 6; ++i) { r.x += c[0][i] * b[i]; r.y += c[1][i] * b[i]; }
    return r;
  }
  Gradient g(Vec2 p) const {
    const double bx[6] = {0, 1, 0, 2 * p.x, 0, p.y}, by[6] = {0, 0, 1, 0, 2 * p.y, p.x};
    Gradient r{};
    for (int i = 0; i < 6; ++i) {
      r.ux_x += c[0][i] * bx[i]; r.ux_y += c[0][i] * by[i];
      r.uy_x += c[1][i] * bx[i]; r.uy_y += c[1][i] * by[i];
    }
    return r;
  }
};

TEST(DctMls, ReproducesQuadraticFieldsExactly) {
  const auto dots = random_dots(900, 5);
  const Quadratic q{{{0.3, 1e-3, -2e-4, 3e-6, -1e-6, 2e-6}, {-0.7, 4e-4, -3e-4, -2e-6, 5e-6, 1e-6}}};
  std::vector<Vec2> disp;
  for (const auto& p : dots) disp.push_back(q.u(p));
  const std::vector<std::uint8_t> tracked(dots.size(), 1);
  const auto pts = grid_points(80, 80, 520, 420, 9, 7);
  for (Weight w : {Weight::cubic_spline, Weight::quartic, Weight::gaussian})
    for (const char* sup : {"20dots", "60dots", "70px"}) {
      MlsOptions o;
      o.weight = w;
      o.support = parse_support(sup);
      const MlsTable t = build_mls_table(dots, pts, o);
      for (int threads : {1, 3}) {
        const auto f = evaluate_mls(t, dots, disp, tracked, o, threads);
        for (std::size_t m = 0; m < pts.size(); ++m) {
          ASSERT_EQ(f[m].status, PointStatus::ok) << to_string(w) << " " << sup;
          const Vec2 u = q.u(pts[m]);
          const Strain e = strain_of(q.g(pts[m]));
          EXPECT_NEAR(f[m].ux, u.x, 1e-9);
          EXPECT_NEAR(f[m].uy, u.y, 1e-9);
          EXPECT_NEAR(f[m].exx, e.xx, 1e-10) << to_string(w) << " " << sup;
          EXPECT_NEAR(f[m].eyy, e.yy, 1e-10);
          EXPECT_NEAR(f[m].exy, e.xy, 1e-10);
        }
      }
    }
}

TEST(DctMls, SupportByCountHoldsExactlyThatManyDots) {
  const auto dots = random_dots(600, 6);
  MlsOptions o;
  o.support = parse_support("37dots");
  const auto pts = grid_points(50, 50, 550, 450, 5, 5);
  const MlsTable t = build_mls_table(dots, pts, o);
  for (std::size_t m = 0; m < pts.size(); ++m) {
    EXPECT_EQ(t.offsets[m + 1] - t.offsets[m], 37);
    int inside = 0;
    for (const auto& d : dots) inside += std::hypot(d.x - pts[m].x, d.y - pts[m].y) < t.rho[m];
    EXPECT_EQ(inside, 37);
  }
  const auto f = evaluate_mls(t, dots, std::vector<Vec2>(dots.size()), std::vector<std::uint8_t>(dots.size(), 1), o);
  for (const auto& v : f) EXPECT_EQ(v.support, 37);
}

TEST(DctMls, MarksPointsItCannotEstimate) {
  // Dots on a line: A is singular (no y information).
  std::vector<Vec2> line;
  for (int i = 0; i < 40; ++i) line.push_back({10.0 * i, 100});
  MlsOptions o;
  o.support = parse_support("55px");
  o.max_gap = 0;  // off: only the algebra decides here
  const auto pts = grid_points(100, 100, 300, 100, 3, 1);
  const MlsTable t = build_mls_table(line, pts, o);
  const auto f = evaluate_mls(t, line, std::vector<Vec2>(line.size()), std::vector<std::uint8_t>(line.size(), 1), o);
  for (const auto& v : f) EXPECT_EQ(v.status, PointStatus::ill_conditioned);
  // Lost dots leave too few in the support.
  const auto dots = random_dots(400, 7);
  o.support = parse_support("10dots");
  o.max_gap = 2.5;
  const auto pts2 = grid_points(300, 250, 300, 250, 1, 1);
  const MlsTable t2 = build_mls_table(dots, pts2, o);
  std::vector<std::uint8_t> tracked(dots.size(), 1);
  for (int k = t2.offsets[0]; k < t2.offsets[0] + 5; ++k) tracked[t2.dots[k]] = 0;
  const auto f2 = evaluate_mls(t2, dots, std::vector<Vec2>(dots.size()), tracked, o);
  EXPECT_EQ(f2[0].status, PointStatus::too_few_dots);
  EXPECT_EQ(f2[0].support, 5);
  // A point far from every dot.
  const auto far = build_mls_table(dots, {Vec2{5000, 5000}}, o);
  EXPECT_EQ(far.geometry[0], PointStatus::far_from_dots);
  EXPECT_THROW(build_mls_table(std::vector<Vec2>(dots.begin(), dots.begin() + 5), pts2, o), InputError);
  EXPECT_THROW(parse_support("5dots"), InputError);
  EXPECT_THROW(parse_support("-2px"), InputError);
  EXPECT_THROW(parse_support("many"), InputError);
}

// The float32 MLS of the cuda backend, run on the host: the kernels.hpp arithmetic that
// k_mls runs, with its roundings (offsets from the point taken in double, then float;
// displacements as float, relative to the first tracked dot's).
std::vector<FieldValue<float>> evaluate_mls_float32(const MlsTable& t, const std::vector<Vec2>& reference,
                                                    const std::vector<Vec2>& disp, const MlsOptions& o) {
  std::vector<FieldValue<float>> out(t.points.size());
  for (std::size_t m = 0; m < t.points.size(); ++m) {
    const float inv = 1.f / static_cast<float>(t.rho[m]);
    const int k0 = t.offsets[m], k1 = t.offsets[m + 1];
    const float u0x = static_cast<float>(disp[t.dots[k0]].x), u0y = static_cast<float>(disp[t.dots[k0]].y);
    MlsPoint<float> mp;
    auto each_dot = [&](auto&& visit) {
      for (int k = k0; k < k1; ++k) {
        const int j = t.dots[k];
        visit(static_cast<float>(reference[j].x - t.points[m].x) * inv,
              static_cast<float>(reference[j].y - t.points[m].y) * inv, static_cast<float>(disp[j].x) - u0x,
              static_cast<float>(disp[j].y) - u0y);
      }
    };
    each_dot([&](float xi, float eta, float ux, float uy) { mp.add(o.weight, xi, eta, ux, uy); });
    out[m].status = mp.solve(o.min_dots, static_cast<float>(o.min_pivot_ratio));
    out[m].support = mp.n;
    if (out[m].status != PointStatus::ok) continue;
    each_dot([&](float xi, float eta, float ux, float uy) { mp.add_residual(o.weight, xi, eta, ux, uy); });
    out[m] = mp.field(static_cast<float>(t.rho[m]), u0x, u0y);
  }
  return out;
}

TEST(DctMls, Float32MatchesFloat64WhereTheWeightedFitIsIllConditioned) {
  // A Gaussian weight on a 45 px support over dots 14-20 px apart leaves a handful of dots
  // with weight: the moment matrix A = P' W P reaches condition numbers of 1e5, and float32
  // normal equations then differed from float64 by up to 2e-4 in strain. The factored form
  // (kernels.hpp) keeps float32 within 2e-6 of float64. The dots lie near x = 5000 px of a
  // 6000 x 4000 frame (offsets are taken from the point in double, so that costs nothing).
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0, 0.01);  // px, like centroid noise
  double worst = 0;
  int compared = 0, total = 0;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const auto d = random_pattern({4700, 1700, 5340, 2180, {}, 0}, 5, 4, 0, seed);
    std::vector<Vec2> dots, disp;
    for (const auto& x : d) {
      dots.push_back(x.centre);
      const double X = x.centre.x - 5000, Y = x.centre.y - 2000;
      disp.push_back({1.3 + 4e-4 * X - 1e-4 * Y + 2e-7 * X * Y + noise(rng),
                      -0.6 + 1e-4 * X + 3e-4 * Y - 1e-7 * X * X + noise(rng)});
    }
    const auto pts = grid_points_over(dots, 24, 18, 0);
    for (Weight w : {Weight::gaussian, Weight::cubic_spline, Weight::quartic})
      for (const char* sup : {"45px", "12dots"}) {
        MlsOptions o;
        o.weight = w;
        o.support = parse_support(sup);
        const MlsTable t = build_mls_table(dots, pts, o);
        const auto f64 = evaluate_mls(t, dots, disp, std::vector<std::uint8_t>(dots.size(), 1), o);
        const auto f32 = evaluate_mls_float32(t, dots, disp, o);
        for (std::size_t m = 0; m < pts.size(); ++m) {
          ++total;
          EXPECT_EQ(f64[m].support, f32[m].support) << "seed " << seed << " " << to_string(w) << " " << sup;
          if (f64[m].status != PointStatus::ok || f32[m].status != PointStatus::ok) {
            // Only a point on the conditioning limit may differ.
            if (f64[m].status != f32[m].status) {
              EXPECT_TRUE(f64[m].status == PointStatus::ill_conditioned ||
                          f32[m].status == PointStatus::ill_conditioned);
            }
            continue;
          }
          ++compared;
          EXPECT_NEAR(f32[m].ux, f64[m].ux, 1e-5) << "seed " << seed << " " << to_string(w) << " " << sup;
          EXPECT_NEAR(f32[m].uy, f64[m].uy, 1e-5) << "seed " << seed << " " << to_string(w) << " " << sup;
          for (auto [a, b] : {std::pair{f32[m].exx, f64[m].exx}, std::pair{f32[m].eyy, f64[m].eyy},
                              std::pair{f32[m].exy, f64[m].exy}}) {
            EXPECT_NEAR(a, b, 2e-6) << "seed " << seed << " " << to_string(w) << " " << sup << " point " << m;
            worst = std::max(worst, std::abs(a - b));
          }
        }
      }
  }
  EXPECT_GT(compared, total * 9 / 10);
  std::printf("float32 vs float64 MLS strain: max |de| %.2e over %d points\n", worst, compared);
}

TEST(DctFe, ReproducesLinearFieldsAndMarksTheHull) {
  const auto dots = random_dots(500, 8);
  std::vector<Vec2> disp;
  for (const auto& p : dots) disp.push_back({0.2 + 1e-3 * p.x - 3e-4 * p.y, -0.1 + 2e-4 * p.x - 5e-4 * p.y});
  std::vector<Vec2> pts = grid_points(60, 60, 540, 440, 11, 9);
  pts.push_back({-100, -100});  // outside
  for (const auto& d : std::vector<Vec2>(dots.begin(), dots.begin() + 5)) pts.push_back(d);  // on vertices
  const FeTable t = build_fe_table(dots, pts, 2.5);
  EXPECT_GT(t.triangles, 500);
  std::vector<std::uint8_t> tracked(dots.size(), 1);
  const auto f = evaluate_fe(t, disp, tracked);
  for (std::size_t m = 0; m < pts.size(); ++m) {
    if (m == 99) {
      EXPECT_NE(f[m].status, PointStatus::ok);
      continue;
    }
    ASSERT_EQ(f[m].status, PointStatus::ok) << m;
    EXPECT_NEAR(f[m].ux, 0.2 + 1e-3 * pts[m].x - 3e-4 * pts[m].y, 1e-9);
    // The recovered gradient of a linear field is exact; the strain is Green-Lagrange's.
    const Strain e = strain_of(Gradient{1e-3, -3e-4, 2e-4, -5e-4});
    EXPECT_NEAR(f[m].exx, e.xx, 1e-12);
    EXPECT_NEAR(f[m].eyy, e.yy, 1e-12);
    EXPECT_NEAR(f[m].exy, e.xy, 1e-12);
    EXPECT_GT(f[m].support, 10);  // the recovery's triangles, not one
  }
  // A lost dot in the recovery's support but not a vertex of the point's own triangle: the
  // point stays valid and, renormalised, still exact for a linear field.
  const int own[3] = {t.tri[0], t.tri[1], t.tri[2]};
  int lost = -1;
  for (int e = t.offsets[0]; e < t.offsets[1] && lost < 0; ++e)
    for (int k = 0; k < 3; ++k) {
      const int d = t.tri_dots[3 * static_cast<std::size_t>(t.support[e]) + k];
      if (d != own[0] && d != own[1] && d != own[2]) { lost = d; break; }
    }
  ASSERT_GE(lost, 0);
  tracked[lost] = 0;
  const auto g = evaluate_fe(t, disp, tracked);
  ASSERT_EQ(g[0].status, PointStatus::ok);
  EXPECT_LT(g[0].support, f[0].support);
  EXPECT_NEAR(g[0].exx, strain_of(Gradient{1e-3, -3e-4, 2e-4, -5e-4}).xx, 1e-12);
  tracked[lost] = 1;
  tracked[t.tri[0]] = 0;
  EXPECT_EQ(evaluate_fe(t, disp, tracked)[0].status, PointStatus::lost_vertex);
}

// The triangulation tiles the dots' convex hull: every Delaunay face once, so the triangles'
// areas add up to the hull's and every dot away from the hull is surrounded (its triangles'
// angles at it sum to 2 pi). Keeping a face only from an edge whose origin was its smallest dot
// lost a third of them (648 of 972 here); the recovery's noise grew with its support from the
// holes (docs/dct.md "FE").
TEST(DctFe, TrianglesTileTheHull) {
  const auto dots = random_dots(500, 8);
  const FeTable t = build_fe_table(dots, {Vec2{300, 250}}, 2.5);
  std::vector<cv::Point2f> pts, hull;
  for (const auto& d : dots) pts.emplace_back(static_cast<float>(d.x), static_cast<float>(d.y));
  cv::convexHull(pts, hull);
  const auto n = static_cast<std::int64_t>(dots.size()), h = static_cast<std::int64_t>(hull.size());
  ASSERT_EQ(static_cast<std::int64_t>(t.tri_dots.size()), 3 * t.triangles);
  // Euler: 2n - 2 - h triangles in a triangulation of n points with h on the hull. OpenCV's
  // subdivision may leave a few slivers along the hull to its outer vertices.
  EXPECT_LE(t.triangles, 2 * n - 2 - h);
  EXPECT_GE(t.triangles, 2 * n - 2 - h - 30);
  std::set<std::array<int, 3>> seen;
  std::vector<double> angle(dots.size(), 0.0);
  double area = 0;
  for (std::int64_t k = 0; k < t.triangles; ++k) {
    std::array<int, 3> v = {t.tri_dots[3 * k], t.tri_dots[3 * k + 1], t.tri_dots[3 * k + 2]};
    for (int i = 0; i < 3; ++i) {
      const Vec2 a = dots[v[i]], b = dots[v[(i + 1) % 3]], c = dots[v[(i + 2) % 3]];
      angle[v[i]] += std::abs(std::atan2((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x),
                                         (b.x - a.x) * (c.x - a.x) + (b.y - a.y) * (c.y - a.y)));
      if (i == 0) area += 0.5 * std::abs((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
    }
    std::sort(v.begin(), v.end());
    EXPECT_TRUE(seen.insert(v).second) << "triangle " << k << " twice";
  }
  const double hull_area = cv::contourArea(hull);
  EXPECT_GT(area, 0.98 * hull_area);
  EXPECT_LT(area, hull_area * (1 + 1e-6));
  int surrounded = 0, inner = 0;
  for (std::size_t j = 0; j < dots.size(); ++j) {
    const double d = cv::pointPolygonTest(hull, pts[j], true);
    if (d < 60) continue;  // away from the hull (~3 dot spacings)
    ++inner;
    surrounded += std::abs(angle[j] - 2 * 3.14159265358979) < 1e-6;
  }
  EXPECT_GT(inner, 250);
  EXPECT_EQ(surrounded, inner);
}

// A rigid rotation, however large, is no strain: Green-Lagrange's E = (F'F - I) / 2 is zero
// where the small-strain tensor reads cos t - 1 (-3.8e-3 at 5 deg). MLS and FE, float64.
TEST(DctFields, RigidRotationGivesZeroStrain) {
  const auto dots = random_dots(500, 8);
  const double t = 5 * 3.14159265358979 / 180, c = std::cos(t), s = std::sin(t);
  const Vec2 o{300, 250};
  std::vector<Vec2> disp;
  for (const auto& p : dots) {
    const double dx = p.x - o.x, dy = p.y - o.y;
    disp.push_back({c * dx - s * dy - dx, s * dx + c * dy - dy});
  }
  const std::vector<Vec2> pts = grid_points(150, 150, 450, 350, 5, 4);
  std::vector<std::uint8_t> tracked(dots.size(), 1);
  MlsOptions mo;
  mo.support = parse_support("40dots");
  const auto fm = evaluate_mls(build_mls_table(dots, pts, mo), dots, disp, tracked, mo);
  const auto ff = evaluate_fe(build_fe_table(dots, pts, 2.5, mo), disp, tracked);
  for (const auto* f : {&fm, &ff})
    for (const auto& v : *f) {
      ASSERT_EQ(v.status, PointStatus::ok);
      EXPECT_NEAR(v.exx, 0, 1e-12);
      EXPECT_NEAR(v.eyy, 0, 1e-12);
      EXPECT_NEAR(v.exy, 0, 1e-12);
    }
  EXPECT_NEAR(small_strain_of(Gradient{c - 1, -s, s, c - 1}).xx, -3.805e-3, 1e-6);  // what it used to read
}

TEST(DctKernels, WeightFunctionsMatchDesign) {
  auto check = [](Weight w, double s, double expect) {
    double v, d;
    weight_fn<double>(w, s, v, d);
    EXPECT_NEAR(v, expect, 1e-12) << to_string(w) << " s=" << s;
    // W'(s)/s against a central difference.
    const double h = 1e-6;
    double vp, vm, dd;
    weight_fn<double>(w, s + h, vp, dd);
    weight_fn<double>(w, s - h, vm, dd);
    EXPECT_NEAR(d * s, (vp - vm) / (2 * h), 1e-6);
  };
  for (double s : {0.1, 0.3, 0.5 - 1e-3, 0.7, 0.95}) {
    check(Weight::cubic_spline, s, s <= 0.5 ? 2.0 / 3 - 4 * s * s + 4 * s * s * s
                                            : 4.0 / 3 - 4 * s + 4 * s * s - 4.0 / 3 * s * s * s);
    check(Weight::quartic, s, 1 - 6 * s * s + 8 * s * s * s - 3 * s * s * s * s);
    const double e1 = std::exp(-1 / (kGaussAlpha * kGaussAlpha));
    check(Weight::gaussian, s, (std::exp(-s * s / (kGaussAlpha * kGaussAlpha)) - e1) / (1 - e1));
  }
  double v, d;
  weight_fn<double>(Weight::quartic, 1.0, v, d);
  EXPECT_EQ(v, 0);
}

}  // namespace
}  // namespace dtflop::dct
