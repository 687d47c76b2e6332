// The arithmetic of a field at one interpolation point that the DCT workload's backends share and
// the cpu-mls probe times: moving least squares (eqs. 7.2-7.6 with 6.5 of the dissertation) and the
// finite-element interpolant with its recovered gradient (7.2), templated on the scalar type and
// compiled for the host (float64 reference, float32 checks) and for the device (float32); and the
// host loop that evaluates MLS fields over a support table, the one source of the loop the CPU
// backends run and the cpu-mls probe times (as kernels/host_loops.hpp is for the RBE's loops), and,
// compiled by nvcc, the device's MLS point that the cuda backend's kernel and the gpu-mls probe run. The FLOP
// constants are what these functions do, counted by hand from the code. Header only; it depends on
// nothing but kernels/host_device.hpp.
#pragma once

#include <cmath>
#include <cstdint>

#include "kernels/host_device.hpp"

namespace dtflop::kernels {
// ---- Moving least squares (eqs. 7.2-7.6, strain by 6.5) --------------------------------
enum class Weight : int { cubic_spline = 0, quartic = 1, gaussian = 2 };
// Width of the truncated Gaussian, in units of the support radius.
constexpr double kGaussAlpha = 0.3;

// W(s) and W'(s)/s for the normalized distance s = r / rho (0 for s >= 1). FLOPs, as written
// below (constants folded, a transcendental counted as 1), flops_weight(): the cubic spline 10
// (its longer branch, s <= 1/2: W 7, W'/s 2, and the branch test 1), the quartic 8 (q 1, W 5,
// W'/s 2), the Gaussian 8 (the exponent 3, exp 1, W 2, W'/s 2).
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

constexpr std::int64_t flops_weight(Weight kind) { return kind == Weight::cubic_spline ? 10 : 8; }

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

// Strain from the displacement gradient (du_x/dx, du_x/dy, du_y/dx, du_y/dy) in the reference
// configuration: the Green-Lagrange tensor E = (F'F - I) / 2 with F = I + grad u,
//   E_xx = u_x,x + (u_x,x^2 + u_y,x^2) / 2,   E_yy = u_y,y + (u_x,y^2 + u_y,y^2) / 2,
//   E_xy = (u_x,y + u_y,x + u_x,x u_x,y + u_y,x u_y,y) / 2,
// zero for any rigid rotation (the small-strain tensor reads cos t - 1 on the diagonal, -38
// microstrain at 0.5 deg) and the small-strain tensor to first order (at 1e-3 strain the
// quadratic terms are 5e-7). FLOPs: E_xx and E_yy 3 multiplies + 2 adds each, E_xy 3
// multiplies + 3 adds: 16.
template <class T>
DTFLOP_HD void strain_from_gradient(T dxx, T dxy, T dyx, T dyy, FieldValue<T>& f) {
  f.exx = dxx + T(0.5) * (dxx * dxx + dyx * dyx);
  f.eyy = dyy + T(0.5) * (dxy * dxy + dyy * dyy);
  f.exy = T(0.5) * (dxy + dyx + dxx * dxy + dyx * dyy);
}
constexpr std::int64_t kFlopsStrain = 16;

// 1 / sqrt(v): the device's reciprocal square root, the host's 1 / sqrt.
template <class T>
DTFLOP_HD T rsqrt_of(T v) {
#ifdef __CUDA_ARCH__
  if constexpr (sizeof(T) == sizeof(float)) return rsqrtf(v);
  else return rsqrt(v);
#else
  return T(1) / std::sqrt(v);
#endif
}

// MLS at one point x_m. Offsets are centred on the point and scaled by its support radius rho,
// xi = (X_j - x_m) / rho, and the basis is p(xi) = [1, xi, eta, xi^2, eta^2, xi eta], so that
// p(0) = e0. The weighted fit a = A^-1 b (A = sum W p p', b = sum W p U, per component) gives
// u = a_0, and differentiating A a = b at x_m (only W depends on x) gives
//   rho du/dx = a_1 + g' sum_j (rho dW_j/dx) p_j r_j,   g = A^-1 e0,   r_j = U_j - p_j' a,
// likewise d/dy with a_2: the derivative of eq. 7.6 written with the fit's residuals r_j.
//
// Numerics. A is never formed. The product P' W P squares the conditioning of the weighted
// least-squares problem sqrt(W) P a = sqrt(W) U: with a Gaussian weight on a support a few dot
// pitches wide, A's condition number reaches 1e5-1e6 (in centred and scaled coordinates),
// and float32 moments lost up to 6e-5 in strain against float64. Instead, pass 1 (add)
// reduces the rows sqrt(W_j) [p_j' | U_j'] into the triangular factor R (R'R = A) by Givens
// rotations, one dot at a time, which costs only the conditioning of sqrt(W) P (the square
// root of A's); solve() back-substitutes a and g from R; pass 2 (add_residual) runs over the
// same dots again and sums the residual terms, which are small, where summing (rho dW/dx) p U
// and (rho dW/dx) p p' separately and subtracting would cancel. Float32 on the device then
// matches float64 to ~1e-7 in strain on such supports.
template <class T>
struct MlsPoint {
  T R[6][8] = {};  // R in columns 0-5 (upper triangle), Q' sqrt(W) U_x and U_y in 6 and 7
  T a[2][6] = {};  // the fit, per component (after solve)
  T g[6] = {};     // A^-1 e0 (after solve)
  T cx[2][6] = {}, cy[2][6] = {};  // sum (rho dW/dx) p r and sum (rho dW/dy) p r (pass 2)
  int n = 0;       // dots with W > 0

