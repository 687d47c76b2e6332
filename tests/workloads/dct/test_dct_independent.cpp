// The DCT workload against images from the independent renderer (independent_renderer/),
// which shares no code with workloads/dct.
#include <cmath>

#include <gtest/gtest.h>

#include "render.hpp"

namespace {

// The renderer itself: a disc's covered area and centroid, and Kirsch's closed form.
TEST(DctIndependentRenderer, DiscAreaAndCentroidExact) {
  dct_indep::Params p;
  p.width = 96;
  p.height = 96;
  p.dots = 1;
  p.noise = 0;
  p.deformation = "none";
  p.seed = 4;
  dct_indep::Scene s = dct_indep::make_scene(p);
  // Centred on a pixel's centre in x and on a pixel's edge in y: the pixel grid is then
  // symmetric about the dot, so its intensity-weighted centroid is exact. (Elsewhere the
  // pixels' partial coverage biases it by up to ~1e-3 px; that is the image, not the renderer.)
  s.dots = {{47, 47.5}};
  const cv::Mat img = dct_indep::render_clean(s, false);
  double a = 0, sx = 0, sy = 0;
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x) {
      const double c = (p.background - img.at<double>(y, x)) / (p.background - p.ink);
      a += c;
      sx += c * x;
      sy += c * y;
    }
  const double pi = 3.14159265358979323846;
  EXPECT_NEAR(a, pi * p.radius * p.radius, 1e-3);  // coverage error bound x ~100 edge pixels
  EXPECT_NEAR(sx / a, 47, 1e-9);  // pixel (c, r) centred on (c, r)
  EXPECT_NEAR(sy / a, 47.5, 1e-9);
}

TEST(DctIndependentRenderer, KirschConcentrationAndFarField) {
  dct_indep::Params p;
  p.deformation = "kirsch";
  p.dots = 10;
  const dct_indep::Scene s = dct_indep::make_scene(p);
  // Load along y: e_yy = 3 e0 at (+-a, 0) from the centre; the far field is uniaxial.
  for (double side : {-1.0, 1.0}) {
    const dct_indep::Grad g = s.field->grad({s.centre.x + side * p.hole, s.centre.y});
    EXPECT_NEAR(g.yy, 3 * p.strain, 1e-9);
  }
  const dct_indep::Grad far = s.field->grad({s.centre.x + 1e6, s.centre.y + 1e6});
  EXPECT_NEAR(far.yy, p.strain, 1e-8);
  EXPECT_NEAR(far.xx, -p.nu * p.strain, 1e-8);
}

}  // namespace
