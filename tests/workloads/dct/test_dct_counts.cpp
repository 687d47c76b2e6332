// The backends' declared CostCounts against the formulas of counts.hpp, worked out by hand
// for one shape, and the shape a real run reports against what the run did.
#include <gtest/gtest.h>

#include <cmath>
#include <utility>

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
  // Of them, the MLS fields' (support entries and points), priced at V_CM; FE has none.
  EXPECT_EQ(c.N_CM, 341LL * 2048 * 60 + 221LL * 2048);
  FrameShape fe = s;
  fe.interp = Interp::fe;
  EXPECT_EQ(cpu_counts(fe, 1).N_CM, 0);
  EXPECT_EQ(cuda_counts(s, HostMemory::pinned).N_CM, 0);  // the device's fields
  // Bytes: Otsu 1 + threshold 2 + labelling 13 per analysed pixel, 10 per window pixel, a byte
  // per ring or weighted pixel, 8 per field value streamed: a support entry's dot index, a
  // point's position, radius and 5 outputs (the dots' positions and displacements are gathered
  // from the caches).
  EXPECT_EQ(c.N_CC, (16LL * 20'000'000 + 10LL * 7'000'000 + 6'500'000 + 8 * (1LL * 2048 * 60 + 8LL * 2048)) / 8);
  // Scalar pixel steps: Otsu's histogram and the labelling, a step each per analysed pixel; one
  // per window pixel classified; the 5 x 5 labels read around each scanned pixel (margin 2).
  EXPECT_EQ(c.pixel_steps, 2LL * 20'000'000 + 7'000'000 + 25LL * 2'500'000);
  // Of them, the labelling's and the histogram's: a step per analysed pixel each, priced apart
  // where the profile can.
  EXPECT_EQ(c.label_steps, 20'000'000);
  EXPECT_EQ(c.hist_steps, 20'000'000);
  // Of N_CC, the pixel passes' (an 8-bit frame's, all but the fields'), which the kinds' figures
  // carry; one frame's passes.
  EXPECT_EQ(c.N_CC_pixel, (16LL * 20'000'000 + 10LL * 7'000'000 + 6'500'000) / 8);
  EXPECT_EQ(c.pixel_passes, 1);
  EXPECT_EQ(c.cpu_footprint, 6LL * 20'000'000 + 8 * (1LL * 2048 * 60 + 8LL * 2048));
  EXPECT_EQ(c.P, 8);
  EXPECT_EQ(c.precision, Precision::fp64);
  EXPECT_EQ(c.cpu_threads, 16);
  EXPECT_EQ(c.N_CG + c.N_GC + c.N_GG + c.N_G + c.launches, 0);
  EXPECT_EQ(cpu_counts(s, 0).cpu_threads, 1);
  // 16-bit frames: twice the pixel reads (the histogram's and the threshold's), the same 8-bit mask.
  FrameShape w = s;
  w.bytes_per_pixel = 2;
  EXPECT_EQ(cpu_counts(w, 1).N_CC - c.N_CC, (20'000'000LL * (2 - 1) + 20'000'000LL * (3 - 2) + 6'500'000) / 8);
  // ... and the same scalar steps: a 16-bit pixel is counted and labelled once, like an 8-bit one;
  // the probe's passes are 8-bit, so the wider bytes stay out of N_CC_pixel.
  EXPECT_EQ(cpu_counts(w, 1).pixel_steps, c.pixel_steps);
  EXPECT_EQ(cpu_counts(w, 1).N_CC_pixel, c.N_CC_pixel);
  // A wider centroid margin reads (2 margin + 1)^2 labels per scanned pixel.
  FrameShape m3 = s;
  m3.margin = 3;
  EXPECT_EQ(cpu_counts(m3, 1).pixel_steps, 2LL * 20'000'000 + 7'000'000 + 49LL * 2'500'000);
}