  // Pass 1: the dot at scaled offset (xi, eta) with displacement (ux, uy) relative to the
  // point's reference displacement. FLOPs: s (3 + sqrt 1), weight 10, sqrt(W) 1, basis 3,
  // the row sqrt(W) [p | U] 7; six rotations: c, s and R_ii (h = x^2 + y^2, 1 / sqrt(h), 3
  // multiplies: 7) and (7 - i) column pairs of 4 multiplies + 2 adds for i = 0..5 (162):
  // 204. Total 229.
  DTFLOP_HD void add(Weight kind, T xi, T eta, T ux, T uy) {
    using std::sqrt;
    T w, dws;
    weight_fn(kind, sqrt(xi * xi + eta * eta), w, dws);
    if (!(w > T(0))) return;
    ++n;
    const T sw = sqrt(w);
    const T p[6] = {T(1), xi, eta, xi * xi, eta * eta, xi * eta};
    T row[8];
    row[0] = sw;
    for (int i = 1; i < 6; ++i) row[i] = sw * p[i];
    row[6] = sw * ux;
    row[7] = sw * uy;
    for (int i = 0; i < 6; ++i) {
      const T y = row[i];
      if (y == T(0)) continue;
      const T x = R[i][i];
      // c = x / r, s = y / r, r = sqrt(x^2 + y^2), with one reciprocal square root (on the
      // device one instruction, which need not be correctly rounded: the rotation is then
      // orthogonal times a factor within a few ulp of 1, and R_ii = h k takes the same factor).
      const T h = x * x + y * y, k = rsqrt_of(h), c = x * k, s = y * k;
      R[i][i] = h * k;
      for (int j = i + 1; j < 8; ++j) {
        const T rj = R[i][j], qj = row[j];
        R[i][j] = c * rj + s * qj;
        row[j] = c * qj - s * rj;
      }
    }
  }

  // Between the passes. Status: too_few_dots below `min_dots`; ill_conditioned when A's LDL'
  // pivots (R_ii^2) span more than 1 / min_pivot_ratio. FLOPs: pivots and the test (7); a,
  // two back substitutions (2 x 36); g, one forward and one back substitution (2 x 36): 151.
  DTFLOP_HD PointStatus solve(int min_dots, T min_pivot_ratio) {
    if (n < min_dots) return PointStatus::too_few_dots;
    T dmax = R[0][0] * R[0][0], dmin = dmax;
    for (int i = 1; i < 6; ++i) {
      const T d = R[i][i] * R[i][i];
      dmax = d > dmax ? d : dmax;
      dmin = d < dmin ? d : dmin;
    }
    if (!(dmin > min_pivot_ratio * dmax)) return PointStatus::ill_conditioned;
    for (int c = 0; c < 2; ++c)
      for (int i = 5; i >= 0; --i) {
        T v = R[i][6 + c];
        for (int j = i + 1; j < 6; ++j) v -= R[i][j] * a[c][j];
        a[c][i] = v / R[i][i];
      }
    T z[6];  // R' z = e0
    for (int i = 0; i < 6; ++i) {
      T v = i == 0 ? T(1) : T(0);
      for (int k = 0; k < i; ++k) v -= R[k][i] * z[k];
      z[i] = v / R[i][i];
    }
    for (int i = 5; i >= 0; --i) {  // R g = z
      T v = z[i];
      for (int j = i + 1; j < 6; ++j) v -= R[i][j] * g[j];
      g[i] = v / R[i][i];
    }
    return PointStatus::ok;
  }

