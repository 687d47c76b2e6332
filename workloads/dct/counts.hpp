// CostCounts of the DCT backends: what one deformed frame costs, from a frame's image
// to its fields in host memory. The seed gives no DCT count formulas (ch. 7.5.1 only names
// the support domain as the varied parameter), so these are derived from the code: the
// per-pixel, per-dot and per-point FLOPs are the constants of kernels.hpp, and the values
// moved are each stage's reads and writes, each counted once per stage, as listed beside the
// functions. Image analysis depends on the image (how many pixels are dots), so the counts
// take the shape a run measured (FrameShape, reported by every backend) or one estimated
// before running (estimate_shape) for prediction.
#pragma once

#include <cstdint>

#include "model/cost_counts.hpp"
#include "workloads/dct/fields.hpp"

namespace dtflop::dct {

struct FrameShape {
  std::int64_t image_pixels = 0;       // the whole frame (what a GPU backend uploads)
  int bytes_per_pixel = 1;             // 1 (8-bit) or 2 (16-bit)
  std::int64_t roi_pixels = 0;         // analysed
  std::int64_t foreground_pixels = 0;  // above threshold (dot pixels)
  std::int64_t components = 0;         // labelled, before filtering
  std::int64_t dots = 0;               // reference dots n_f (kept and tracked against)
  std::int64_t window_pixels = 0;      // sum of the kept dots' centroid windows
  std::int64_t ring_pixels = 0;        // of which background-ring pixels
  std::int64_t weighted_pixels = 0;    // of which weighted pixels
  std::int64_t scanned_pixels = 0;     // of which background pixels whose neighbourhood's labels
                                       // were read (the CPU's classification; 0 on cuda)
  int margin = 2;                      // centroid margin: a scan reads (2 margin + 1)^2 labels
  std::int64_t points = 0;             // interpolation points n_m
  std::int64_t support_entries = 0;    // sum over points of their support dots (MLS) or recovery triangles (FE)
  std::int64_t tree_steps = 0;         // the matching's k-d tree work (tracking.hpp, match_work)
  std::int64_t match_steps = 0;        // the matching's grid work (tracking.hpp, match_work)
  Interp interp = Interp::mls;
  Weight weight = Weight::cubic_spline;  // MLS weight function (its FLOPs per support dot)
  bool otsu = true;                    // the threshold is computed from the frame's histogram
  bool adaptive = false;               // the threshold is the local mean (cv::adaptiveThreshold)
};

// Estimate for prediction: n_dots dots of radius r px in a w x h frame, n_points points with
// `dots_per_support` dots each.
FrameShape estimate_shape(std::int64_t width, std::int64_t height, int bytes_per_pixel, std::int64_t n_dots,
                          double dot_radius, std::int64_t n_points, std::int64_t dots_per_support, Interp interp,
                          int margin = 2);

// FE: the points of a grid of n_points over the dots' bounding box expected inside the dots'
// hull, the grid taken as square less its outer ring (n_points itself below 9 points).
std::int64_t fe_inner_points(std::int64_t n_points);

// Expected support entries of an MLS support of radius `radius` px, summed over an nx x ny grid
// of points spread over [x0, x1] x [y0, y1] (fields.hpp, grid_points), for `dots` dots spread
// uniformly over that rectangle: at each point the density times the area of the support disc
// that lies inside the rectangle (a point near the pattern's edge has a one-sided support).
// Rounded to a whole count. Throws InputError for a non-positive radius or an empty rectangle.
std::int64_t expected_entries_within(double radius, double x0, double y0, double x1, double y1, std::int64_t nx,
                                     std::int64_t ny, std::int64_t dots);
// The area of the disc of radius r about (cx, cy) that lies inside [x0, x1] x [y0, y1].
double disc_area_inside(double cx, double cy, double r, double x0, double y0, double x1, double y1);

// FLOPs of centroids + displacements + fields (the same formulas on every backend).
std::int64_t analysis_flops(const FrameShape& s);
std::int64_t field_flops(const FrameShape& s);
// Of field_flops, those of MLS points (their support dots and solves; 0 for FE): N_CM on the CPU.
std::int64_t mls_flops(const FrameShape& s);

// cpu-seq (threads = 1) and cpu-par: float64 (P = 8), nothing on a device.
//   N_C  = 14 ring + 11 weighted + 48 n_f (plane + centroid) + 2 n_f (displacements)
//          + MLS: (321 + 2 W) sum(l_m) + 221 n_m (two passes over the support, each evaluating
//            the weight function's W FLOPs: 10 cubic spline, 8 quartic or Gaussian; kernels.hpp)
//          | FE: 29 sum(l_m) + 31 n_m (l_m: the recovery's triangles; kernels.hpp, FePoint)
//          + adaptive threshold: 5 roi (the box filter's running row and column sums, an add
//            and a subtract each, and its scale: integer arithmetic, counted with the FLOPs)
//            [16-bit: + 1 roi, the scale of the conversion to 8 bits]
//   N_CC = the bytes the stages read and write, / 8 (rounded up), b bytes per pixel:
//          Otsu histogram b roi; threshold (b + 1) roi (16-bit too: read, the 8-bit mask
//          written) | adaptive 13 roi (box filter: image read, 4-byte row sums written
//          and read, the mean written; then image and mean read, mask written) [16-bit: + 3 roi,
//          the image converted to 8 bits first]; labelling with statistics 13 roi (mask read, labels written,
//          read and written again); centroids 10 window (label read twice, class written
//          and read) + b (ring + weighted); fields 8 x the values streamed (MLS:
//          sum(l_m) + 8 n_m: a support entry's dot index; 2 position, 1 radius, 5 outputs a
//          point | FE: 2 sum(l_m) + 14 n_m: a recovery triangle's index and coefficient; a
//          point's 3 triangle dots, 3 shape functions, 8 outputs). Values gathered by a dot's or
//          triangle's index (positions, displacements, gradients) come from tables that stay in
//          the caches and are not counted (counts.cpp, cpu_field_values)
//   N_CC_pixel = of N_CC, what the passes the cpu-pixel probe times move on an 8-bit frame, / 8
//          (rounded down): [Otsu: roi] + 2 roi (a fixed threshold) + 13 roi + 10 window + ring +
//          weighted. Where the profile prices the pixel steps by kind, figures timed on such
//          passes, dt_CC leaves them out; a 16-bit frame's wider reads and an adaptive
//          threshold's filter stay in it
//   pixel_steps = the scalar pixel loops, one step per pixel visited and per neighbourhood label
//          read: [Otsu: roi, the histogram's counts] + roi (labelling: each pixel's label
//          decided) + window (each window pixel classified) + (2 margin + 1)^2 scanned (the
//          labels of a background window pixel's neighbourhood; in the caches, so not in N_CC)
//   label_steps = roi: of pixel_steps, the labelling's (OpenCV's threshold and 8-connected
//          labelling with statistics, several times a histogram count or a label read);
//          hist_steps = [Otsu: roi], the histogram's: priced apart, and the rest at L_scan, where
//          the profile has L_label, L_hist and L_scan
//   pixel_passes = 1: the frame's passes (histogram, threshold, labelling, windows), on several
//          threads a fixed L_pass_all beside their steps where the profile has it
//   cpu_footprint = roi (b + 1 + 4) [adaptive: + 1 roi, the mean, + 1 roi for the 16-bit
//          image's 8-bit copy] + the fields' bytes: the frame, the
//          mask and the labels, the working set the model weighs against the cache
CostCounts cpu_counts(const FrameShape& s, int threads);

// Device buffers and launch layout of the cuda backend.
struct CudaLayout {
  int block_pixels = 256;  // threads per block of the per-pixel kernels
  int block_points = 128;  // threads (points) per block of the field kernel
  int block_dots = 128;    // threads per block of the per-dot centroid kernel (one block per dot)
};

// cuda: float32 (P = 4 bytes per value; the frame counts as bytes / 4 values, the device's
// double-precision centroid positions as 2 values each). Every copy and launch of a frame:
//   N_CG = roi bytes / 4 (the region of interest is uploaded, not the whole frame)
//          + n_f (the match table: each reference dot's device component)       2 copies
//   N_GC = 1 (component count) [+ 1 Otsu threshold] (one copy) + 11 a component (centroid
//          x, y as doubles, weight, status, area, root, 3 pixel counts: kCudaRecordBytes, one
//          copy; none without components) + n_m fields (sizeof(FieldValue<float>) / 4 each,
//          one copy)                                                        3 copies
//          copies_GC lists them by size
//   N_GG = roi bytes / 4 + roi (threshold + label init: read pixel, write label)
//          + 5 roi (union: own and 4 neighbour labels) + 2 fg (compress)
//          + roi + components (roots to ids) + 2 roi (stats: label, root; none without components)
//          + stage + ring + weighted (centroid: the labels of each window grown by the
//          margin, staged once in shared memory, cuda_centroid_stage_pixels; a pixel of each
//          ring and each weighted pixel)
//          + 6 n_f (displacements: 2 doubles in, 2 floats out) + MLS: 5 sum(l_m) + 8 n_m
//          | FE: 12 n_m + 8 n_m;  Otsu adds roi bytes / 4 (histogram read) + 256 (its bins, read once)
//   N_G  = the FLOPs above (the weight function's included);  N_GM = MLS: one point's FLOPs,
//          the mean point's (mls_flops / n_m, rounded up; its thread's chain) | FE: 0;  N_C = 0 (matching is
//          comparisons, not FLOPs). The cuda backend has no adaptive threshold (refused).
//          The launch layout (CudaLayout) changes no count: every kernel covers its pixels,
//          points or dots with any block size.
//   gpu_frame_pixels = roi x the whole-frame passes, a thread a pixel each: init, union, compress,
//          ids [+ stats with components] [+ histogram with Otsu];  N_GG_frame = their values in N_GG
//          (all of the above up to the stats, and Otsu's histogram read)
//   gpu_pixel_steps = window (the centroid kernel's classification: a window pixel a step, its
//          neighbourhood read from the stage in both passes; 0 without components)
//   launches = 9 (+2 with Otsu): init, union, compress, ids, stats-init, stats, centroid,
//              displacement, fields [+ histogram, otsu]
//   host_waits = 3 (the count, the component records, the fields)
// A copy of b bytes counts ceil(b / 4) values: an upload that is not whole 4-byte values is counted to the value.
CostCounts cuda_counts(const FrameShape& s, HostMemory frame_memory);
// Bytes of the frame's upload (the region of interest).
std::int64_t cuda_upload_bytes(const FrameShape& s);
// Labels the cuda centroid kernel stages: each kept dot's window grown by the margin on every
// side, (w + 2 margin)(h + 2 margin) for a w x h window. The shape holds the windows' sum, not
// each one's sides, so the sides are the mean window's taken square, d = sqrt(window / n_f):
//   window + 4 margin n_f d + 4 margin^2 n_f   (rounded; 0 without dots)
// A window that with its margin exceeds the kernel's stage (12 KiB of labels: a dot of radius
// above ~48 px) reads its labels from device memory instead, 2 window + the scans; not modelled.
std::int64_t cuda_centroid_stage_pixels(const FrameShape& s);
// Bytes of one component's records that the cuda backend reads back, in one copy a frame: centroid
// x and y (double), weight (float), status, area, root (int) and 3 pixel counts (int).
inline constexpr std::int64_t kCudaRecordBytes = 44;

}  // namespace dtflop::dct
