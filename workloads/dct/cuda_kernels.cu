// Kernels of the DCT cuda backend (see cuda_kernels.hpp and cuda_backend.cpp for the flow).
// Centroid positions are kept as doubles (so that a displacement of 1e-3 px is not lost in
// the rounding of a 6000-px coordinate); all arithmetic is float32.
#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "workloads/dct/cuda_kernels.hpp"

namespace dtflop::dct::gpu {


namespace {


template <class Pix>
__device__ __forceinline__ int bin256(Pix v) {
  return sizeof(Pix) == 1 ? static_cast<int>(v) : static_cast<int>(v) / 257;
}

// Lanes of a warp that fall in one bin add once (the background fills one bin: without the
// aggregation its shared-memory atomics serialize).
template <class Pix>
__global__ void k_histogram(const Pix* img, int w, int h, unsigned int* hist) {
  __shared__ unsigned int local[256];
  for (int i = threadIdx.x; i < 256; i += blockDim.x) local[i] = 0;
  __syncthreads();
  const long long n = static_cast<long long>(w) * h;
  const long long stride = static_cast<long long>(gridDim.x) * blockDim.x;
  // Every lane runs the same number of iterations, so the whole warp meets in the match.
  const long long rounds = (n + stride - 1) / stride;
  for (long long r = 0; r < rounds; ++r) {
    const long long i = r * stride + blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x;
    const int bin = i < n ? bin256(img[i]) : -1;
    const unsigned peers = __match_any_sync(0xffffffffu, bin);
    if (bin >= 0 && (threadIdx.x % 32) == static_cast<unsigned>(__ffs(peers) - 1))
      atomicAdd(&local[bin], static_cast<unsigned>(__popc(peers)));
  }
  __syncthreads();
  for (int i = threadIdx.x; i < 256; i += blockDim.x)
    if (local[i]) atomicAdd(&hist[i], local[i]);
}

// Otsu's threshold: the between-class variance of analysis.cpp's otsu_threshold at every t at
// once, one thread a bin (blockDim.x == 256), and the first maximum. The class weights and sums are
// sums of integers below 2^53, exact in double in any order, so every t's variance is the serial
// loop's to the bit and the same t wins. (The serial loop on one thread took 40 us of a frame on
// an H100: 512 dependent double divisions.)
constexpr int kOtsuThreads = 256;
__global__ void k_otsu(const unsigned int* h, int wide, int* T) {
  __shared__ double w[kOtsuThreads], s[kOtsuThreads];
  __shared__ double best_v[kOtsuThreads];
  __shared__ int best_t[kOtsuThreads];
  const int i = threadIdx.x;
  w[i] = static_cast<double>(h[i]);
  s[i] = i * static_cast<double>(h[i]);
  __syncthreads();
  // Inclusive prefix sums (Hillis-Steele): w[i] = w0 and s[i] = s0 of the serial loop at t = i.
  for (int o = 1; o < kOtsuThreads; o <<= 1) {
    const double wa = i >= o ? w[i - o] : 0, sa = i >= o ? s[i - o] : 0;
    __syncthreads();
    w[i] += wa;
    s[i] += sa;
    __syncthreads();
  }
  const double total = w[kOtsuThreads - 1], sum = s[kOtsuThreads - 1];
  const double w0 = w[i], s0 = s[i], w1 = total - w0;
  double v = -1;  // below every variance: a t with an empty class is never chosen
  if (w0 != 0 && w1 != 0) {
    const double m0 = s0 / w0, m1 = (sum - s0) / w1;
    v = w0 * w1 * (m0 - m1) * (m0 - m1);
  }
  best_v[i] = v;
  best_t[i] = i;
  __syncthreads();
  // The largest variance, the lowest t among equals (the serial loop's strict >).
  for (int o = kOtsuThreads / 2; o > 0; o >>= 1) {
    if (i < o) {
      const double vb = best_v[i + o];
      const int tb = best_t[i + o];
      if (vb > best_v[i] || (vb == best_v[i] && tb < best_t[i])) {
        best_v[i] = vb;
        best_t[i] = tb;
      }
    }
    __syncthreads();
  }
  if (i == 0) {
    const int t = best_v[0] < 0 ? 0 : best_t[0];  // one class only: t = 0, as the serial loop
    *T = wide ? t * 257 + 256 : t;
  }
}

// Labels: -1 background; otherwise the index of a pixel of the same component (a tree).
template <class Pix>
__global__ void k_init(const Pix* img, int w, int h, const int* T_dev, int T_fixed, int dark, int* L) {
  const long long n = static_cast<long long>(w) * h;
  const int T = T_dev ? *T_dev : T_fixed;
  for (long long i = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x; i < n;
       i += static_cast<long long>(gridDim.x) * blockDim.x) {
    const int v = img[i];
    const bool fg = dark ? v <= T : v > T;
    L[i] = fg ? static_cast<int>(i) : -1;
  }
}

__device__ __forceinline__ int find_root(const volatile int* L, int x) {
  for (;;) {
    const int p = L[x];
    if (p == x) return x;
    x = p;
  }
}

// Union of two trees by linking the larger root under the smaller (atomicMin), retried
// until the link holds (Playne and Hawick's union-find).
__device__ __forceinline__ void unite(int* L, int a, int b) {
  for (;;) {
    a = find_root(L, a);
    b = find_root(L, b);
    if (a == b) return;
    if (a > b) { const int t = a; a = b; b = t; }
    const int old = atomicMin(&L[b], a);
    if (old == b) return;
    b = old;
  }
}

// Unions by the 8-connectivity decision tree (Wu et al.) over the pixels above and to the
// left, a (up-left), b (up), c (up-right), d (left): pairs that are neighbours of each other
// are united by those pixels' own steps, so about one union per pixel suffices.
__global__ void k_union(int* L, int w, int h) {
  const long long n = static_cast<long long>(w) * h;
  for (long long i = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x; i < n;
       i += static_cast<long long>(gridDim.x) * blockDim.x) {
    if (L[i] < 0) continue;
    const int x = static_cast<int>(i % w), y = static_cast<int>(i / w);
    const int me = static_cast<int>(i);
    const bool d = x > 0 && L[i - 1] >= 0;
    if (y == 0) {
      if (d) unite(L, me, me - 1);
      continue;
    }
    const int up = me - w;
    const bool a = x > 0 && L[up - 1] >= 0, b = L[up] >= 0, c = x + 1 < w && L[up + 1] >= 0;
    if (b) {
      unite(L, me, up);
    } else if (c) {
      unite(L, me, up + 1);
      if (a) unite(L, me, up - 1);
      else if (d) unite(L, me, me - 1);
    } else if (a) {
      unite(L, me, up - 1);
    } else if (d) {
      unite(L, me, me - 1);
    }
  }
}

__global__ void k_compress(int* L, long long n) {
  for (long long i = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x; i < n;
       i += static_cast<long long>(gridDim.x) * blockDim.x)
    if (L[i] >= 0) L[i] = find_root(L, static_cast<int>(i));
}

// Roots take ids 0..n-1, stored as -(id + 2) in the root's own label.
__global__ void k_ids(int* L, long long n, int* count) {
  for (long long i = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x; i < n;
       i += static_cast<long long>(gridDim.x) * blockDim.x)
    if (L[i] == static_cast<int>(i)) L[i] = -(atomicAdd(count, 1) + 2);
}

// Root (first pixel) of pixel i, or -1 for background. After k_ids a label is either -1,
// the root's index (>= 0), or, at the root itself, -(id + 2).
__device__ __forceinline__ int root_of_pixel(const int* L, int i) {
  const int v = L[i];
  return v >= 0 ? v : (v <= -2 ? i : -1);
}


__global__ void k_stats_init(CompStats s, int n) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  s.area[i] = 0;
  s.minx[i] = s.miny[i] = 0x7fffffff;
  s.maxx[i] = s.maxy[i] = -1;
  s.root[i] = 0x7fffffff;
}

// blockDim.x == 32: each warp covers 32 consecutive pixels of one row; lanes of one component
// are aggregated into one atomic per statistic.
__global__ void k_stats(const int* L, int w, int h, CompStats s) {
  const int x = blockIdx.x * 32 + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  int key = -1, root = -1;
  if (x < w && y < h) {
    const int i = y * w + x;
    root = root_of_pixel(L, i);
    if (root >= 0) key = -L[root] - 2;
  }
  const unsigned peers = __match_any_sync(0xffffffffu, key);
  if (key < 0) return;
  const int lane = threadIdx.x;
  const int leader = __ffs(peers) - 1;
  if (lane != leader) return;
  const int last = 31 - __clz(peers);
  atomicAdd(&s.area[key], __popc(peers));
  atomicMin(&s.minx[key], x);
  atomicMax(&s.maxx[key], x - lane + last);
  atomicMin(&s.miny[key], y);
  atomicMax(&s.maxy[key], y);
  atomicMin(&s.root[key], root);
}

// One block per component: filters, then the centroid of eq. 7.1 (kernels::centroid_block,
// kernels/dot_centroid.hpp: the gpu-centroid probe times the same block).
template <class Pix>
__global__ void k_centroid(const Pix* img, const int* L, int w, int h, Roi roi, CompStats s, DotParams p, DotOut out) {
  const int id = blockIdx.x;
  const int area = s.area[id];
  const int bx = s.minx[id], by = s.miny[id], bw = s.maxx[id] - bx + 1, bh = s.maxy[id] - by + 1;
  const int grow = p.margin + kRingWidth;
  int status = 0;
  if (area < p.min_area || area > p.max_area) status = 1;
  else if (fmaxf(bw, bh) > p.max_aspect * fminf(bw, bh) || area < p.min_fill * static_cast<float>(bw) * bh) status = 2;
  else if (p.reject_border && (bx - grow < 0 || by - grow < 0 || bx + bw + grow > w || by + bh + grow > h)) status = 3;
  if (status != 0) {
    if (threadIdx.x == 0) {
      out.status[id] = status;
      out.pixels[3 * id] = out.pixels[3 * id + 1] = out.pixels[3 * id + 2] = 0;
    }
    return;
  }
  const int rootc = s.root[id];
  kernels::DotWindow win;
  win.x0 = max(bx - grow, 0);
  win.y0 = max(by - grow, 0);
  win.w = min(bx + bw - 1 + grow, w - 1) - win.x0 + 1;
  win.h = min(by + bh - 1 + grow, h - 1) - win.y0 + 1;
  auto label = [&](int x, int y) -> int {
    if (x < 0 || y < 0 || x >= w || y >= h) return -1;
    return root_of_pixel(L, y * w + x);
  };
  const kernels::DotSums d = kernels::centroid_block(img, w, win, label, rootc, p.margin, p.dark != 0);
  if (threadIdx.x == 0) {
    const bool ok = d.w > 0.f && d.ring > 0.f;
    out.status[id] = ok ? 0 : 4;
    out.x[id] = roi.x + static_cast<double>(d.cx) + static_cast<double>(d.wx / d.w);
    out.y[id] = roi.y + static_cast<double>(d.cy) + static_cast<double>(d.wy / d.w);
    out.weight[id] = d.w;
    out.pixels[3 * id] = win.w * win.h;
    out.pixels[3 * id + 1] = static_cast<int>(d.ring);
    out.pixels[3 * id + 2] = static_cast<int>(d.weighted);
  }
}

__global__ void k_displacement(int n, const double2* ref, const double* cx, const double* cy, const int* match,
                               float2* U, unsigned char* valid) {
  const int j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j >= n) return;
  const int k = match[j];
  if (k < 0) {
    valid[j] = 0;
    U[j] = make_float2(0.f, 0.f);
    return;
  }
  valid[j] = 1;
  U[j] = make_float2(static_cast<float>(cx[k] - ref[j].x), static_cast<float>(cy[k] - ref[j].y));
}