  // Pass 2, over the same dots as pass 1. FLOPs: s 4, weight 10, rho dW/dx and dy (3),
  // basis 3, the two residuals (2 x 11), (rho dW/dx) p and (rho dW/dy) p (10), the four
  // 6-term sums (48): 100.
  DTFLOP_HD void add_residual(Weight kind, T xi, T eta, T ux, T uy) {
    using std::sqrt;
    T w, dws;
    weight_fn(kind, sqrt(xi * xi + eta * eta), w, dws);
    if (!(w > T(0))) return;
    // d/dx of W(|x - X_j| / rho) at x = x_m, times rho: -xi W'(s) / s.
    const T nd = -dws, wx = xi * nd, wy = eta * nd;
    const T p[6] = {T(1), xi, eta, xi * xi, eta * eta, xi * eta};
    T wxp[6], wyp[6];
    wxp[0] = wx;
    wyp[0] = wy;
    for (int i = 1; i < 6; ++i) { wxp[i] = wx * p[i]; wyp[i] = wy * p[i]; }
    const T u[2] = {ux, uy};
    for (int c = 0; c < 2; ++c) {
      T r = u[c] - a[c][0];
      for (int i = 1; i < 6; ++i) r -= p[i] * a[c][i];
      for (int i = 0; i < 6; ++i) {
        cx[c][i] += wxp[i] * r;
        cy[c][i] += wyp[i] * r;
      }
    }
  }

  // The field at the point from both passes; `u0` is the reference displacement that was
  // subtracted from every dot's (MLS reproduces constants, so it is added back). FLOPs: the
  // four derivatives (4 x 12), scaling by 1 / rho (4), u0 added back (2), the strain
  // (kFlopsStrain): 54 + kFlopsStrain.
  DTFLOP_HD FieldValue<T> field(T rho, T u0x, T u0y) const {
    T dx[2], dy[2];
    for (int c = 0; c < 2; ++c) {
      T sx = a[c][1], sy = a[c][2];
      for (int i = 0; i < 6; ++i) {
        sx += g[i] * cx[c][i];
        sy += g[i] * cy[c][i];
      }
      dx[c] = sx / rho;
      dy[c] = sy / rho;
    }
    FieldValue<T> f;
    f.support = n;
    f.ux = a[0][0] + u0x;
    f.uy = a[1][0] + u0y;
    strain_from_gradient(dx[0], dy[0], dx[1], dy[1], f);
    return f;
  }
};
// Per support dot: pass 1 (229 with the cubic spline) + pass 2 (100) + the caller's offsets,
// twice (xi, eta: 2 subtracts + 2 multiplies; U - U0: 2 subtracts; 6 each pass). Each pass
// evaluates the weight once: with another weight function both passes count its FLOPs instead.
constexpr std::int64_t flops_per_support_dot(Weight kind) {
  return 229 + 100 + 2 * 6 + 2 * (flops_weight(kind) - flops_weight(Weight::cubic_spline));
}
constexpr std::int64_t kFlopsPerSupportDot = flops_per_support_dot(Weight::cubic_spline);
// Per point: solve (151) + field (54 + kFlopsStrain).
constexpr std::int64_t kFlopsPerPoint = 151 + 54 + kFlopsStrain;

// FE (linear triangles, seed 7.2). The displacement is the finite-element interpolant: the
// point's triangle's shape functions, u = sum N_i U_i. The strain is the recovered gradient,
// not the point's own triangle's constant one: one triangle's gradient is the difference of
// three centroids over one dot spacing, so its noise (~0.005 px / 60 px, 85-140 microstrain
// on the independent renders) is 15-20x MLS's. Instead every triangle t of the point's support
// contributes its constant gradient G_t = sum_i (dN_i/dx, dN_i/dy) U_i with a coefficient c_t
// fixed by the reference (fields.cpp, build_fe_table: a weighted least-squares fit of
// G(x) = G0 + G1 (x - x_m) to the triangles' gradients at their centroids, weights area x the
// MLS weight of the centroid's distance, c_t = w_t e0' M^-1 q_t, sum c_t = 1), the patch
// recovery of Zienkiewicz and Zhu with the MLS support as the patch. A triangle with a lost
// vertex is left out and the others renormalised by the sum of the coefficients kept.
template <class T>
struct FePoint {
  T ux = 0, uy = 0;                   // the interpolant (set by own())
  T gxx = 0, gxy = 0, gyx = 0, gyy = 0, s = 0;  // sum c_t G_t and sum c_t
  int n = 0;                          // triangles that contributed

