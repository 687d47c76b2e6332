// The support suggestion (workloads/dct/support.hpp): its model against the figures measured on
// independent renders (results/dct-quality/support.md), the feature estimate on fields of known
// shape, and bad input.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "model/errors.hpp"
#include "workloads/dct/support.hpp"

namespace dtflop::dct {
namespace {

TEST(DctSupport, RefusesWhatItCannotUse) {
  EXPECT_THROW(suggest_support(0, 20, 500), InputError);
  EXPECT_THROW(suggest_support(std::nan(""), 20, 500), InputError);
  EXPECT_THROW(suggest_support(0.004, -1, 500), InputError);
  EXPECT_THROW(suggest_support(0.004, 20, 5), InputError);
}

TEST(DctSupport, TablesAreMeasuredShapes) {
  const auto& t = support_noise_table();
  ASSERT_GE(t.size(), 8u);
  for (std::size_t i = 1; i < t.size(); ++i) {
    EXPECT_GT(t[i].dots, t[i - 1].dots);
    EXPECT_LT(t[i].noise_factor, t[i - 1].noise_factor);      // more dots, less noise
    EXPECT_GT(t[i].radius_spacings, t[i - 1].radius_spacings);
  }
  const auto& b = support_bias_table();
  ASSERT_GE(b.size(), 3u);
  for (std::size_t i = 1; i < b.size(); ++i) EXPECT_GT(b[i].relative_bias, b[i - 1].relative_bias);
}

// Without a feature the whole error is noise: the largest support the table (or the pattern)
// allows. The noise is proportional to the displacement deviation.
TEST(DctSupport, NoFeatureTakesTheLargestSupport) {
  EXPECT_EQ(suggest_support(0.0045, 34, 1000).dots, support_noise_table().back().dots);
  EXPECT_EQ(suggest_support(0.0045, 34, 150).dots, 150);
  EXPECT_NEAR(support_error(90, 0.002, 30, {}).noise, 0.5 * support_error(90, 0.004, 30, {}).noise, 1e-15);
}

// The model against what was measured (results/dct-quality/): the default renders (500 dots of
// radius 7, spacing ~33 px, displacement sd ~0.0045 px) read 5.6-7.3 microstrain at 200 dots
// under tension; Kirsch's hole edge (spacing ~16 px, sd ~0.0044 px, amplitude 4000
// microstrain over 2a/7 = 85.7 px) read a total of 96 microstrain at 60 dots, 59 at 90 and 531
// at 200, the least at 90 of the supports tried.
TEST(DctSupport, ModelReproducesTheMeasurements) {
  EXPECT_NEAR(support_error(200, 0.0045, 33, {}).noise, 6.5e-6, 2e-6);
  const StrainFeature hole{4000e-6, 85.7};
  const double at60 = support_error(60, 0.0044, 15.9, hole).total, at200 = support_error(200, 0.0044, 15.9, hole).total;
  EXPECT_GT(at60, 96e-6 / 2);
  EXPECT_LT(at60, 96e-6 * 2);
  EXPECT_GT(at200, 531e-6 / 2);
  EXPECT_LT(at200, 531e-6 * 2);
  const SupportSuggestion s = suggest_support(0.0044, 15.9, 2400, hole);
  EXPECT_GE(s.dots, 45);
  EXPECT_LE(s.dots, 120);
  // A shorter feature asks for a smaller support, more noise for a larger one.
  EXPECT_LT(suggest_support(0.0044, 15.9, 2400, {4000e-6, 40}).dots, s.dots);
  EXPECT_GT(suggest_support(0.0088, 15.9, 2400, hole).dots, s.dots);
}

// A Gaussian bump in e_yy, amplitude A and width w: amplitude A, steepest gradient
// A e^(-1/2) / w, so length w e^(1/2). Pure noise: no feature.
TEST(DctSupport, FeatureOfAKnownField) {
  const int nx = 41, ny = 31;
  const double h = 10, w = 50, A = 2e-3;
  std::vector<Vec2> pts;
  std::vector<FieldValue<double>> f;
  std::vector<FieldSigma> sd;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0, 5e-6);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      pts.push_back({i * h, j * h});
      FieldValue<double> v;
      const double r2 = std::pow(i * h - 200, 2) + std::pow(j * h - 150, 2);
      v.eyy = A * std::exp(-r2 / (2 * w * w)) + noise(rng);
      v.exx = noise(rng);
      v.exy = noise(rng);
      f.push_back(v);
      sd.push_back({1e-3, 1e-3, 5e-6, 5e-6, 5e-6});
    }
  const StrainFeature e = estimate_feature(pts, f, sd, nx, ny);
  EXPECT_NEAR(e.amplitude, A, 0.02 * A);
  EXPECT_NEAR(e.length_px, w * std::exp(0.5), 0.1 * w * std::exp(0.5));
  for (auto& v : f) v.eyy = noise(rng);
  EXPECT_EQ(estimate_feature(pts, f, sd, nx, ny).length_px, 0);
  EXPECT_EQ(estimate_feature(pts, f, sd, nx + 1, ny).length_px, 0);  // not that grid
}

}  // namespace
}  // namespace dtflop::dct