// One point a thread (kernels/point_fields.hpp: the arithmetic the gpu-mls probe times).
__global__ void k_mls(int n, kernels::MlsDeviceTable t, FieldValue<float>* out) {
  const int m = blockIdx.x * blockDim.x + threadIdx.x;
  if (m < n) out[m] = kernels::mls_point_device(t, m);
}

// One warp a point: its lanes take the point's support triangles in turn, so 32 triangles' gathers
// (dots, validity, displacements: three dependent loads each) are in flight where one thread would
// wait on each in order (a thread a point took 64-157 us for 500-1500 points of ~170 triangles on
// an H100, a latency chain the model's bandwidth terms cannot price), then the warp adds up its
// lanes' partial sums (5 x 31 additions, counted in cuda_counts) and lane 0 writes the field.
__global__ void k_fe(int n, const int* tri, const float* N, const int* offsets, const int* support, const float* coef,
                     const int* tri_dots, const float* tri_gx, const float* tri_gy, const unsigned char* geometry,
                     const float2* U, const unsigned char* valid, FieldValue<float>* out) {
  const int lane = static_cast<int>(threadIdx.x) & 31;
  const long long warps = (static_cast<long long>(gridDim.x) * blockDim.x) / 32;
  for (long long w = (static_cast<long long>(blockIdx.x) * blockDim.x + threadIdx.x) / 32; w < n; w += warps) {
    const int m = static_cast<int>(w);  // the same for the whole warp: its shuffles below are whole-warp
    FieldValue<float> f;
    f.status = static_cast<PointStatus>(geometry[m]);
    if (f.status == PointStatus::ok) {
      const int a = tri[3 * m], b = tri[3 * m + 1], c = tri[3 * m + 2];
      if (!valid[a] || !valid[b] || !valid[c]) {
        f.status = PointStatus::lost_vertex;
      } else {
        FePoint<float> fp;
        for (int e = offsets[m] + lane; e < offsets[m + 1]; e += 32) {
          const int q = 3 * support[e];
          const int d0 = tri_dots[q], d1 = tri_dots[q + 1], d2 = tri_dots[q + 2];
          if (!valid[d0] || !valid[d1] || !valid[d2]) continue;
          const float2 u0 = U[d0], u1 = U[d1], u2 = U[d2];
          const float tx[3] = {u0.x, u1.x, u2.x}, ty[3] = {u0.y, u1.y, u2.y};
          fp.add(coef[e], &tri_gx[q], &tri_gy[q], tx, ty);
        }
        for (int d = 16; d > 0; d /= 2) {
          fp.gxx += __shfl_down_sync(0xffffffffu, fp.gxx, d);
          fp.gxy += __shfl_down_sync(0xffffffffu, fp.gxy, d);
          fp.gyx += __shfl_down_sync(0xffffffffu, fp.gyx, d);
          fp.gyy += __shfl_down_sync(0xffffffffu, fp.gyy, d);
          fp.s += __shfl_down_sync(0xffffffffu, fp.s, d);
          fp.n += __shfl_down_sync(0xffffffffu, fp.n, d);
        }
        float Ux[3], Uy[3];
        const int v[3] = {a, b, c};
        for (int k = 0; k < 3; ++k) {
          const float2 u = U[v[k]];
          Ux[k] = u.x;
          Uy[k] = u.y;
        }
        fp.own(&N[3 * m], Ux, Uy);
        f = fp.field();
      }
    }
    if (lane == 0) out[m] = f;
  }
}