  // The point's own triangle: 2 components x (3 multiplies + 2 adds) = 10 FLOPs.
  DTFLOP_HD void own(const T N[3], const T Ux[3], const T Uy[3]) {
    ux = N[0] * Ux[0] + N[1] * Ux[1] + N[2] * Ux[2];
    uy = N[0] * Uy[0] + N[1] * Uy[1] + N[2] * Uy[2];
  }
  // One support triangle with coefficient c, vertex gradients (gx, gy) and vertex
  // displacements: its four gradient terms (4 x 5 = 20), times c and summed (4 x 2 = 8), the
  // coefficient sum (1): 29 FLOPs.
  DTFLOP_HD void add(T c, const T gx[3], const T gy[3], const T Ux[3], const T Uy[3]) {
    const T txx = gx[0] * Ux[0] + gx[1] * Ux[1] + gx[2] * Ux[2];
    const T txy = gy[0] * Ux[0] + gy[1] * Ux[1] + gy[2] * Ux[2];
    const T tyx = gx[0] * Uy[0] + gx[1] * Uy[1] + gx[2] * Uy[2];
    const T tyy = gy[0] * Uy[0] + gy[1] * Uy[1] + gy[2] * Uy[2];
    gxx += c * txx; gxy += c * txy; gyx += c * tyx; gyy += c * tyy;
    s += c;
    ++n;
  }
  // The field: the coefficients kept must carry at least half the fit (else lost_vertex);
  // 1 / s and 4 multiplies (5), strain from the gradient (strain_from_gradient).
  DTFLOP_HD FieldValue<T> field() const {
    FieldValue<T> f;
    f.ux = ux;
    f.uy = uy;
    f.support = n;
    if (!(s > T(0.5))) {
      f.status = PointStatus::lost_vertex;
      return f;
    }
    const T k = T(1) / s;
    strain_from_gradient(gxx * k, gxy * k, gyx * k, gyy * k, f);
    return f;
  }
};
constexpr std::int64_t kFlopsPerFeEntry = 29;
constexpr std::int64_t kFlopsPerFePoint = 10 + 5 + kFlopsStrain;
// The device's FE kernel gives a point a warp: its 32 lanes' partial sums of the five sums above
// are added up at the end (5 x 31 additions a point).
constexpr std::int64_t kFlopsPerFeWarpCombine = 5 * 31;


// ---- The host loop over MLS points --------------------------------------------------------
// A support table in compressed rows: point m's support dots are dots[offsets[m] .. offsets[m + 1]),
// nearest first. `Vec` is any type with double members x and y.
template <class Vec>
struct MlsSupports {
  const std::int32_t* offsets;  // points + 1
  const std::int32_t* dots;     // dot indices
  const Vec* points;            // the points x_m
  const double* rho;            // their support radii
  const PointStatus* geometry;  // ok, or why the point has no field whatever the dots do
};
// The dots: reference positions, displacements, and whether each was tracked in this frame.
template <class Vec>
struct MlsDots {
  const Vec* reference;
  const Vec* disp;
  const std::uint8_t* tracked;
};
struct MlsSettings {
  Weight weight = Weight::cubic_spline;
  int min_dots = 6;
  double min_pivot_ratio = 1e-5;
};

// The fields of points [begin, end) in float64 into out[begin, end): for each point, the first
// tracked dot's displacement as the reference u0, then two passes over the tracked support dots
// (MlsPoint::add, solve, MlsPoint::add_residual, field). One support dot costs
// flops_per_support_dot(weight) FLOPs and a point kFlopsPerPoint; the two passes' chains of
// dependent rotations, square roots and divisions, not the FLOPs, are what it takes on a CPU
// (docs/model.md 2.6, lat_mls). Never inlined: the workload and the probe run one function.
template <class Vec>
[[gnu::noinline]] void mls_fields(const MlsSupports<Vec>& t, const MlsDots<Vec>& d, const MlsSettings& o, int begin,
                                  int end, FieldValue<double>* out) {
  for (int m = begin; m < end; ++m) {
    FieldValue<double>& f = out[m];
    f = FieldValue<double>{};
    if (t.geometry[m] != PointStatus::ok) {
      f.status = t.geometry[m];
      continue;
    }
    const Vec xm = t.points[m];
    const double rho = t.rho[m];
    double u0x = 0, u0y = 0;  // the reference displacement: the first tracked dot's (nearest first)
    for (std::int32_t k = t.offsets[m]; k < t.offsets[m + 1]; ++k)
      if (d.tracked[t.dots[k]]) {
        u0x = d.disp[t.dots[k]].x;
        u0y = d.disp[t.dots[k]].y;
        break;
      }
    MlsPoint<double> mp;
    auto each_dot = [&](auto&& visit) {
      for (std::int32_t k = t.offsets[m]; k < t.offsets[m + 1]; ++k) {
        const std::int32_t j = t.dots[k];
        if (d.tracked[j])
          visit((d.reference[j].x - xm.x) / rho, (d.reference[j].y - xm.y) / rho, d.disp[j].x - u0x,
                d.disp[j].y - u0y);
      }
    };
    each_dot([&](double xi, double eta, double ux, double uy) { mp.add(o.weight, xi, eta, ux, uy); });
    f.support = mp.n;
    f.status = mp.solve(o.min_dots, o.min_pivot_ratio);
    if (f.status != PointStatus::ok) continue;
    each_dot([&](double xi, double eta, double ux, double uy) { mp.add_residual(o.weight, xi, eta, ux, uy); });
    f = mp.field(rho, u0x, u0y);
  }
}

#ifdef __CUDACC__
// ---- One MLS point on the device -----------------------------------------------------------
// The DCT cuda backend's field kernel runs this for each point on a thread of its own, and the
// gpu-mls probe times the same function: float32 arithmetic, positions in double until their
// offsets from the point are taken. The support table and dots as mls_fields() reads them, in
// the device's types (`valid` for tracked, displacements as float2).
struct MlsDeviceTable {
  const double2* points;
  const float* rho;
  const unsigned char* geometry;  // PointStatus of each point
  const int* offsets;             // points + 1
  const int* dots;
  const double2* reference;
  const float2* disp;
  const unsigned char* valid;
  int weight;  // Weight
  int min_dots;
  float min_pivot;
};

// Point m's field: the first tracked dot's displacement as u0, then two passes over the tracked
// support dots, as mls_fields(). One thread's chain of dependent rotations, square roots and
// divisions: a point's support, not the field's FLOPs, is what it takes (docs/model.md 2.6, lat_GM).
__device__ __forceinline__ FieldValue<float> mls_point_device(const MlsDeviceTable& t, int m) {
  FieldValue<float> f;
  if (t.geometry[m] != 0) {
    f.status = static_cast<PointStatus>(t.geometry[m]);
    return f;
  }
  const double2 p = t.points[m];
  const float r = t.rho[m], inv = 1.f / r;
  const int k0 = t.offsets[m], k1 = t.offsets[m + 1];
  float2 u0 = make_float2(0.f, 0.f);
  for (int k = k0; k < k1; ++k)
    if (t.valid[t.dots[k]]) {
      u0 = t.disp[t.dots[k]];
      break;
    }
  const Weight w = static_cast<Weight>(t.weight);
  MlsPoint<float> mp;
  // The second pass reads the same entries again, from cache. Offsets are taken in double
  // before rounding to float.
  for (int k = k0; k < k1; ++k) {
    const int j = t.dots[k];
    if (!t.valid[j]) continue;
    const float2 u = t.disp[j];
    const double2 X = t.reference[j];
    mp.add(w, static_cast<float>(X.x - p.x) * inv, static_cast<float>(X.y - p.y) * inv, u.x - u0.x, u.y - u0.y);
  }
  f.support = mp.n;
  f.status = mp.solve(t.min_dots, t.min_pivot);
  if (f.status != PointStatus::ok) return f;
  for (int k = k0; k < k1; ++k) {
    const int j = t.dots[k];
    if (!t.valid[j]) continue;
    const float2 u = t.disp[j];
    const double2 X = t.reference[j];
    mp.add_residual(w, static_cast<float>(X.x - p.x) * inv, static_cast<float>(X.y - p.y) * inv, u.x - u0.x,
                    u.y - u0.y);
  }
  return mp.field(r, u0.x, u0.y);
}
#endif

}  // namespace dtflop::kernels
