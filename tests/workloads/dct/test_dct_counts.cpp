// The backends' declared CostCounts against the formulas of counts.hpp, worked out by hand
// for one shape, and the shape a real run reports against what the run did.
#include <gtest/gtest.h>

#include "model/errors.hpp"
#include "workloads/dct/backend.hpp"
#include "workloads/dct/counts.hpp"
#include "workloads/dct/specimen.hpp"

namespace dtflop::dct {
namespace {

FrameShape hand_shape() {
  FrameShape s;
  s.image_pixels = 6000 * 4000;
  s.bytes_per_pixel = 1;
  s.roi_pixels = 5000 * 4000;
  s.foreground_pixels = 3'000'000;
  s.components = 1700;
  s.dots = 1600;
  s.window_pixels = 7'000'000;
  s.ring_pixels = 2'000'000;
  s.weighted_pixels = 4'500'000;
  s.scanned_pixels = 2'500'000;
  s.points = 2048;
  s.support_entries = 2048 * 60;
  s.interp = Interp::mls;
  s.otsu = true;
  return s;
}

TEST(DctCounts, CpuMatchesFormulas) {
  const FrameShape s = hand_shape();
  const CostCounts c = cpu_counts(s, 16);
  // 14 ring + 11 weighted + (44 + 4) per dot + 2 per dot + 341 per support entry + 207 per point.
  EXPECT_EQ(c.N_C, 14LL * 2'000'000 + 11LL * 4'500'000 + 48LL * 1600 + 2LL * 1600 + 341LL * 2048 * 60 + 221LL * 2048);
  // Bytes: Otsu 1 + threshold 2 + labelling 13 per analysed pixel, 10 per window pixel, 25
  // labels of 4 bytes per scanned pixel, a byte per ring or weighted pixel, 8 per field value.
  EXPECT_EQ(c.N_CC, (16LL * 20'000'000 + 10LL * 7'000'000 + 100LL * 2'500'000 + 6'500'000 +
                     8 * (5LL * 2048 * 60 + 8LL * 2048)) / 8);
  EXPECT_EQ(c.cpu_footprint, 6LL * 20'000'000 + 8 * (5LL * 2048 * 60 + 8LL * 2048));
  EXPECT_EQ(c.P, 8);
  EXPECT_EQ(c.precision, Precision::fp64);
  EXPECT_EQ(c.cpu_threads, 16);
  EXPECT_EQ(c.N_CG + c.N_GC + c.N_GG + c.N_G + c.launches, 0);
  EXPECT_EQ(cpu_counts(s, 0).cpu_threads, 1);
  // 16-bit frames: twice the pixel reads, a 16-bit mask converted to 8 bits.
  FrameShape w = s;
  w.bytes_per_pixel = 2;
  EXPECT_EQ(cpu_counts(w, 1).N_CC - c.N_CC, (20'000'000LL * (2 - 1) + 20'000'000LL * (7 - 2) + 6'500'000) / 8);
}

TEST(DctCounts, CudaMatchesFormulas) {
  FrameShape s = hand_shape();
  const CostCounts c = cuda_counts(s, HostMemory::pinned);
  EXPECT_EQ(c.N_CG, 20'000'000 / 4 + 1600);
  EXPECT_EQ(c.transfers_CG, 2);
  // Count and Otsu threshold (4 bytes each), 7 arrays of component records (x, y as doubles,
  // weight, status, area, root, 3 pixel counts: 44 bytes a component), the fields.
  const std::int64_t field = sizeof(FieldValue<float>);
  EXPECT_EQ(c.N_GC, (4 + 4 + 44 * 1700 + field * 2048) / 4);
  EXPECT_EQ(c.transfers_GC, 10);
  EXPECT_EQ(c.copies_GC, (std::vector<CopySize>{{4, 2}, {8 * 1700, 2}, {4 * 1700, 4}, {12 * 1700, 1}, {field * 2048, 1}}));
  EXPECT_EQ(c.host_waits, 3);
  const std::int64_t roi = 20'000'000, rv = roi / 4;
  EXPECT_EQ(c.N_GG, rv + roi + 5 * roi + 2 * 3'000'000 + roi + 1700 + 2 * roi + 2 * 7'000'000 + 2 * 4'500'000 +
                        6 * 1600 + 5 * 2048 * 60 + 8 * 2048 + rv + 512);
  EXPECT_EQ(c.N_G, cpu_counts(s, 1).N_C);  // the same arithmetic, in float32
  EXPECT_EQ(c.N_C, 0);
  EXPECT_EQ(c.launches, 11);
  EXPECT_EQ(c.P, 4);
  EXPECT_EQ(c.host_memory, HostMemory::pinned);
  s.otsu = false;
  s.interp = Interp::fe;
  s.support_entries = 2048 * 90;  // FE: recovery triangles
  const CostCounts f = cuda_counts(s, HostMemory::pageable);
  EXPECT_EQ(f.launches, 9);
  EXPECT_EQ(f.transfers_GC, 9);  // no threshold to read back
  // Per recovery triangle 20 + 8 + 1 FLOPs; per point its own triangle (10), 1 / s and the
  // scaling (5), the Green-Lagrange strain (16).
  EXPECT_EQ(f.N_G, 14LL * 2'000'000 + 11LL * 4'500'000 + 50LL * 1600 + 29LL * 2048 * 90 + 31LL * 2048);
  EXPECT_EQ(f.host_memory, HostMemory::pageable);
  // 16-bit frames: twice the bytes uploaded.
  s.bytes_per_pixel = 2;
  EXPECT_EQ(cuda_counts(s, HostMemory::pinned).N_CG, 20'000'000 / 2 + 1600);
  // An upload that is not whole 4-byte values counts its last, partial value.
  s.bytes_per_pixel = 1;
  s.roi_pixels = 641 * 481;
  EXPECT_EQ(cuda_counts(s, HostMemory::pinned).N_CG, (641 * 481 + 3) / 4 + 1600);
}

TEST(DctCounts, EstimateIsCloseToAMeasuredRun) {
  // The shape a cpu-seq run reports is the run's own; the estimate from dot size alone is
  // within 15% of it on window and weighted pixels.
  const Specimen sp = parse_specimen("uniform:size=640x480,pattern=grid,radius=8,pitch=30");
  PipelineOptions o;
  o.mls.support = parse_support("30dots");
  o.points_x = 8;
  o.points_y = 6;
  auto b = make_backend("cpu-seq", o);
  b->set_reference(sp.reference_image());
  const FrameOutput out = b->process(sp.deformed_image());
  const FrameShape& m = out.shape;
  EXPECT_EQ(m.dots, static_cast<std::int64_t>(sp.dots.size()));
  EXPECT_EQ(m.points, 48);
  EXPECT_EQ(m.support_entries, 48 * 30);
  EXPECT_EQ(m.roi_pixels, 640 * 480);
  EXPECT_EQ(m.window_pixels, m.ring_pixels + m.weighted_pixels + 0);  // isolated dots: nothing ignored
  EXPECT_EQ(out.counts, cpu_counts(m, 1));
  const FrameShape e = estimate_shape(640, 480, 1, m.dots, 8, 48, 30, Interp::mls);
  EXPECT_NEAR(static_cast<double>(e.window_pixels), static_cast<double>(m.window_pixels), 0.15 * static_cast<double>(m.window_pixels));
  EXPECT_NEAR(static_cast<double>(e.weighted_pixels), static_cast<double>(m.weighted_pixels), 0.15 * static_cast<double>(m.weighted_pixels));
  EXPECT_THROW(estimate_shape(0, 480, 1, 10, 8, 48, 30, Interp::mls), InputError);
}

}  // namespace
}  // namespace dtflop::dct