int grid_for(long long n, int block) {
  const long long g = (n + block - 1) / block;
  return static_cast<int>(std::min<long long>(std::max<long long>(g, 1), 65535LL * 32));
}

}  // namespace

void launch_otsu(const void* img, bool wide, int w, int h, unsigned int* hist, int* T, int block, cudaStream_t s) {
  const long long n = static_cast<long long>(w) * h;
  DTFLOP_CUDA(cudaMemsetAsync(hist, 0, 256 * sizeof(unsigned int), s));
  const int g = std::min(grid_for(n, block), 1024);
  if (wide) k_histogram<std::uint16_t><<<g, block, 0, s>>>(static_cast<const std::uint16_t*>(img), w, h, hist);
  else k_histogram<std::uint8_t><<<g, block, 0, s>>>(static_cast<const std::uint8_t*>(img), w, h, hist);
  DTFLOP_CUDA_LAUNCHED();
  k_otsu<<<1, kOtsuThreads, 0, s>>>(hist, wide ? 1 : 0, T);
  DTFLOP_CUDA_LAUNCHED();
}

void launch_labels(const void* img, bool wide, int w, int h, const int* T_dev, int T_fixed, bool dark, int* L,
                   int* count, int block, cudaStream_t s) {
  const long long n = static_cast<long long>(w) * h;
  const int g = grid_for(n, block);
  if (wide) k_init<std::uint16_t><<<g, block, 0, s>>>(static_cast<const std::uint16_t*>(img), w, h, T_dev, T_fixed, dark, L);
  else k_init<std::uint8_t><<<g, block, 0, s>>>(static_cast<const std::uint8_t*>(img), w, h, T_dev, T_fixed, dark, L);
  DTFLOP_CUDA_LAUNCHED();
  k_union<<<g, block, 0, s>>>(L, w, h);
  DTFLOP_CUDA_LAUNCHED();
  k_compress<<<g, block, 0, s>>>(L, n);
  DTFLOP_CUDA_LAUNCHED();
  DTFLOP_CUDA(cudaMemsetAsync(count, 0, sizeof(int), s));
  k_ids<<<g, block, 0, s>>>(L, n, count);
  DTFLOP_CUDA_LAUNCHED();
}