TEST(DctCounts, CudaMatchesFormulas) {
  FrameShape s = hand_shape();
  const CostCounts c = cuda_counts(s, HostMemory::pinned);
  EXPECT_EQ(c.N_CG, 20'000'000 / 4 + 1600);
  EXPECT_EQ(c.transfers_CG, 2);
  // Three copies back: count and Otsu threshold (4 bytes each), the component records (x, y as
  // doubles, weight, status, area, root, 3 pixel counts: 44 bytes a component), the fields.
  const std::int64_t field = sizeof(FieldValue<float>);
  EXPECT_EQ(c.N_GC, (4 + 4 + 44 * 1700 + field * 2048) / 4);
  EXPECT_EQ(c.transfers_GC, 3);
  EXPECT_EQ(c.copies_GC, (std::vector<CopySize>{{8, 1}, {44 * 1700, 1}, {field * 2048, 1}}));
  EXPECT_EQ(c.host_waits, 3);
  const std::int64_t roi = 20'000'000, rv = roi / 4;
  // The centroid kernel stages each window grown by the margin (2): 1600 mean windows of
  // sqrt(7e6 / 1600) = 66.14 px a side, 70.14 with the margin: 1600 x 70.14^2 = 7'872'240 labels.
  const std::int64_t stage = 7'872'240;
  EXPECT_EQ(cuda_centroid_stage_pixels(s), stage);
  EXPECT_EQ(c.N_GG, rv + roi + 5 * roi + 2 * 3'000'000 + roi + 1700 + 2 * roi + stage + 2'000'000 + 4'500'000 +
                        6 * 1600 + 2048 * 60 + 8 * 2048 + rv + 256);
  EXPECT_EQ(c.gpu_pixel_steps, 7'000'000);  // every window pixel classified in its dot's block
  // Six passes over the region, a thread a pixel: histogram, init, union, compress, ids, stats; their
  // values are the first rows of N_GG above and the histogram's read.
  EXPECT_EQ(c.gpu_frame_pixels, 6 * roi);
  EXPECT_EQ(c.N_GG_frame, rv + roi + 5 * roi + 2 * 3'000'000 + roi + 1700 + 2 * roi + rv);
  EXPECT_EQ(cpu_counts(s, 1).gpu_frame_pixels, 0);
  EXPECT_EQ(cpu_counts(s, 1).N_GG_frame, 0);
  EXPECT_EQ(cpu_counts(s, 1).gpu_pixel_steps, 0);
  EXPECT_EQ(c.N_G, cpu_counts(s, 1).N_C);  // the same arithmetic, in float32
  // One point's MLS chain, its thread's: 60 support dots at 341 FLOPs (the cubic spline) and the
  // point's own 221.
  EXPECT_EQ(c.N_GM, 60 * 341 + 221);
  FrameShape fe = s;
  fe.interp = Interp::fe;
  EXPECT_EQ(cuda_counts(fe, HostMemory::pinned).N_GM, 0);  // FE gives a point a warp: no chain
  // Working set: the 8-bit frame and its labels, 60 bytes of records a component, 29 a reference
  // dot, a point's position and field record, 4 bytes a support entry.
  EXPECT_EQ(c.gpu_footprint, roi * (1 + 4) + 60 * 1700 + 29 * 1600 + (16 + field) * 2048 + 4 * 2048 * 60);
  EXPECT_EQ(c.N_C, 0);
  EXPECT_EQ(c.pixel_steps, 0);  // the pixel work is the device's
  // The host's pass over the 1700 records: each tallied, placed by 4 radix passes of its root (a
  // pixel of 20'000'000 needs 25 bits) and handed on.
  EXPECT_EQ(c.record_steps, 1700 * (1 + 4 + 1));
  EXPECT_EQ(cpu_counts(s, 1).record_steps, 0);  // the CPU backends label on the host: no records
  EXPECT_EQ(c.launches, 11);
  EXPECT_EQ(c.P, 4);
  EXPECT_EQ(c.host_memory, HostMemory::pinned);
  // A frame without components: no statistics or centroid kernels, no records to wait for.
  FrameShape none = s;
  none.components = 0;
  const CostCounts z = cuda_counts(none, HostMemory::pinned);
  EXPECT_EQ(z.launches, 8);
  EXPECT_EQ(z.host_waits, 2);
  EXPECT_EQ(z.gpu_pixel_steps, 0);  // no centroid kernel, no classification
  EXPECT_EQ(z.record_steps, 0);
  EXPECT_EQ(z.gpu_frame_pixels, 5 * roi);  // no statistics pass
  EXPECT_EQ(c.N_GG_frame - z.N_GG_frame, 2 * roi + 1700);  // the statistics' reads, and one id fewer a component
  EXPECT_EQ(z.copies_GC, (std::vector<CopySize>{{8, 1}, {field * 2048, 1}}));
  s.otsu = false;
  s.interp = Interp::fe;
  s.support_entries = 2048 * 90;  // FE: recovery triangles
  const CostCounts f = cuda_counts(s, HostMemory::pageable);
  EXPECT_EQ(f.launches, 9);
  EXPECT_EQ(f.transfers_GC, 3);  // the count alone comes back first
  EXPECT_EQ(f.copies_GC.front(), (CopySize{4, 1}));
  // Per recovery triangle 20 + 8 + 1 FLOPs; per point its own triangle (10), 1 / s and the
  // scaling (5), the Green-Lagrange strain (16); on the device a point is a warp's, whose 32
  // lanes' partial sums of gxx, gxy, gyx, gyy and s are added up (5 x 31).
  EXPECT_EQ(f.N_G, 14LL * 2'000'000 + 11LL * 4'500'000 + 50LL * 1600 + 29LL * 2048 * 90 + 31LL * 2048 + 155LL * 2048);
  EXPECT_EQ(f.host_memory, HostMemory::pageable);
  // On the CPU, FE streams a recovery triangle's index and coefficient per support entry and a
  // point's 3 triangle dots, 3 shape functions and 8 outputs; the triangles' dots, gradients and
  // displacements are gathered from the caches. On the device, the same: 2 values a support entry
  // and 14 a point in N_GG.
  const CostCounts fc = cpu_counts(s, 1);
  EXPECT_EQ(fc.N_CC, (2LL * 20'000'000 + 13LL * 20'000'000 + 10LL * 7'000'000 + 6'500'000 +
                      8 * (2LL * 2048 * 90 + 14LL * 2048)) / 8);
  EXPECT_EQ(f.N_GG, rv + roi + 5 * roi + 2 * 3'000'000 + roi + 1700 + 2 * roi + stage + 2'000'000 + 4'500'000 +
                        6 * 1600 + 2 * 2048 * 90 + 14 * 2048);
  // 16-bit frames: twice the bytes uploaded.
  s.bytes_per_pixel = 2;
  EXPECT_EQ(cuda_counts(s, HostMemory::pinned).N_CG, 20'000'000 / 2 + 1600);
  // An upload that is not whole 4-byte values counts its last, partial value.
  s.bytes_per_pixel = 1;
  s.roi_pixels = 641 * 481;
  EXPECT_EQ(cuda_counts(s, HostMemory::pinned).N_CG, (641 * 481 + 3) / 4 + 1600);
}

