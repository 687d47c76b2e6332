// The centroid of one dot (eq. 7.1 of the dissertation): the classification of its window's
// pixels, the background plane fitted to its ring and the intensity-weighted centroid of the rest,
// templated on the scalar type and compiled for the host (float64 reference, float32 checks) and
// for the device (float32); and, compiled by nvcc, the device's block of one dot (centroid_block):
// the one source of what the DCT cuda backend's centroid kernel does and the gpu-centroid probe
// times (as kernels/point_fields.hpp is for the fields); and the host's window routine
// (centroid_window), the DCT CPU backends' and the cpu-pixel probe's. The FLOP constants are what
// these functions do, counted by hand from the code. Header only; it depends on nothing but
// kernels/host_device.hpp and the standard library.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "kernels/host_device.hpp"

namespace dtflop::kernels {

// A dot's window is its labelled bounding box grown by `margin` + kRingWidth pixels. Each
// window pixel is one of:
enum PixelClass : int { kIgnore = 0, kRing = 1, kWeighted = 2 };
constexpr int kRingWidth = 2;

// Class of pixel (x, y) for component `id`: labelled `id` -> weighted; background within
// Chebyshev distance `margin` of `id` and of no other component -> weighted (it holds the
// dot's partly covered edge); background near no component -> ring (background estimate);
// anything else -> ignored. `label(x, y)` returns -1 for background or outside the image.
template <class LabelAt>
DTFLOP_HD int classify_pixel(const LabelAt& label, int x, int y, int id, int margin) {
  const int l = label(x, y);
  if (l == id) return kWeighted;
  if (l != -1) return kIgnore;
  bool self = false, other = false;
  for (int dy = -margin; dy <= margin; ++dy)
    for (int dx = -margin; dx <= margin; ++dx) {
      const int n = label(x + dx, y + dy);
      self |= n == id;
      other |= (n != -1 && n != id);
    }
  if (other) return kIgnore;
  return self ? kWeighted : kRing;
}

// Sums over ring pixels for the background plane I = a + b x + c y (local coordinates).
template <class T>
struct RingSums {
  T n = 0, x = 0, y = 0, xx = 0, xy = 0, yy = 0, i = 0, xi = 0, yi = 0;
  DTFLOP_HD void add(T lx, T ly, T v) {  // 5 multiplies + 9 adds = 14 FLOPs
    n += T(1); x += lx; y += ly; xx += lx * lx; xy += lx * ly; yy += ly * ly;
    i += v; xi += lx * v; yi += ly * v;
  }
  DTFLOP_HD void merge(const RingSums& o) {
    n += o.n; x += o.x; y += o.y; xx += o.xx; xy += o.xy; yy += o.yy; i += o.i; xi += o.xi; yi += o.yi;
  }
};
constexpr std::int64_t kFlopsPerRingPixel = 14;

// Solves the 3x3 normal equations for the plane (Cramer's rule). Returns false when the ring
// cannot fix a plane (fewer than 3 pixels or all on a line); then the plane is its mean.
template <class T>
DTFLOP_HD bool solve_plane(const RingSums<T>& s, T& a, T& b, T& c) {
  // Six cofactors (3 FLOPs each) = 18; det: 3 mul + 2 add = 5; the degeneracy scale and test
  // (3); numerators 3 x 5 = 15 and 3 divides. Total 44 FLOPs.
  const T c00 = s.xx * s.yy - s.xy * s.xy;
  const T c01 = s.xy * s.y - s.x * s.yy;
  const T c02 = s.x * s.xy - s.xx * s.y;
  const T c11 = s.n * s.yy - s.y * s.y;
  const T c12 = s.x * s.y - s.n * s.xy;
  const T c22 = s.n * s.xx - s.x * s.x;
  const T det = s.n * c00 + s.x * c01 + s.y * c02;
  const T scale = s.n * s.xx * s.yy;
  if (s.n < T(3) || !(det > T(1e-6) * scale)) {
    a = s.n > T(0) ? s.i / s.n : T(0);
    b = c = T(0);
    return s.n > T(0);
  }
  a = (c00 * s.i + c01 * s.xi + c02 * s.yi) / det;
  b = (c01 * s.i + c11 * s.xi + c12 * s.yi) / det;
  c = (c02 * s.i + c12 * s.xi + c22 * s.yi) / det;
  return true;
}
constexpr std::int64_t kFlopsPerPlane = 44;

template <class T>
struct WeightSums {
  T w = 0, wx = 0, wy = 0;
  // bg = a + b x + c y (4), w = +-(I - bg) (1), max (1), 2 multiplies + 3 adds (5): 11 FLOPs.
  DTFLOP_HD void add(T lx, T ly, T v, T a, T b, T c, bool dark) {
    const T bg = a + b * lx + c * ly;
    T d = dark ? bg - v : v - bg;
    d = d > T(0) ? d : T(0);
    w += d; wx += d * lx; wy += d * ly;
  }
  DTFLOP_HD void merge(const WeightSums& o) { w += o.w; wx += o.wx; wy += o.wy; }
};
constexpr std::int64_t kFlopsPerWeightedPixel = 11;
// Centroid from the sums: 2 divides + 2 adds (window centre).
constexpr std::int64_t kFlopsPerCentroid = 4;

// ---- One dot's window on the host -----------------------------------------------------------

// What the host's centroid of one dot found; coordinates are the labels' (the region of interest's).
struct WindowCentroid {
  bool kept = false;               // the window held ring and weighted pixels: x, y, weight are set
  double x = 0, y = 0, weight = 0; // the intensity-weighted centroid and its total weight
  std::int64_t window = 0, ring = 0, weighted = 0;  // window pixels, and of them ring and weighted
  std::int64_t scanned = 0;        // background window pixels whose (2 margin + 1)^2 labels were read
  std::int64_t first = -1;         // the first of the dot's own pixels in raster order (y cols + x)
};

namespace detail {

// The window [x0, x1) x [y0, y1) of component `id` with the labels read through `label`.
template <int Margin, bool Dark, class Pix, class LabelAt>
WindowCentroid centroid_window_in(const LabelAt& label, const Pix* img, std::size_t img_stride, int cols, int id,
                                  int x0, int y0, int x1, int y1, int runtime_margin) {
  const int margin = Margin >= 0 ? Margin : runtime_margin;
  WindowCentroid out;
  auto pixel = [img, img_stride](int x, int y) {
    return static_cast<double>(img[static_cast<std::size_t>(y) * img_stride + static_cast<std::size_t>(x)]);
  };
  const int w = x1 - x0, h = y1 - y0;
  const double cx = x0 + 0.5 * (w - 1), cy = y0 + 0.5 * (h - 1);
  std::vector<std::uint8_t> cls(static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
  RingSums<double> ring;
  for (int y = y0, k = 0; y < y1; ++y)
    for (int x = x0; x < x1; ++x, ++k) {
      const int c = classify_pixel(label, x, y, id, margin);
      cls[static_cast<std::size_t>(k)] = static_cast<std::uint8_t>(c);
      if (c == kRing) {
        ring.add(x - cx, y - cy, pixel(x, y));
        ++out.ring;
      }
      const int l = label(x, y);
      out.scanned += l == -1;  // classify_pixel read its neighbourhood
      if (out.first < 0 && l == id) out.first = static_cast<std::int64_t>(y) * cols + x;
    }
  double a, b, c;
  solve_plane(ring, a, b, c);
  WeightSums<double> sums;
  for (int y = y0, k = 0; y < y1; ++y)
    for (int x = x0; x < x1; ++x, ++k)
      if (cls[static_cast<std::size_t>(k)] == kWeighted) {
        sums.add(x - cx, y - cy, pixel(x, y), a, b, c, Dark);
        ++out.weighted;
      }
  out.window = static_cast<std::int64_t>(w) * h;
  if (!(sums.w > 0) || out.ring == 0) return out;
  out.kept = true;
  out.x = cx + sums.wx / sums.w;
  out.y = cy + sums.wy / sums.w;
  out.weight = sums.w;
  return out;
}

// centroid_window with the margin (Margin >= 0; -1: `runtime_margin`) and the polarity fixed at
// compile time. A window whose neighbourhoods stay inside the region (most) reads its labels
// without a bounds check; one at the region's edge reads outside ones as background.
template <int Margin, bool Dark, class Pix>
WindowCentroid centroid_window_fixed(const Pix* img, std::size_t img_stride, const int* labels,
                                     std::size_t label_stride, int cols, int rows, int id, int bx, int by, int bw,
                                     int bh, int runtime_margin) {
  const int margin = Margin >= 0 ? Margin : runtime_margin;
  const int grow = margin + kRingWidth;
  const int x0 = bx - grow > 0 ? bx - grow : 0, y0 = by - grow > 0 ? by - grow : 0;
  const int x1 = bx + bw + grow < cols ? bx + bw + grow : cols, y1 = by + bh + grow < rows ? by + bh + grow : rows;
  if (x1 <= x0 || y1 <= y0) return {};
  // The labels as a pointer and stride by value: the classes' byte stores may alias anything, so
  // a label read through a reference would reload them at every read. Background (0) reads as -1,
  // without a branch on the pixel.
  const auto at = [labels, label_stride](int x, int y) {
    const int l = labels[static_cast<std::size_t>(y) * label_stride + static_cast<std::size_t>(x)];
    return l - static_cast<int>(l == 0);
  };
  if (x0 - margin >= 0 && y0 - margin >= 0 && x1 + margin <= cols && y1 + margin <= rows)
    return centroid_window_in<Margin, Dark>(at, img, img_stride, cols, id, x0, y0, x1, y1, margin);
  const auto checked = [at, cols, rows](int x, int y) {
    return x < 0 || y < 0 || x >= cols || y >= rows ? -1 : at(x, y);
  };
  return centroid_window_in<Margin, Dark>(checked, img, img_stride, cols, id, x0, y0, x1, y1, margin);
}

template <bool Dark, class Pix>
WindowCentroid centroid_window_dark(const Pix* img, std::size_t img_stride, const int* labels,
                                    std::size_t label_stride, int cols, int rows, int id, int bx, int by, int bw,
                                    int bh, int margin) {
#define DTFLOP_CENTROID_MARGIN(M) \
  case M:                         \
    return centroid_window_fixed<M, Dark>(img, img_stride, labels, label_stride, cols, rows, id, bx, by, bw, bh, M);
  switch (margin) {
    DTFLOP_CENTROID_MARGIN(0)
    DTFLOP_CENTROID_MARGIN(1)
    DTFLOP_CENTROID_MARGIN(2)
    DTFLOP_CENTROID_MARGIN(3)
    DTFLOP_CENTROID_MARGIN(4)
    DTFLOP_CENTROID_MARGIN(5)
    DTFLOP_CENTROID_MARGIN(6)
    DTFLOP_CENTROID_MARGIN(7)
    DTFLOP_CENTROID_MARGIN(8)
    default:
      return centroid_window_fixed<-1, Dark>(img, img_stride, labels, label_stride, cols, rows, id, bx, by, bw, bh,
                                             margin);
  }
#undef DTFLOP_CENTROID_MARGIN
}

}  // namespace detail

// One dot's centroid on the host (eq. 7.1), in float64: the DCT CPU backends' window routine and
// the one the cpu-pixel probe times. `img` points at the region's first pixel, `img_stride` pixels
// a row; `labels` likewise (0 background, else the component), `cols` x `rows` the region; the
// window is the component's box (bx, by, bw, bh) grown by margin + kRingWidth, cut to the region.
// Each window pixel is classified once and the classes kept for the weighted pass.
// The margin (the workload's 0..8) and the polarity select a routine compiled for them (the
// (2 margin + 1)^2 label reads of a background pixel unroll), and a window away from the region's
// edge reads its labels unchecked: a window step costs 1.20-1.23 ns on the 2-vCPU VM against
// 1.64-1.70 ns with margin, polarity and bounds checked at run time (the same frames and labels;
// docs/PERFORMANCE.md). The backends called it with run-time values and the cpu-pixel probe with
// constants, which the compiler folded in: the probe's window step was 30-40% cheaper than the
// backends'. Every caller now runs the same code.
template <class Pix>
WindowCentroid centroid_window(const Pix* img, std::size_t img_stride, const int* labels, std::size_t label_stride,
                               int cols, int rows, int id, int bx, int by, int bw, int bh, int margin, bool dark) {
  return dark ? detail::centroid_window_dark<true>(img, img_stride, labels, label_stride, cols, rows, id, bx, by, bw,
                                                   bh, margin)
              : detail::centroid_window_dark<false>(img, img_stride, labels, label_stride, cols, rows, id, bx, by,
                                                    bw, bh, margin);
}

#ifdef __CUDACC__
// ---- One dot's block on the device --------------------------------------------------------

// N sums of a block at once (one pair of barriers for all of them): each warp's by shuffles, then
// thread 0 adds the warps' partials in warp order, value by value. shared holds 32 * N floats.
template <int N>
__device__ __forceinline__ void block_sums(float (&v)[N], float* shared) {
  for (int o = 16; o > 0; o >>= 1)
    for (int j = 0; j < N; ++j) v[j] += __shfl_down_sync(0xffffffffu, v[j], o);
  const int warp = threadIdx.x / 32, lane = threadIdx.x % 32, nw = (blockDim.x + 31) / 32;
  __syncthreads();
  if (lane == 0)
    for (int j = 0; j < N; ++j) shared[32 * j + warp] = v[j];
  __syncthreads();
  if (threadIdx.x == 0)
    for (int j = 0; j < N; ++j) {
      float r = 0.f;
      for (int k = 0; k < nw; ++k) r += shared[32 * j + k];
      v[j] = r;  // valid in thread 0
    }
}

// A block's stage: its dot's window grown by the margin, one byte a pixel (kStageBackground for
// background and outside the image, kStageOwn for the dot's component, kStageOther for another).
// The classification reads a pixel's (2 margin + 1)^2 neighbours: from the stage they are
// shared-memory loads, where from the labels each was a dependent device-memory load (the kernel
// was a latency chain: 42 us of a frame of 1193 dots on an H100). A window larger than the stage
// reads the labels. A launch gives each block kCentroidStageBytes of dynamic shared memory.
constexpr int kCentroidStageBytes = 12 * 1024;
constexpr unsigned char kStageBackground = 0, kStageOwn = 1, kStageOther = 2;

struct DotWindow {
  int x0 = 0, y0 = 0, w = 0, h = 0;  // a dot's window: its first pixel and size, inside the image
};

// What a dot's block found, valid in thread 0.
struct DotSums {
  float cx = 0, cy = 0;         // the window's centre: the origin of the local coordinates
  float w = 0, wx = 0, wy = 0;  // the weights' sums: the centroid is (cx + wx / w, cy + wy / w)
  float ring = 0, weighted = 0; // ring pixels (the background plane's) and weighted pixels
};

// One dot's centroid (eq. 7.1) by the block that calls it, every thread of it (blockDim.x a
// multiple of 32, at most 1024): the window's pixels classified (classify_pixel) from the stage,
// the ring's sums reduced and its plane solved, the pixels classified again and the weighted ones'
// sums reduced. `img` is the frame (rows of `width` pixels); `label(x, y)` returns -1 for
// background or a pixel outside the image and the pixel's component otherwise; `own` is the dot's
// component (>= 0).
template <class Pix, class LabelAt>
__device__ DotSums centroid_block(const Pix* img, int width, DotWindow win, const LabelAt& label, int own, int margin,
                                  bool dark) {
  const int wn = win.w * win.h;
  DotSums out;
  out.cx = win.x0 + 0.5f * (win.w - 1);
  out.cy = win.y0 + 0.5f * (win.h - 1);
  const float cx = out.cx, cy = out.cy;
  extern __shared__ unsigned char stage[];
  const int m = margin, sx0 = win.x0 - m, sy0 = win.y0 - m, sw = win.w + 2 * m, sn = sw * (win.h + 2 * m);
  const bool staged = sn <= kCentroidStageBytes;  // the same for the whole block
  if (staged) {
    for (int k = threadIdx.x; k < sn; k += blockDim.x) {
      const int l = label(sx0 + k % sw, sy0 + k / sw);
      stage[k] = l == -1 ? kStageBackground : l == own ? kStageOwn : kStageOther;
    }
    __syncthreads();
  }
  // A staged pixel's label as classify_pixel compares it: -1 background, `own`, or -2 another
  // component (a component is >= 0).
  auto staged_label = [&](int x, int y) -> int {
    const unsigned char c = stage[(y - sy0) * sw + (x - sx0)];
    return c == kStageBackground ? -1 : c == kStageOwn ? own : -2;
  };
  auto pixel_class = [&](int x, int y) {
    return staged ? classify_pixel(staged_label, x, y, own, m) : classify_pixel(label, x, y, own, m);
  };
  __shared__ float red[32 * 9];
  __shared__ float plane[3];
  RingSums<float> ring;
  for (int k = threadIdx.x; k < wn; k += blockDim.x) {
    const int x = win.x0 + k % win.w, y = win.y0 + k / win.w;
    if (pixel_class(x, y) == kRing)
      ring.add(x - cx, y - cy, static_cast<float>(img[static_cast<long long>(y) * width + x]));
  }
  float r9[9] = {ring.n, ring.x, ring.y, ring.xx, ring.xy, ring.yy, ring.i, ring.xi, ring.yi};
  block_sums(r9, red);
  if (threadIdx.x == 0) {
    RingSums<float> tot;
    tot.n = r9[0]; tot.x = r9[1]; tot.y = r9[2]; tot.xx = r9[3]; tot.xy = r9[4]; tot.yy = r9[5];
    tot.i = r9[6]; tot.xi = r9[7]; tot.yi = r9[8];
    float a, b, c;
    solve_plane(tot, a, b, c);
    plane[0] = a; plane[1] = b; plane[2] = c;
  }
  __syncthreads();
  const float a = plane[0], b = plane[1], c = plane[2];
  WeightSums<float> ws;
  int nweight = 0;
  for (int k = threadIdx.x; k < wn; k += blockDim.x) {
    const int x = win.x0 + k % win.w, y = win.y0 + k / win.w;
    if (pixel_class(x, y) == kWeighted) {
      ws.add(x - cx, y - cy, static_cast<float>(img[static_cast<long long>(y) * width + x]), a, b, c, dark);
      ++nweight;
    }
  }
  float w4[4] = {ws.w, ws.wx, ws.wy, static_cast<float>(nweight)};
  block_sums(w4, red);
  out.w = w4[0]; out.wx = w4[1]; out.wy = w4[2]; out.weighted = w4[3];
  out.ring = r9[0];
  return out;
}
#endif  // __CUDACC__

}  // namespace dtflop::kernels
