// The arithmetic of the DCT workload that every backend shares: the background-removed,
// intensity-weighted centroid of one dot (eq. 7.1) and the moving-least-squares estimate at
// one point (eqs. 7.2-7.6 with 6.5). Written once, templated on the scalar type, and
// compiled for the host (float64 reference, float32 checks) and for the device (float32).
// The FLOP constants below are what these functions do, counted by hand from the code;
// counts.cpp builds the backends' CostCounts from them.
#pragma once

#include <cmath>
#include <cstdint>

#ifdef __CUDACC__
#define DTFLOP_HD __host__ __device__ __forceinline__
#else
#define DTFLOP_HD inline
#endif

namespace dtflop::dct {

// ---- Centroids (eq. 7.1) ---------------------------------------------------------------
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

// ---- Moving least squares (eqs. 7.2-7.6, strain by 6.5) --------------------------------
enum class Weight : int { cubic_spline = 0, quartic = 1, gaussian = 2 };
// Width of the truncated Gaussian, in units of the support radius.
constexpr double kGaussAlpha = 0.3;

// W(s) and W'(s)/s for the normalized distance s = r / rho (0 for s >= 1). 10 FLOPs each
// branch, counted as kFlopsWeight below (the Gaussian's exp counted as 1).
template <class T>
DTFLOP_HD void weight_fn(Weight kind, T s, T& w, T& dw_over_s) {
  using std::exp;
  if (s >= T(1)) { w = T(0); dw_over_s = T(0); return; }
  if (kind == Weight::cubic_spline) {
    if (s <= T(0.5)) {
      w = T(2) / T(3) - T(4) * s * s + T(4) * s * s * s;
      dw_over_s = T(-8) + T(12) * s;
    } else {
      const T q = T(1) - s;
      w = T(4) / T(3) * q * q * q;
      dw_over_s = s > T(0) ? T(-4) * q * q / s : T(0);
    }
  } else if (kind == Weight::quartic) {
    // 1 - 6 s^2 + 8 s^3 - 3 s^4, factored: the expanded sum cancels near s = 1, where float32
    // made W zero or negative for dots inside the support (and a support count differ).
    const T q = T(1) - s;
    w = q * q * q * (T(1) + T(3) * s);
    dw_over_s = T(-12) * q * q;
  } else {
    const T a2 = T(kGaussAlpha * kGaussAlpha);
    const T e1 = T(1.4945338524781451e-05);  // exp(-1 / alpha^2), alpha = 0.3
    const T e = exp(-(s * s) / a2);
    w = (e - e1) / (T(1) - e1);
    dw_over_s = T(-2) / a2 * e / (T(1) - e1);
  }
}

// Status of an interpolated point.
enum class PointStatus : std::uint8_t {
  ok = 0,
  too_few_dots = 1,      // fewer tracked dots in the support than the basis needs
  ill_conditioned = 2,   // the moment matrix A's pivots span more than 1 / min_pivot_ratio
  outside_mesh = 3,      // FE: the point lies in no triangle (outside the dots' hull)
  lost_vertex = 4,       // FE: a vertex of its triangle was not tracked
  far_from_dots = 5,     // the nearest dot is farther than the allowed gap (hole, edge)
};

template <class T>
struct FieldValue {
  T ux = 0, uy = 0, exx = 0, eyy = 0, exy = 0;
  PointStatus status = PointStatus::ok;
  int support = 0;  // dots that contributed
};

// Accumulated MLS moments at one point, with everything scaled by the support radius rho:
// xi = (X_j - x_m) / rho, basis p(xi) = [1, xi, eta, xi^2, eta^2, xi eta]; A = sum W p p',
// Ax = rho dA/dx = sum (rho dW/dx) p p', likewise Ay; b = sum W p U, bx, by likewise.
template <class T>
struct MlsMoments {
  T A[21] = {}, Ax[21] = {}, Ay[21] = {};
  T b[2][6] = {}, bx[2][6] = {}, by[2][6] = {};
  int n = 0;