TEST(DctCounts, WeightFunctionsArePricedPerSupportDot) {
  // Per support dot 321 FLOPs besides the weight function, evaluated once in each pass: the
  // cubic spline 10, the quartic and the Gaussian 8 (kernels.hpp, weight_fn, counted by hand).
  EXPECT_EQ(flops_per_support_dot(Weight::cubic_spline), 341);
  EXPECT_EQ(flops_per_support_dot(Weight::quartic), 337);
  EXPECT_EQ(flops_per_support_dot(Weight::gaussian), 337);
  FrameShape s = hand_shape();
  const std::int64_t fixed = 14LL * 2'000'000 + 11LL * 4'500'000 + 50LL * 1600 + 221LL * 2048;
  for (auto [w, per] : {std::pair{Weight::cubic_spline, 341LL}, std::pair{Weight::quartic, 337LL},
                        std::pair{Weight::gaussian, 337LL}}) {
    s.weight = w;
    SCOPED_TRACE(to_string(w));
    EXPECT_EQ(cpu_counts(s, 1).N_C, fixed + per * 2048 * 60);
    EXPECT_EQ(cuda_counts(s, HostMemory::pinned).N_G, fixed + per * 2048 * 60);
    // Nothing else changes: the same values are read and written.
    FrameShape cubic = s;
    cubic.weight = Weight::cubic_spline;
    EXPECT_EQ(cpu_counts(s, 1).N_CC, cpu_counts(cubic, 1).N_CC);
    EXPECT_EQ(cuda_counts(s, HostMemory::pinned).N_GG, cuda_counts(cubic, HostMemory::pinned).N_GG);
  }
  // FE's per-frame arithmetic has no weight (its recovery coefficients are the reference's).
  s.interp = Interp::fe;
  FrameShape cubic = s;
  cubic.weight = Weight::cubic_spline;
  EXPECT_EQ(cpu_counts(s, 1).N_C, cpu_counts(cubic, 1).N_C);
}

