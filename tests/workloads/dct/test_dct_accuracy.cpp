// End-to-end accuracy against the renderer's closed forms: images -> dots -> tracking ->
// fields (cpu-seq, float64). The targets: 0.1% uniform tension with ~60 dots per
// support within 20 microstrain RMS; Kirsch's e_yy at the hole edge within 5%, with the
// field's error map written as an image.
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "model/errors.hpp"
#include "workloads/dct/backend.hpp"
#include "workloads/dct/io.hpp"
#include "workloads/dct/specimen.hpp"

namespace dtflop::dct {
namespace {

struct FieldErrors {
  double u_rms = 0, e_rms = 0, e_max = 0;
  int valid = 0;
};

FieldErrors errors_against(const Specimen& s, const std::vector<Vec2>& pts, const std::vector<FieldValue<double>>& f) {
  FieldErrors r;
  double su = 0, se = 0;
  for (std::size_t m = 0; m < pts.size(); ++m) {
    if (f[m].status != PointStatus::ok) continue;
    const Vec2 u = s.deformation->displacement(pts[m]);
    const Strain e = s.deformation->strain(pts[m]);
    su += std::pow(f[m].ux - u.x, 2) + std::pow(f[m].uy - u.y, 2);
    for (double d : {f[m].exx - e.xx, f[m].eyy - e.yy, f[m].exy - e.xy}) {
      se += d * d;
      r.e_max = std::max(r.e_max, std::abs(d));
    }
    ++r.valid;
  }
  if (r.valid) {
    r.u_rms = std::sqrt(su / (2 * r.valid));
    r.e_rms = std::sqrt(se / (3 * r.valid));
  }
  return r;
}

FrameOutput run_pipeline(const Specimen& s, PipelineOptions o, const std::string& backend = "cpu-seq") {
  auto b = make_backend(backend, o);
  b->set_reference(s.reference_image());
  return b->process(s.deformed_image());
}

TEST(DctAccuracy, UniformTensionWithin20Microstrain) {
  // 0.1% tension along x with Poisson contraction; ~60 dots per support domain.
  const Specimen s = parse_specimen("uniform:size=1300x1000,strain=1e-3,nu=0.3,pattern=random,radius=10,gap=9,seed=3");
  PipelineOptions o;
  o.mls.support = parse_support("60dots");
  o.points_x = 16;
  o.points_y = 12;
  o.points_inset = 60;
  const FrameOutput out = run_pipeline(s, o);
  EXPECT_EQ(out.matches.matched, static_cast<int>(s.dots.size()));
  const FieldErrors e = errors_against(s, out.matches.matched ? std::vector<Vec2>(grid_points_over(s.reference_centres(), 16, 12, 60)) : std::vector<Vec2>{}, out.fields);
  EXPECT_EQ(e.valid, 16 * 12);
  std::printf("uniform 0.1%%: %zu dots, strain RMS error %.2f microstrain (max %.2f), u RMS %.5f px\n", s.dots.size(),
              e.e_rms * 1e6, e.e_max * 1e6, e.u_rms);
  EXPECT_LE(e.e_rms, 20e-6);
  EXPECT_LE(e.u_rms, 0.01);
  // FE on the same frame: valid, its recovered strain (over the support's triangles) near MLS's.
  o.interp = Interp::fe;
  const FrameOutput fe = run_pipeline(s, o);
  const FieldErrors ef = errors_against(s, grid_points_over(s.reference_centres(), 16, 12, 60), fe.fields);
  std::printf("uniform 0.1%% FE: strain RMS error %.2f microstrain\n", ef.e_rms * 1e6);
  EXPECT_GT(ef.valid, 16 * 12 * 9 / 10);
  EXPECT_LE(ef.e_rms, 2 * e.e_rms);
}

TEST(DctAccuracy, RigidMotionsAndBending) {
  for (const char* spec : {"translation:size=500x400,dx=0.37,dy=-0.81,radius=6",
                           "rotation:size=500x400,deg=0.3,radius=6",
                           "bending:size=500x400,k=4e-6,nu=0.3,radius=6"}) {
    const Specimen s = parse_specimen(spec);
    PipelineOptions o;
    o.mls.support = parse_support("40dots");
    o.points_x = o.points_y = 10;
    o.points_inset = 30;
    const FrameOutput out = run_pipeline(s, o);
    const FieldErrors e = errors_against(s, grid_points_over(s.reference_centres(), 10, 10, 30), out.fields);
    std::printf("%s: u RMS %.5f px, strain RMS %.2f microstrain\n", spec, e.u_rms, e.e_rms * 1e6);
    EXPECT_EQ(e.valid, 100) << spec;
    EXPECT_LE(e.u_rms, 0.005) << spec;
    EXPECT_LE(e.e_rms, 30e-6) << spec;
  }
}

TEST(DctAccuracy, KirschHoleEdgeWithinFivePercent) {
  // Load along y; the concentration is at (a, 0) from the centre: e_yy = 3 e0 there. The
  // image covers the region beside that edge point at a scale where a support of 20 dots
  // spans a small arc of the hole.
  const double a = 600, e0 = 2e-3, nu = 0.3;
  Specimen s;
  s.render.width = 560;
  s.render.height = 600;
  const Vec2 centre{60 - a, 300};
  s.deformation = make_kirsch(centre, a, e0, nu, true);
  s.hole = std::make_pair(centre, a);
  PatternArea area{8, 8, 552, 592, centre, a + 6};
  s.dots = grid_pattern(area, 17, 5.5);
  PipelineOptions o;
  o.mls.support = parse_support("20dots");
  o.analysis.max_area = 2000;
  const Vec2 edge{centre.x + a, centre.y};
  o.points = grid_points(edge.x, edge.y - 240, edge.x + 440, edge.y + 240, 23, 25);
  o.points.push_back(edge);
  const FrameOutput out = run_pipeline(s, o);
  const auto& f = out.fields.back();
  ASSERT_EQ(f.status, PointStatus::ok);
  const double truth = s.deformation->strain(edge).yy;
  EXPECT_NEAR(small_strain_of(s.deformation->gradient(edge)).yy, 3 * e0, 1e-12);  // truth: Green-Lagrange's
  std::printf("Kirsch e_yy at the hole edge: %.1f microstrain (closed form %.1f, error %.2f%%)\n", f.eyy * 1e6,
              truth * 1e6, 100 * (f.eyy - truth) / truth);
  EXPECT_NEAR(f.eyy, truth, 0.05 * truth);
  // Error map of e_yy over the grid (microstrain), written beside the test binary.
  std::vector<double> err;
  for (std::size_t m = 0; m + 1 < o.points.size(); ++m)
    err.push_back(out.fields[m].status == PointStatus::ok ? (out.fields[m].eyy - s.deformation->strain(o.points[m]).yy) * 1e6
                                                          : std::nan(""));
  const std::vector<Vec2> grid(o.points.begin(), o.points.end() - 1);
  const cv::Mat map = overlay(s.deformed_image(), grid, 23, 25, err, "e_yy error", "microstrain");
  const auto path = std::filesystem::path(DTFLOP_BINARY_DIR) / "test-output" / "dct_kirsch_eyy_error.png";
  write_image(path, map);
  EXPECT_TRUE(std::filesystem::file_size(path) > 1000);
}

}  // namespace
}  // namespace dtflop::dct