  // One dot at scaled offset (xi, eta) with displacement (ux, uy) relative to the point's
  // reference displacement. FLOPs: s (3 + sqrt 1), weight 10, rho dW/dx and dy (3), basis
  // (3), W p, Wx p, Wy p (18), three 21-entry symmetric outer products (126), the right-hand
  // sides (72): 236; with the caller's offsets (xi, eta: 2 subtracts + 2 multiplies; U - U0:
  // 2 subtracts), kFlopsPerSupportDot = 242.
  DTFLOP_HD void add(Weight kind, T xi, T eta, T ux, T uy) {
    using std::sqrt;
    const T s = sqrt(xi * xi + eta * eta);
    T w, dws;
    weight_fn(kind, s, w, dws);
    if (!(w > T(0))) return;
    ++n;
    // d/dx of W(|x - X_j| / rho) at x = x_m, times rho: -xi W'(s) / s.
    const T wx = -xi * dws, wy = -eta * dws;
    const T p[6] = {T(1), xi, eta, xi * xi, eta * eta, xi * eta};
    T wp[6], wxp[6], wyp[6];
    for (int i = 0; i < 6; ++i) { wp[i] = w * p[i]; wxp[i] = wx * p[i]; wyp[i] = wy * p[i]; }
    int k = 0;
    for (int i = 0; i < 6; ++i)
      for (int j = i; j < 6; ++j, ++k) {
        A[k] += wp[i] * p[j];
        Ax[k] += wxp[i] * p[j];
        Ay[k] += wyp[i] * p[j];
      }
    const T u[2] = {ux, uy};
    for (int c = 0; c < 2; ++c)
      for (int i = 0; i < 6; ++i) {
        b[c][i] += wp[i] * u[c];
        bx[c][i] += wxp[i] * u[c];
        by[c][i] += wyp[i] * u[c];
      }
  }
};
constexpr std::int64_t kFlopsPerSupportDot = 242;

DTFLOP_HD int sym_index(int i, int j) {
  if (i > j) { const int t = i; i = j; j = t; }
  return i * 6 - i * (i - 1) / 2 + (j - i);
}

// Solves the moments for the field at the point. `u0` is the reference displacement that
// was subtracted from every dot's displacement (MLS reproduces constants, so it is added
// back). FLOPs: LDL' of the 6x6 (120), three solves with it (3 x 66), the right-hand sides
// e1 - Ax g and e2 - Ay g (156), the dot products for u and its derivatives (120), scaling by
// 1 / rho (4), u0 added back (2), e_xy (3): kFlopsPerPoint = 603.
template <class T>
DTFLOP_HD FieldValue<T> mls_solve(const MlsMoments<T>& m, T rho, T u0x, T u0y, int min_dots,
                                  T min_pivot_ratio) {
  FieldValue<T> f;
  f.support = m.n;
  if (m.n < min_dots) {
    f.status = PointStatus::too_few_dots;
    return f;
  }
  // LDL' factorization.
  T L[6][6] = {}, d[6];
  T dmax = T(0), dmin = T(0);
  for (int j = 0; j < 6; ++j) {
    T v = m.A[sym_index(j, j)];
    for (int k = 0; k < j; ++k) v -= L[j][k] * L[j][k] * d[k];
    d[j] = v;
    if (j == 0) { dmax = v; dmin = v; }
    dmax = v > dmax ? v : dmax;
    dmin = v < dmin ? v : dmin;
    if (!(v > T(0))) break;
    for (int i = j + 1; i < 6; ++i) {
      T x = m.A[sym_index(i, j)];
      for (int k = 0; k < j; ++k) x -= L[i][k] * L[j][k] * d[k];
      L[i][j] = x / v;
    }
  }
  if (!(dmin > min_pivot_ratio * dmax)) {
    f.status = PointStatus::ill_conditioned;
    return f;
  }
  auto solve = [&](T* r) {
    for (int i = 0; i < 6; ++i)
      for (int k = 0; k < i; ++k) r[i] -= L[i][k] * r[k];
    for (int i = 0; i < 6; ++i) r[i] /= d[i];
    for (int i = 5; i >= 0; --i)
      for (int k = i + 1; k < 6; ++k) r[i] -= L[k][i] * r[k];
  };
  // gamma = A^-1 p(0), p(0) = e0.
  T g[6] = {T(1), T(0), T(0), T(0), T(0), T(0)};
  solve(g);
  // rho d(gamma)/dx = A^-1 (e1 - Ax gamma); likewise y with e2.
  T gx[6], gy[6];
  for (int i = 0; i < 6; ++i) {
    T sx = T(0), sy = T(0);
    for (int j = 0; j < 6; ++j) {
      sx += m.Ax[sym_index(i, j)] * g[j];
      sy += m.Ay[sym_index(i, j)] * g[j];
    }
    gx[i] = (i == 1 ? T(1) : T(0)) - sx;
    gy[i] = (i == 2 ? T(1) : T(0)) - sy;
  }
  solve(gx);
  solve(gy);
  T u[2], dx[2], dy[2];
  for (int c = 0; c < 2; ++c) {
    T v = T(0), vx = T(0), vy = T(0);
    for (int i = 0; i < 6; ++i) {
      v += g[i] * m.b[c][i];
      vx += gx[i] * m.b[c][i] + g[i] * m.bx[c][i];
      vy += gy[i] * m.b[c][i] + g[i] * m.by[c][i];
    }
    u[c] = v;
    dx[c] = vx / rho;
    dy[c] = vy / rho;
  }
  f.ux = u[0] + u0x;
  f.uy = u[1] + u0y;
  f.exx = dx[0];
  f.eyy = dy[1];
  f.exy = T(0.5) * (dy[0] + dx[1]);
  return f;
}
constexpr std::int64_t kFlopsPerPoint = 603;

// FE (linear triangles): u = sum N_i U_i (2 components x 3 terms x 2 FLOPs = 12) and the
// four displacement derivatives from the constant shape-function gradients (4 x 3 x 2 = 24),
// plus e_xy (2) and the reference displacement added back (2): 40 FLOPs per point.
constexpr std::int64_t kFlopsPerFePoint = 40;

}  // namespace dtflop::dct