namespace dtflop::dct {
namespace {

// The matching's k-d tree steps, written out by hand for 25 reference dots on a 5 x 5 grid: a tree
// of 25 points has 1 + ceil(log2(25 / 10)) = 3 levels, so a build is 25 x 3 = 75 steps and a search
// for the 2 nearest 3 + 10 + 2 = 15.
TEST(DctTreeSteps, MatchDotsReportsWhatTheFormulaCounts) {
  EXPECT_EQ(tree_build_steps(25), 75);
  EXPECT_EQ(tree_search_steps(25, 2), 15);
  EXPECT_EQ(tree_build_steps(10), 10);   // one leaf: one level
  EXPECT_EQ(tree_build_steps(11), 22);   // two leaves: two levels
  std::vector<Vec2> ref, def;
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 5; ++x) {
      ref.push_back({20.0 * x, 20.0 * y});
      def.push_back({20.0 * x + 0.5, 20.0 * y - 0.25});
    }
  MatchOptions o;
  o.search_radius = 8;  // given, as the pipeline gives it: no tree over the reference
  Matches m = match_dots(ref, def, o);
  EXPECT_EQ(m.matched, 25);
  EXPECT_EQ(m.tree_steps, 75 + 25 * 15);
  EXPECT_EQ(m.tree_steps, match_tree_steps(25, 25));
  // Without a radius, the reference's own tree and searches come first.
  o.search_radius = 0;
  m = match_dots(ref, def, o);
  EXPECT_EQ(m.tree_steps, 2 * (75 + 25 * 15));
  EXPECT_EQ(m.tree_steps, match_tree_steps(25, 25, 0, 0, o.refine_neighbours, false));
  // Three dots lost (moved away): the refining pass builds the reference tree and searches again.
  def[3] = {500, 500};
  def[7] = {600, 600};
  def[11] = {700, 700};
  o.search_radius = 8;
  m = match_dots(ref, def, o);
  EXPECT_EQ(m.matched, 22);
  EXPECT_EQ(m.tree_steps, match_tree_steps(25, 25, 3, 3, o.refine_neighbours));
}

}  // namespace
}  // namespace dtflop::dct