TEST(DctCounts, ThresholdMethodsArePriced) {
  const FrameShape otsu = hand_shape();
  const std::int64_t roi = 20'000'000;
  // The rest of the frame's bytes (hand_shape, CpuMatchesFormulas): labelling 13 per analysed
  // pixel, 10 per window pixel, the ring and weighted pixels, the fields.
  const std::int64_t rest = 13LL * roi + 10LL * 7'000'000 + 6'500'000 + 8 * (1LL * 2048 * 60 + 8LL * 2048);
  const std::int64_t flops = cpu_counts(otsu, 1).N_C;
  // Otsu: histogram 1 + threshold 2 bytes per pixel.
  EXPECT_EQ(cpu_counts(otsu, 1).N_CC, (3 * roi + rest) / 8);
  // Fixed: no histogram.
  FrameShape fixed = otsu;
  fixed.otsu = false;
  EXPECT_EQ(cpu_counts(fixed, 1).N_CC, (2 * roi + rest) / 8);
  EXPECT_EQ(cpu_counts(fixed, 1).N_C, flops);
  EXPECT_EQ(cpu_counts(fixed, 1).cpu_footprint, cpu_counts(otsu, 1).cpu_footprint);
  // ... and no histogram steps: one step per analysed pixel (the labelling) less.
  EXPECT_EQ(cpu_counts(otsu, 1).pixel_steps - cpu_counts(fixed, 1).pixel_steps, roi);
  EXPECT_EQ(cpu_counts(otsu, 1).hist_steps, roi);  // a fixed threshold counts no histogram
  EXPECT_EQ(cpu_counts(fixed, 1).hist_steps, 0);
  EXPECT_EQ(cpu_counts(fixed, 1).label_steps, roi);
  // Adaptive: box filter (1 read, 4 + 4 row sums, 1 mean written) and the comparison (2 read,
  // 1 written): 13 bytes a pixel; 5 operations a pixel; the mean adds a byte a pixel to the
  // working set.
  FrameShape adaptive = fixed;
  adaptive.adaptive = true;
  EXPECT_EQ(cpu_counts(adaptive, 1).N_CC, (13 * roi + rest) / 8);
  EXPECT_EQ(cpu_counts(adaptive, 1).N_C, flops + 5 * roi);
  EXPECT_EQ(cpu_counts(adaptive, 1).cpu_footprint, cpu_counts(otsu, 1).cpu_footprint + roi);
  EXPECT_EQ(cpu_counts(adaptive, 1).pixel_steps, cpu_counts(fixed, 1).pixel_steps);  // vector loops: no scalar steps
  // The box filter is not a pass the probe times: its bytes stay priced in dt_CC, the passes' are
  // a fixed threshold's.
  EXPECT_EQ(cpu_counts(adaptive, 1).N_CC_pixel, cpu_counts(fixed, 1).N_CC_pixel);
  EXPECT_EQ(cpu_counts(otsu, 1).N_CC_pixel - cpu_counts(fixed, 1).N_CC_pixel, roi / 8);  // Otsu's histogram
  // 16-bit adaptive: converted to 8 bits first (2 read, 1 written, a multiply), the 8-bit copy
  // in the working set; the rest of the frame reads the 16-bit ring and weighted pixels.
  FrameShape wide = adaptive;
  wide.bytes_per_pixel = 2;
  EXPECT_EQ(cpu_counts(wide, 1).N_CC, (16 * roi + rest + 6'500'000) / 8);
  EXPECT_EQ(cpu_counts(wide, 1).N_C, flops + 6 * roi);
  EXPECT_EQ(cpu_counts(wide, 1).cpu_footprint, roi * (2 + 1 + 4 + 2) + 8 * (1LL * 2048 * 60 + 8LL * 2048));
  // cuda: a fixed threshold drops the histogram and Otsu kernels, the histogram's read and the
  // threshold's 4 bytes from the first copy back.
  const CostCounts g = cuda_counts(otsu, HostMemory::pinned), f = cuda_counts(fixed, HostMemory::pinned);
  EXPECT_EQ(g.launches - f.launches, 2);
  EXPECT_EQ(g.N_GG - f.N_GG, roi / 4 + 256);
  EXPECT_EQ(g.gpu_frame_pixels - f.gpu_frame_pixels, roi);  // the histogram's pass
  EXPECT_EQ(g.N_GG_frame - f.N_GG_frame, roi / 4);
  EXPECT_EQ(g.N_GC - f.N_GC, 1);
  EXPECT_EQ(g.transfers_GC, f.transfers_GC);
}

