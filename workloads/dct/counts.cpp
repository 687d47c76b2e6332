#include "workloads/dct/counts.hpp"
#include "workloads/dct/tracking.hpp"

#include <algorithm>
#include <cmath>
#include <vector>
#include <numbers>

#include <fmt/format.h>

#include "kernels/component_records.hpp"
#include "model/errors.hpp"
#include "workloads/dct/kernels.hpp"

namespace dtflop::dct {

FrameShape estimate_shape(std::int64_t width, std::int64_t height, int bytes_per_pixel, std::int64_t n_dots,
                          double r, std::int64_t n_points, std::int64_t dots_per_support, Interp interp, int margin) {
  if (width < 1 || height < 1 || n_dots < 0 || !(r > 0) || n_points < 0 || dots_per_support < 0)
    throw InputError("shape estimate needs a positive frame size and dot radius, and counts >= 0");
  if (bytes_per_pixel != 1 && bytes_per_pixel != 2) throw InputError("bytes per pixel must be 1 or 2");
  FrameShape s;
  s.image_pixels = s.roi_pixels = width * height;
  s.bytes_per_pixel = bytes_per_pixel;
  const double pi = std::numbers::pi;
  const double area = pi * r * r;
  s.foreground_pixels = static_cast<std::int64_t>(std::llround(static_cast<double>(n_dots) * area));
  s.components = s.dots = n_dots;
  const double side = 2 * r + 1 + 2 * (margin + kRingWidth);
  s.window_pixels = static_cast<std::int64_t>(std::llround(static_cast<double>(n_dots) * side * side));
  // Weighted: the dot grown by `margin` (a square dilation, counted as a disc of r + margin).
  s.weighted_pixels = static_cast<std::int64_t>(std::llround(static_cast<double>(n_dots) * pi * (r + margin + 0.5) * (r + margin + 0.5)));
  s.ring_pixels = s.window_pixels - s.weighted_pixels;
  // Every window pixel but the dot's own is background whose neighbourhood is read.
  s.scanned_pixels = s.window_pixels - static_cast<std::int64_t>(std::llround(static_cast<double>(n_dots) * area));
  s.margin = margin;
  s.points = n_points;
  // FE's recovery reads the triangles whose centroids lie in the support: a Delaunay
  // triangulation of n dots holds 2n - 2 - h triangles (h on the hull), about two per support
  // dot, for the points inside the dots' hull; the grid spans the dots' bounding box, and its
  // outer ring of points lies (mostly) outside the hull and reads none. Counted as two per
  // support dot for the grid's inner points, the grid taken as square (an estimate; the
  // reference's table gives the exact count).
  s.support_entries = interp == Interp::fe ? 2 * fe_inner_points(n_points) * dots_per_support
                                           : n_points * dots_per_support;
  s.interp = interp;
  const MatchWork work = match_work(n_dots, n_dots);  // every dot found and matched at once
  s.tree_steps = work.tree_steps;
  s.match_steps = work.match_steps;
  return s;
}

double disc_area_inside(double cx, double cy, double r, double x0, double y0, double x1, double y1) {
  // The integral over x of the chord's length inside [y0, y1]; the chord is smooth between the
  // breakpoints (the rectangle's sides, where the circle crosses y0 or y1), so Gauss-Legendre on
  // each piece is exact to rounding within a few pieces.
  const double a = std::max(x0, cx - r), b = std::min(x1, cx + r);
  if (!(b > a)) return 0;
  std::vector<double> cuts = {a, b};
  for (double y : {y0, y1}) {
    const double dy = std::abs(y - cy);
    if (dy < r) {
      const double h = std::sqrt(r * r - dy * dy);
      for (double x : {cx - h, cx + h})
        if (x > a && x < b) cuts.push_back(x);
    }
  }
  std::sort(cuts.begin(), cuts.end());
  // 8-point Gauss-Legendre nodes and weights on [-1, 1].
  static constexpr double node[4] = {0.1834346424956498, 0.5255324099163290, 0.7966664774136267,
                                     0.9602898564975363};
  static constexpr double weight[4] = {0.3626837833783620, 0.3137066458778873, 0.2223810344533745,
                                       0.1012285362903763};
  auto chord = [&](double x) {
    const double d = r * r - (x - cx) * (x - cx);
    if (d <= 0) return 0.0;
    const double h = std::sqrt(d);
    return std::max(0.0, std::min(cy + h, y1) - std::max(cy - h, y0));
  };
  double area = 0;
  for (std::size_t i = 0; i + 1 < cuts.size(); ++i) {
    const double m = 0.5 * (cuts[i] + cuts[i + 1]), half = 0.5 * (cuts[i + 1] - cuts[i]);
    if (!(half > 0)) continue;
    // Substitute x = m + half sin(t): the chord's square-root end points become smooth.
    double piece = 0;
    for (int k = 0; k < 4; ++k)
      for (double sgn : {-1.0, 1.0}) {
        const double t = sgn * node[k] * std::numbers::pi / 2;
        piece += weight[k] * chord(m + half * std::sin(t)) * std::cos(t);
      }
    area += piece * half * std::numbers::pi / 2;
  }
  return area;
}

std::int64_t fe_inner_points(std::int64_t n_points) {
  if (n_points < 9) return n_points;
  const double side = std::sqrt(static_cast<double>(n_points)) - 2;
  return std::llround(side * side);
}

std::int64_t expected_entries_within(double radius, double x0, double y0, double x1, double y1, std::int64_t nx,
                                     std::int64_t ny, std::int64_t dots) {
  if (!(radius > 0) || !std::isfinite(radius) || !(x1 > x0) || !(y1 > y0) || nx < 1 || ny < 1 || dots < 0)
    throw InputError("expected support entries need a positive radius, a non-empty rectangle and a grid of points");
  const double density = static_cast<double>(dots) / ((x1 - x0) * (y1 - y0));
  double sum = 0;
  for (std::int64_t j = 0; j < ny; ++j)
    for (std::int64_t i = 0; i < nx; ++i) {
      const double x = nx == 1 ? 0.5 * (x0 + x1) : x0 + (x1 - x0) * static_cast<double>(i) / static_cast<double>(nx - 1);
      const double y = ny == 1 ? 0.5 * (y0 + y1) : y0 + (y1 - y0) * static_cast<double>(j) / static_cast<double>(ny - 1);
      sum += std::min(static_cast<double>(dots), density * disc_area_inside(x, y, radius, x0, y0, x1, y1));
    }
  return std::llround(sum);
}

std::int64_t analysis_flops(const FrameShape& s) {
  return kFlopsPerRingPixel * s.ring_pixels + kFlopsPerWeightedPixel * s.weighted_pixels +
         (kFlopsPerPlane + kFlopsPerCentroid) * s.dots;
}

std::int64_t mls_flops(const FrameShape& s) {
  if (s.interp != Interp::mls) return 0;
  return flops_per_support_dot(s.weight) * s.support_entries + kFlopsPerPoint * s.points;
}

std::int64_t field_flops(const FrameShape& s) {
  const std::int64_t disp = 2 * s.dots;
  if (s.interp == Interp::fe) return disp + kFlopsPerFeEntry * s.support_entries + kFlopsPerFePoint * s.points;
  return disp + mls_flops(s);
}

namespace {
// The device's field kernels, streamed values only, as on the CPU below: a value gathered by a
// dot's or a triangle's index (a support dot's reference position and displacement; a recovery
// triangle's dots, gradients and vertex displacements) comes from a table of a few thousand dots'
// or triangles' size that the multiprocessors' L1 and the L2 hold, and is no device memory traffic.
// Counted as traffic at the device's bandwidths, FE's 17 values a support entry priced its kernel
// at 3-4 times what it took (the k_fe kernel ran 6-13 us for 36 000-97 000 entries on an H200, a
// warp's chain of ceil(entries / 32) dependent gathers a point). MLS: per support entry its dot's
// index (1); FE: its triangle's index and coefficient (2). Per point the figures the fields were
// counted with before (MLS 8, FE 14: a point's inputs and its field record, which on the device is
// 7 values and, with a double position and its support range, comes nearer 15); that difference is
// a few KB a frame, beside the megabytes of a frame's passes, and is left as it was.
std::int64_t field_values(const FrameShape& s) {
  if (s.interp == Interp::fe) return 2 * s.support_entries + 14 * s.points;
  return s.support_entries + 8 * s.points;
}
// The same on the CPU, streamed values only: a value gathered by a dot's or a triangle's index
// (a support dot's reference position and displacement; a recovery triangle's dots, gradients and
// vertex displacements) comes from a table of a few dots' or triangles' size that stays in the
// caches, like the labels of a window's neighbourhood scan, and is no host memory traffic. MLS:
// per support entry its dot's index (1), per point 2 position, 1 radius, 5 outputs (8). FE: per
// support entry its triangle's index and coefficient (2), per point its triangle's 3 dots, 3
// shape functions and 8 outputs (14).
std::int64_t cpu_field_values(const FrameShape& s) {
  if (s.interp == Interp::fe) return 2 * s.support_entries + 14 * s.points;
  return s.support_entries + 8 * s.points;
}
}  // namespace

CostCounts cpu_counts(const FrameShape& s, int threads) {
  CostCounts c;
  c.P = 8;
  c.precision = Precision::fp64;
  const std::int64_t b = s.bytes_per_pixel;
  c.N_C = analysis_flops(s) + field_flops(s) + (s.adaptive ? (5 + (b == 2 ? 1 : 0)) * s.roi_pixels : 0);
  // The MLS fields' FLOPs, priced at their own rate (docs/model.md 2.6): chains of dependent
  // rotations, square roots and divisions, far slower than the FMA rate.
  c.N_CM = mls_flops(s);
  const std::int64_t scan = static_cast<std::int64_t>(2 * s.margin + 1) * (2 * s.margin + 1);
  const std::int64_t threshold = s.adaptive ? 13 + (b == 2 ? 3 : 0) : b + 1;
  const std::int64_t bytes = (s.otsu ? b : 0) * s.roi_pixels + threshold * s.roi_pixels + 13 * s.roi_pixels +
                             10 * s.window_pixels + b * (s.ring_pixels + s.weighted_pixels) + 8 * cpu_field_values(s);
  c.N_CC = (bytes + 7) / 8;
  // Of them, what the passes the cpu-pixel probe times move on an 8-bit frame: its histogram, a
  // fixed threshold, the labelling and the windows. A 16-bit frame's wider reads, and an
  // adaptive threshold's box filter, are work the probe does not do, and stay in dt_CC.
  c.N_CC_pixel = ((s.otsu ? 1 : 0) * s.roi_pixels + 2 * s.roi_pixels + 13 * s.roi_pixels + 10 * s.window_pixels +
                  (s.ring_pixels + s.weighted_pixels)) / 8;
  // The scalar pixel loops (docs/model.md 2.6): Otsu's histogram, the labelling, the windows'
  // classification and the labels each background window pixel's neighbourhood scan reads.
  c.pixel_steps = (s.otsu ? s.roi_pixels : 0) + s.roi_pixels + s.window_pixels + scan * s.scanned_pixels;
  c.label_steps = s.roi_pixels;                // of them, the labelling's: a step an analysed pixel
  c.hist_steps = s.otsu ? s.roi_pixels : 0;    // and Otsu's histogram's: a count an analysed pixel
  c.pixel_passes = s.roi_pixels > 0 ? 1 : 0;    // one frame's passes
  const std::int64_t extra = s.adaptive ? 1 + (b == 2 ? 1 : 0) : 0;
  c.cpu_footprint = s.roi_pixels * (b + 1 + 4 + extra) + 8 * cpu_field_values(s);
  c.cpu_threads = threads < 1 ? 1 : threads;
  c.match_steps = s.match_steps;  // the matching, on one thread
  c.tree_steps = s.tree_steps;    // and its k-d tree work (a radius to find, lost dots)
  return c;
}

std::int64_t cuda_upload_bytes(const FrameShape& s) { return s.roi_pixels * s.bytes_per_pixel; }

std::int64_t cuda_centroid_stage_pixels(const FrameShape& s) {
  if (s.dots <= 0 || s.window_pixels <= 0) return 0;
  const double n = static_cast<double>(s.dots), m = s.margin;
  const double d = std::sqrt(static_cast<double>(s.window_pixels) / n);
  return s.window_pixels + std::llround(4 * m * n * d + 4 * m * m * n);
}

CostCounts cuda_counts(const FrameShape& s, HostMemory frame_memory) {
  static_assert(sizeof(FieldValue<float>) % 4 == 0, "the fields' records must be whole 4-byte values");
  CostCounts c;
  c.P = 4;
  c.precision = Precision::fp32;
  c.host_memory = frame_memory;
  // A copy of b bytes moves ceil(b / 4) values (the last one partly): an odd-sized frame is counted
  // to the value, and the protocol's check against CUPTI's bytes allows for it (calibrate/measure).
  const std::int64_t roi_values = (cuda_upload_bytes(s) + 3) / 4;
  const std::int64_t nc = s.components;
  // Host -> device: the region of interest, then the match table (one int per reference dot).
  c.N_CG = roi_values + s.dots;
  c.transfers_CG = 2;
  // Device -> host, three copies: the component count [and Otsu's threshold], the component
  // records (kCudaRecordBytes each, in one array) and the fields.
  const std::int64_t field_bytes = static_cast<std::int64_t>(sizeof(FieldValue<float>));
  add_copies(c.copies_GC, s.otsu ? 8 : 4, 1);
  if (nc > 0) add_copies(c.copies_GC, kCudaRecordBytes * nc, 1);  // none: no records, no wait for them
  add_copies(c.copies_GC, field_bytes * s.points, 1);
  std::int64_t bytes_GC = 0;
  for (const auto& k : c.copies_GC) {
    bytes_GC += k.bytes * k.count;
    c.transfers_GC += k.count;
  }
  c.N_GC = bytes_GC / 4;
  // The whole-frame passes, a thread a pixel each: the threshold (labels' init), the unions, the
  // compression, the roots' ids and, with components, the statistics; with Otsu's threshold the
  // histogram before them. Their values, then the rest of the kernels'.
  const int frame_passes = 4 + (nc > 0 ? 1 : 0) + (s.otsu ? 1 : 0);
  c.gpu_frame_pixels = frame_passes * s.roi_pixels;
  c.N_GG_frame = roi_values + s.roi_pixels      // threshold + label init
                 + 5 * s.roi_pixels             // union
                 + 2 * s.foreground_pixels      // compress
                 + s.roi_pixels + nc            // roots to ids
                 + (nc > 0 ? 2 * s.roi_pixels : 0)  // stats
                 + (s.otsu ? roi_values : 0);   // the histogram reads the frame
  c.N_GG = c.N_GG_frame + (s.otsu ? 256 : 0)   // Otsu's kernel reads the 256 bins once
           + cuda_centroid_stage_pixels(s) + s.ring_pixels + s.weighted_pixels  // centroids
           + 6 * s.dots                   // displacements
           + field_values(s);
  // Without components the statistics and centroid kernels (3 launches) and the records' wait
  // are left out (such a frame then fails its matching).
  c.launches = nc > 0 ? 9 : 6;
  if (s.otsu) c.launches += 2;
  // The centroid kernel's classification: every window pixel of a kept dot, in its dot's block.
  c.gpu_pixel_steps = nc > 0 ? s.window_pixels : 0;
  // The host's pass over the records (kernels/component_records.hpp): each tallied, ordered by its
  // root (a pixel of the region) a byte a pass, and handed on.
  c.record_steps = kernels::record_steps(nc, s.roi_pixels);
  c.N_G = analysis_flops(s) + field_flops(s) + (s.interp == Interp::fe ? kFlopsPerFeWarpCombine * s.points : 0);
  // One point's MLS field, the chain its thread runs (docs/model.md 2.6): the mean point's, rounded up.
  c.N_GM = s.points > 0 ? (mls_flops(s) + s.points - 1) / s.points : 0;
  // The kernels' working set: the region of interest and its labels (4 bytes a pixel); the
  // components' records (6 statistics, x and y as doubles, weight, status, 3 pixel counts: 60
  // bytes); the reference dots (position 16, match 4, displacement 8, validity 1); the points
  // (position 16, their field record) and the support table (4 bytes an entry).
  c.gpu_footprint = s.roi_pixels * (s.bytes_per_pixel + 4) + 60 * nc + 29 * s.dots + (16 + field_bytes) * s.points +
                    4 * s.support_entries;
  c.N_C = 0;
  // The host waits for the device three times a frame: for the component count, for the
  // component records, and for the fields.
  c.host_waits = nc > 0 ? 3 : 2;
  // The host matches the frame's dots to the reference: its only counted CPU work.
  c.tree_steps = s.tree_steps;
  c.match_steps = s.match_steps;
  return c;
}

}  // namespace dtflop::dct
