// The renderer's truth: closed forms against the checks of docs/design.md, strain against the
// displacement's own derivatives, exact pre-images, exact area coverage, patterns' gaps.
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "model/errors.hpp"
#include "workloads/dct/specimen.hpp"
#include "workloads/dct/tracking.hpp"

namespace dtflop::dct {
namespace {

Gradient numeric_gradient(const Deformation& d, Vec2 X, double h) {
  const Vec2 px = d.displacement({X.x + h, X.y}), mx = d.displacement({X.x - h, X.y});
  const Vec2 py = d.displacement({X.x, X.y + h}), my = d.displacement({X.x, X.y - h});
  return {(px.x - mx.x) / (2 * h), (py.x - my.x) / (2 * h), (px.y - mx.y) / (2 * h), (py.y - my.y) / (2 * h)};
}

TEST(DctKirsch, ClosedFormChecksFromDesign) {
  // E = 210 GPa, nu = 0.3, T = 100 MPa: e0 = T / E.
  const double e0 = 100.0 / 210000.0, a = 50;
  const auto k = make_kirsch({0, 0}, a, e0, 0.3);
  const Strain top = small_strain_of(k->gradient({0, a}));
  EXPECT_NEAR(top.xx, 1.4286e-3, 1e-7);   // sigma_xx / T = 3 at (0, a)
  EXPECT_NEAR(top.yy, -4.286e-4, 1e-7);
  const Strain side = small_strain_of(k->gradient({a, 0}));   // sigma_yy / T = -1 at (a, 0): e_xx = nu e0
  EXPECT_NEAR(side.xx, 0.3 * e0, 1e-9);
  EXPECT_NEAR(side.yy, -e0, 1e-9);
  // Far field: u_x -> T x / E, u_y -> -nu T y / E.
  const Vec2 far = k->displacement({1e5 * a, 0});
  EXPECT_NEAR(far.x / (1e5 * a), e0, 1e-9);
  const Vec2 farY = k->displacement({0, 1e5 * a});
  EXPECT_NEAR(farY.y / (1e5 * a), -0.3 * e0, 1e-9);
  // Load along y: the concentration moves to (a, 0).
  const auto ky = make_kirsch({0, 0}, a, e0, 0.3, true);
  EXPECT_NEAR(ky->gradient({a, 0}).uy_y, 1.4286e-3, 1e-7);
}

TEST(DctDeformations, StrainIsTheDisplacementsDerivative) {
  const Vec2 c{400, 300};
  std::vector<std::unique_ptr<Deformation>> defs;
  defs.push_back(make_translation(1.5, -0.7));
  defs.push_back(make_rotation(c, 0.01));
  defs.push_back(make_uniform(c, 1e-3, -3e-4, 2e-4));
  defs.push_back(make_bending(c, 2e-6, 0.3));
  defs.push_back(make_kirsch(c, 80, 1e-3, 0.3));
  defs.push_back(make_kirsch(c, 80, 1e-3, 0.25, true));
  for (const auto& d : defs)
    for (Vec2 X : {Vec2{100, 50}, Vec2{520, 310}, Vec2{400, 390}, Vec2{333, 222}}) {
      const Gradient g = d->gradient(X), n = numeric_gradient(*d, X, 1e-3);
      EXPECT_NEAR(g.ux_x, n.ux_x, 1e-8) << d->describe();
      EXPECT_NEAR(g.ux_y, n.ux_y, 1e-8) << d->describe();
      EXPECT_NEAR(g.uy_x, n.uy_x, 1e-8) << d->describe();
      EXPECT_NEAR(g.uy_y, n.uy_y, 1e-8) << d->describe();
      const auto back = d->inverse(d->map(X));
      ASSERT_TRUE(back.has_value());
      EXPECT_NEAR(back->x, X.x, 1e-9);
      EXPECT_NEAR(back->y, X.y, 1e-9);
    }
}

TEST(DctRender, CoverageIsExactArea) {
  // Noiseless dark dots: sum of (ground - I) / (ground - ink) is the dots' total area,
  // within 8-bit rounding (+-0.5 grey level per pixel, mean zero).
  RenderOptions o;
  o.width = 320;
  o.height = 240;
  o.ground = 250;
  o.ink = 10;
  o.bit_depth = 16;
  const auto dots = grid_pattern({20, 20, 300, 220, {}, 0}, 40, 11.3);
  const cv::Mat img = render(dots, *make_uniform({160, 120}, 2e-3, -6e-4), o);
  ASSERT_EQ(img.type(), CV_16UC1);
  double sum = 0;
  for (int i = 0; i < img.rows; ++i)
    for (int j = 0; j < img.cols; ++j) sum += (250.0 * 257 - img.at<std::uint16_t>(i, j)) / (240.0 * 257);
  // Area of a deformed disc: pi r^2 det(F).
  const double expected = static_cast<double>(dots.size()) * M_PI * 11.3 * 11.3 * (1 + 2e-3) * (1 - 6e-4);
  EXPECT_NEAR(sum, expected, 1e-3 * expected);
}

TEST(DctPatterns, GapsAndCounts) {
  const PatternArea area{0, 0, 500, 400, Vec2{250, 200}, 60};
  const auto r = random_pattern(area, 5, 4, 300, 7);
  ASSERT_EQ(r.size(), 300u);
  std::vector<Vec2> c;
  for (const auto& d : r) {
    c.push_back(d.centre);
    EXPECT_GE(std::hypot(d.centre.x - 250, d.centre.y - 200), 65 - 1e-9);
  }
  PointIndex idx(c);
  std::vector<std::uint32_t> k;
  std::vector<double> d2;
  for (const auto& p : c) {
    idx.knn(p, 2, k, d2);
    EXPECT_GE(std::sqrt(d2[1]), 2 * 5 + 4 - 1e-9);
  }
  const auto g = graded_pattern({0, 0, 600, 600, {}, 0}, {{300, 300}, 14, 40, 3, 8, 250}, 3);
  int near = 0, far = 0;
  for (const auto& d : g) (std::hypot(d.centre.x - 300, d.centre.y - 300) < 100 ? near : far) += 1;
  // Denser near the focus: per unit area at least 2x.
  EXPECT_GT(near / (M_PI * 100 * 100), 2 * far / (600.0 * 600 - M_PI * 100 * 100));
  EXPECT_THROW(random_pattern(area, 5, 4, 3000, 1), InputError);
  EXPECT_THROW(grid_pattern(area, 8, 5), InputError);
}

TEST(DctSpecimen, ParsesAndRejects) {
  const Specimen s = parse_specimen("kirsch:size=400x300,a=40,strain=1e-3,radius=4,pitch=14");
  EXPECT_GT(s.dots.size(), 100u);
  for (const auto& d : s.dots) EXPECT_GE(std::hypot(d.centre.x - 199.5, d.centre.y - 149.5), 40 + 4);
  EXPECT_THROW(parse_specimen("kirsch:size=400x300,colour=red"), InputError);
  EXPECT_THROW(parse_specimen("twist:size=400x300"), InputError);
  EXPECT_THROW(parse_specimen("uniform:size=40000x300"), InputError);
  EXPECT_THROW(parse_specimen("uniform:bits=12"), InputError);
  EXPECT_THROW(parse_specimen("uniform:strain=abc"), InputError);
}

}  // namespace
}  // namespace dtflop::dct