TEST(DctCounts, DiscAreaInsideARectangle) {
  // Within 1e-6 of the area: far finer than a count of dots needs.
  const double pi = 3.14159265358979323846;
  EXPECT_NEAR(disc_area_inside(50, 50, 10, 0, 0, 100, 100), pi * 100, 3e-4);      // inside
  EXPECT_NEAR(disc_area_inside(0, 50, 10, 0, 0, 100, 100), pi * 50, 3e-4);        // on a side
  EXPECT_NEAR(disc_area_inside(0, 0, 10, 0, 0, 100, 100), pi * 25, 3e-4);         // in a corner
  EXPECT_NEAR(disc_area_inside(5, 5, 100, 0, 0, 10, 10), 100, 3e-4);              // covers it
  EXPECT_EQ(disc_area_inside(-20, 50, 10, 0, 0, 100, 100), 0);                    // outside
  // A chord: the segment of a disc cut at distance d from its centre, area r^2 acos(d/r) - d sqrt(r^2 - d^2).
  const double r = 10, d = 6, segment = r * r * std::acos(d / r) - d * std::sqrt(r * r - d * d);
  EXPECT_NEAR(disc_area_inside(50, 6, r, 0, 0, 100, 100), pi * r * r - segment, 3e-4);
  // A corner cut at both sides, against a fine Monte Carlo-free midpoint sum.
  double grid = 0;
  const int n = 2000;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double x = -10 + 20 * (i + 0.5) / n, y = -10 + 20 * (j + 0.5) / n;
      if (x * x + y * y < 100 && x + 3 >= 0 && y + 4 >= 0) grid += (20.0 / n) * (20.0 / n);
    }
  EXPECT_NEAR(disc_area_inside(3, 4, 10, 0, 0, 100, 100), grid, 0.05);
}