namespace {
template <class K>
int max_threads(K kernel) {
  cudaFuncAttributes a{};
  DTFLOP_CUDA(cudaFuncGetAttributes(&a, kernel));
  return a.maxThreadsPerBlock;
}
}  // namespace

BlockLimits block_limits() {
  BlockLimits b;
  for (int t : {max_threads(k_histogram<std::uint8_t>), max_threads(k_histogram<std::uint16_t>),
                max_threads(k_init<std::uint8_t>), max_threads(k_init<std::uint16_t>), max_threads(k_union),
                max_threads(k_compress), max_threads(k_ids), max_threads(k_stats)})
    b.pixels = std::min(b.pixels, t);
  b.points = std::min(max_threads(k_mls), max_threads(k_fe));
  b.dots = std::min(max_threads(k_centroid<std::uint8_t>), max_threads(k_centroid<std::uint16_t>));
  return b;
}

void launch_stats(const int* L, int w, int h, CompStats cs, int n, int block, cudaStream_t s) {
  k_stats_init<<<grid_for(n, 256), 256, 0, s>>>(cs, n);
  DTFLOP_CUDA_LAUNCHED();
  const dim3 sb(32, static_cast<unsigned>(block / 32));
  const dim3 sg(static_cast<unsigned>((w + 31) / 32), static_cast<unsigned>((h + sb.y - 1) / sb.y));
  k_stats<<<sg, sb, 0, s>>>(L, w, h, cs);
  DTFLOP_CUDA_LAUNCHED();
}