TEST(DctCounts, SupportByRadiusExpectsTheDensityTimesTheDiscInside) {
  // One point at the centre of a 1000 x 1000 pattern of 4000 dots: 0.004 per px^2 x pi 50^2.
  EXPECT_EQ(expected_entries_within(50, 0, 0, 1000, 1000, 1, 1, 4000), std::llround(0.004 * 3.14159265358979 * 2500));
  // 2 x 2 points in the corners: a quarter disc each.
  EXPECT_EQ(expected_entries_within(50, 0, 0, 1000, 1000, 2, 2, 4000),
            std::llround(4 * 0.004 * 3.14159265358979 * 2500 / 4));
  // A support larger than the pattern holds every dot, no more.
  EXPECT_EQ(expected_entries_within(5000, 0, 0, 1000, 1000, 3, 3, 4000), 9 * 4000);
  EXPECT_THROW(expected_entries_within(0, 0, 0, 1000, 1000, 3, 3, 4000), InputError);
  EXPECT_THROW(expected_entries_within(10, 0, 0, 0, 1000, 3, 3, 4000), InputError);
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
  // FE: two recovery triangles per support dot at the grid's inner points (a square grid's
  // outer ring lies outside the dots' hull): 32x32 -> 30x30.
  EXPECT_EQ(fe_inner_points(1024), 900);
  EXPECT_EQ(fe_inner_points(4), 4);
  EXPECT_EQ(estimate_shape(640, 480, 1, m.dots, 8, 1024, 30, Interp::fe).support_entries, 2 * 900 * 30);
}

}  // namespace
}  // namespace dtflop::dct

namespace dtflop::dct {
namespace {

// The matching's steps, written out by hand for 25 reference dots on a 5 x 5 grid: the grid
// matching bins the 25 frame dots and answers 25 queries (50 steps); a k-d tree of 25 points (the
// reference's, for a radius not given or for dots lost) has 1 + ceil(log2(25 / 10)) = 3 levels,
// so a build is 25 x 3 = 75 steps, a search for the 2 nearest 3 + 10 + 2 = 15 and for the
// 2 x 6 + 1 = 13 nearest 3 + 10 + 13 = 26.
TEST(DctMatchSteps, MatchDotsReportsWhatTheFormulaCounts) {
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
  o.search_radius = 8;  // given, as the pipeline gives it: no tree at all
  Matches m = match_dots(ref, def, o);
  EXPECT_EQ(m.matched, 25);
  EXPECT_EQ(m.tree_steps, 0);
  EXPECT_EQ(m.match_steps, 25 + 25);
  EXPECT_EQ((MatchWork{m.tree_steps, m.match_steps}), match_work(25, 25));
  // Without a radius, the reference's own tree and searches come first.
  o.search_radius = 0;
  m = match_dots(ref, def, o);
  EXPECT_EQ(m.tree_steps, 75 + 25 * 15);
  EXPECT_EQ(m.match_steps, 50);
  EXPECT_EQ((MatchWork{m.tree_steps, m.match_steps}), match_work(25, 25, 0, 0, o.refine_neighbours, false));
  // Three dots lost (moved away): the refining pass builds the reference tree, searches it for each
  // lost dot's neighbours and asks the grid again for the three.
  def[3] = {500, 500};
  def[7] = {600, 600};
  def[11] = {700, 700};
  o.search_radius = 8;
  m = match_dots(ref, def, o);
  EXPECT_EQ(m.matched, 22);
  EXPECT_EQ(m.tree_steps, 75 + 3 * 26);
  EXPECT_EQ(m.match_steps, 25 + 25 + 3);
  EXPECT_EQ((MatchWork{m.tree_steps, m.match_steps}), match_work(25, 25, 3, 3, o.refine_neighbours));
}

}  // namespace
}  // namespace dtflop::dct