void launch_centroids(const void* img, bool wide, const int* L, int w, int h, Roi roi, CompStats cs, DotParams p,
                      DotOut out, int n, int block, cudaStream_t s) {
  if (n <= 0) return;
  constexpr int stage = kernels::kCentroidStageBytes;
  if (wide)
    k_centroid<<<n, block, stage, s>>>(static_cast<const std::uint16_t*>(img), L, w, h, roi, cs, p, out);
  else
    k_centroid<<<n, block, stage, s>>>(static_cast<const std::uint8_t*>(img), L, w, h, roi, cs, p, out);
  DTFLOP_CUDA_LAUNCHED();
}

void launch_displacement(int n, const double2* ref, const double* cx, const double* cy, const int* match, float2* U,
                         unsigned char* valid, cudaStream_t s) {
  if (n <= 0) return;
  k_displacement<<<grid_for(n, 128), 128, 0, s>>>(n, ref, cx, cy, match, U, valid);
  DTFLOP_CUDA_LAUNCHED();
}

void launch_mls(int n, const double2* pts, const float* rho, const unsigned char* geometry, const int* offsets,
                const int* dots, const double2* ref, const float2* U, const unsigned char* valid, int weight,
                int min_dots, float min_pivot, FieldValue<float>* out, int block, cudaStream_t s) {
  if (n <= 0) return;
  const kernels::MlsDeviceTable t{pts, rho, geometry, offsets, dots, ref, U, valid, weight, min_dots, min_pivot};
  k_mls<<<grid_for(n, block), block, 0, s>>>(n, t, out);
  DTFLOP_CUDA_LAUNCHED();
}

void launch_fe(int n, const int* tri, const float* N, const int* offsets, const int* support, const float* coef,
               const int* tri_dots, const float* tri_gx, const float* tri_gy, const unsigned char* geometry,
               const float2* U, const unsigned char* valid, FieldValue<float>* out, int block, cudaStream_t s) {
  if (n <= 0) return;
  k_fe<<<grid_for(32LL * n, block), block, 0, s>>>(n, tri, N, offsets, support, coef, tri_dots, tri_gx, tri_gy, geometry, U,
                                            valid, out);
  DTFLOP_CUDA_LAUNCHED();
}

}  // namespace dtflop::dct::gpu
