#include "workloads/dct/uncertainty.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <unordered_map>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "workloads/dct/kernels.hpp"
#include "workloads/dct/tracking.hpp"

namespace dtflop::dct {
namespace {


double pixel(const cv::Mat& img, int x, int y) {
  return img.depth() == CV_16U ? img.at<std::uint16_t>(y, x) : img.at<std::uint8_t>(y, x);
}

// The ring around a dot, (r1, r2] from its centroid, where the background is sampled.
struct Ring {
  double r0 = 0;   // the dot's equivalent radius + margin + 0.5: pixels within weigh
  double r1 = 0, r2 = 0;
};
Ring ring_of(const DotObservation& d, int margin) {
  const double req = std::sqrt(std::max(1, d.area) / std::numbers::pi);
  Ring r;
  r.r0 = req + margin + 0.5;
  r.r1 = r.r0 + 1;
  r.r2 = r.r1 + 3;
  return r;
}

// Least-squares plane a + b (x - cx) + c (y - cy) over the ring's pixels; false when the
// ring leaves the image or holds too few pixels. `rss` and `n` return the residuals' sum of
// squares and count; rxx, ryy the ring's second moments about its mean.
struct Plane {
  double a = 0, b = 0, c = 0, rss = 0, rxx = 0, ryy = 0;
  long n = 0;
};
bool fit_ring(const cv::Mat& img, const DotObservation& d, const Ring& r, Plane& p) {
  const int x0 = static_cast<int>(std::floor(d.x - r.r2)), x1 = static_cast<int>(std::ceil(d.x + r.r2));
  const int y0 = static_cast<int>(std::floor(d.y - r.r2)), y1 = static_cast<int>(std::ceil(d.y + r.r2));
  if (x0 < 0 || y0 < 0 || x1 >= img.cols || y1 >= img.rows) return false;
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  double sx = 0, sy = 0, sxx = 0, syy = 0;
  long n = 0;
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double dx = x - d.x, dy = y - d.y, rr = std::hypot(dx, dy);
      if (rr <= r.r1 || rr > r.r2) continue;
      const Eigen::Vector3d q(1, dx, dy);
      M += q * q.transpose();
      v += q * pixel(img, x, y);
      sx += dx; sy += dy; sxx += dx * dx; syy += dy * dy;
      ++n;
    }
  if (n < 12) return false;
  const Eigen::Vector3d s = M.ldlt().solve(v);
  p.a = s[0]; p.b = s[1]; p.c = s[2];
  p.n = n;
  p.rss = 0;
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double dx = x - d.x, dy = y - d.y, rr = std::hypot(dx, dy);
      if (rr <= r.r1 || rr > r.r2) continue;
      const double e = pixel(img, x, y) - (p.a + p.b * dx + p.c * dy);
      p.rss += e * e;
    }
  p.rxx = sxx - sx * sx / static_cast<double>(n);
  p.ryy = syy - sy * sy / static_cast<double>(n);
  return true;
}

// Dots whose ring no other dot reaches.
std::vector<std::uint8_t> isolated(const std::vector<DotObservation>& dots, int margin) {
  std::vector<std::uint8_t> ok(dots.size(), 0);
  if (dots.size() < 2) return ok;
  std::vector<Vec2> c;
  double rmax = 0;
  for (const auto& d : dots) {
    c.push_back({d.x, d.y});
    rmax = std::max(rmax, std::sqrt(std::max(1, d.area) / std::numbers::pi));
  }
  PointIndex index(c);
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  for (std::size_t k = 0; k < dots.size(); ++k) {
    index.knn(c[k], 2, idx, d2);
    ok[k] = d2.size() == 2 && std::sqrt(d2[1]) > ring_of(dots[k], margin).r2 + rmax + 1;
  }
  return ok;
}

}  // namespace

NoiseEstimate estimate_noise(const cv::Mat& image, const std::vector<DotObservation>& dots, const AnalysisOptions& o) {
  NoiseEstimate e;
  const auto ok = isolated(dots, o.margin);
  double rss = 0;
  long dof = 0;
  // At most 400 dots, spread over the list, are enough for a pooled estimate.
  const std::size_t step = std::max<std::size_t>(1, dots.size() / 400);
  for (std::size_t k = 0; k < dots.size(); k += step) {
    if (!ok[k]) continue;
    Plane p;
    if (!fit_ring(image, dots[k], ring_of(dots[k], o.margin), p)) continue;
    rss += p.rss;
    dof += p.n - 3;
    e.pixels += p.n;
    ++e.dots_used;
  }
  if (e.dots_used < kMinNoiseDots) {
    e.why_not = fmt::format("no noise estimate: {} isolated dot(s) with a clear background ring, {} needed", e.dots_used,
                            kMinNoiseDots);
    return e;
  }
  e.sigma = std::sqrt(rss / static_cast<double>(dof));
  return e;
}

CentroidSigma centroid_sigma(const cv::Mat& image, const DotObservation& d, double noise, const AnalysisOptions& o) {
  CentroidSigma s;
  if (!std::isfinite(noise)) return s;
  const Ring r = ring_of(d, o.margin);
  Plane p;
  if (!fit_ring(image, d, r, p)) return s;
  const bool dark = o.polarity == Polarity::dark_dots;
  double w = 0, sxx = 0, syy = 0;
  const int x0 = static_cast<int>(std::floor(d.x - r.r0)), x1 = static_cast<int>(std::ceil(d.x + r.r0));
  const int y0 = static_cast<int>(std::floor(d.y - r.r0)), y1 = static_cast<int>(std::ceil(d.y + r.r0));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double dx = x - d.x, dy = y - d.y;
      if (std::hypot(dx, dy) > r.r0) continue;
      const double bg = p.a + p.b * dx + p.c * dy, v = pixel(image, x, y);
      const double wt = dark ? bg - v : v - bg;
      if (!(wt > 0)) continue;  // clipped at 0 (eq. 7.1): no first-order noise through it
      w += wt;
      sxx += dx * dx;
      syy += dy * dy;
    }
  if (!(w > 0)) return s;
  const double n2 = noise * noise;
  s.x = std::sqrt(n2 * sxx / (w * w) + (p.rxx > 0 ? n2 / p.rxx * (sxx / w) * (sxx / w) : 0));
  s.y = std::sqrt(n2 * syy / (w * w) + (p.ryy > 0 ? n2 / p.ryy * (syy / w) * (syy / w) : 0));
  return s;
}

std::vector<FieldSigma> propagate_mls(const MlsTable& t, const std::vector<Vec2>& reference,
                                      const std::vector<std::uint8_t>& tracked, const std::vector<Vec2>& dot_var,
                                      const MlsOptions& o, const std::vector<FieldValue<double>>& fields) {
  using Vec6 = Eigen::Matrix<double, 6, 1>;
  using Mat6 = Eigen::Matrix<double, 6, 6>;
  std::vector<FieldSigma> out(t.points.size());
  struct Entry {
    int j;
    double w, wx, wy;
    Vec6 p;
  };
  std::vector<Entry> e;
  for (std::size_t m = 0; m < t.points.size(); ++m) {
    if (fields[m].status != PointStatus::ok) continue;
    const Vec2 xm = t.points[m];
    const double rho = t.rho[m];
    e.clear();
    Mat6 A = Mat6::Zero();
    for (int k = t.offsets[m]; k < t.offsets[m + 1]; ++k) {
      const int j = t.dots[k];
      if (!tracked[j]) continue;
      const double xi = (reference[j].x - xm.x) / rho, eta = (reference[j].y - xm.y) / rho;
      double w = 0, dws = 0;
      weight_fn(o.weight, std::sqrt(xi * xi + eta * eta), w, dws);
      if (!(w > 0)) continue;
      Entry en{j, w, -xi * dws, -eta * dws, Vec6()};
      en.p << 1, xi, eta, xi * xi, eta * eta, xi * eta;
      A += w * en.p * en.p.transpose();
      e.push_back(en);
    }
    const Mat6 Ai = A.ldlt().solve(Mat6::Identity());
    const Vec6 g = Ai.col(0);
    Vec6 sx = Vec6::Zero(), sy = Vec6::Zero();
    for (const auto& en : e) {
      const double gp = g.dot(en.p);
      sx += en.wx * gp * en.p;
      sy += en.wy * gp * en.p;
    }
    const Vec6 ex = Vec6::Unit(1) - sx, ey = Vec6::Unit(2) - sy;
    double vux = 0, vuy = 0, vxx = 0, vyy = 0, vxy = 0;
    for (const auto& en : e) {
      const Vec6 q = en.w * (Ai * en.p);
      const double gp = g.dot(en.p);
      const double phi = en.w * gp;
      const double phx = (ex.dot(q) + en.wx * gp) / rho, phy = (ey.dot(q) + en.wy * gp) / rho;
      const Vec2 v = dot_var[en.j];
      vux += phi * phi * v.x;
      vuy += phi * phi * v.y;
      vxx += phx * phx * v.x;
      vyy += phy * phy * v.y;
      vxy += 0.25 * (phy * phy * v.x + phx * phx * v.y);
    }
    out[m] = {std::sqrt(vux), std::sqrt(vuy), std::sqrt(vxx), std::sqrt(vyy), std::sqrt(vxy)};
  }
  return out;
}

std::vector<FieldSigma> propagate_fe(const FeTable& t, const std::vector<std::uint8_t>& tracked,
                                     const std::vector<Vec2>& dot_var, const std::vector<FieldValue<double>>& fields) {
  std::vector<FieldSigma> out(t.points.size());
  std::unordered_map<int, std::array<double, 2>> phi;  // dot -> (d/dx, d/dy) coefficient of the gradient
  for (std::size_t m = 0; m < t.points.size(); ++m) {
    if (fields[m].status != PointStatus::ok) continue;
    double vux = 0, vuy = 0, vxx = 0, vyy = 0, vxy = 0;
    for (int i = 0; i < 3; ++i) {
      const int j = t.tri[3 * m + i];
      if (j < 0 || !tracked[j]) continue;
      const double n = t.N[3 * m + i];
      vux += n * n * dot_var[j].x;
      vuy += n * n * dot_var[j].y;
    }
    // The recovered gradient is sum_t c_t G_t / sum_t c_t over the triangles kept: collect
    // each dot's coefficient.
    phi.clear();
    double s = 0;
    for (int e = t.offsets[m]; e < t.offsets[m + 1]; ++e) {
      const std::size_t q = 3 * static_cast<std::size_t>(t.support[e]);
      const int* v = &t.tri_dots[q];
      if (!tracked[v[0]] || !tracked[v[1]] || !tracked[v[2]]) continue;
      s += t.coef[e];
      for (int k = 0; k < 3; ++k) {
        auto& c = phi[v[k]];
        c[0] += t.coef[e] * t.tri_gx[q + k];
        c[1] += t.coef[e] * t.tri_gy[q + k];
      }
    }
    if (s > 0)
      for (const auto& [j, c] : phi) {
        const Vec2 v = dot_var[j];
        const double px = c[0] / s, py = c[1] / s;
        vxx += px * px * v.x;
        vyy += py * py * v.y;
        vxy += 0.25 * (py * py * v.x + px * px * v.y);
      }
    out[m] = {std::sqrt(vux), std::sqrt(vuy), std::sqrt(vxx), std::sqrt(vyy), std::sqrt(vxy)};
  }
  return out;
}

FrameUncertainty frame_uncertainty(const cv::Mat& reference, const cv::Mat& frame, const Backend& b,
                                   const FrameOutput& out) {
  const AnalysisOptions& ao = b.options().analysis;
  FrameUncertainty u;
  const auto& rdots = b.reference_dots();
  u.reference_noise = estimate_noise(reference, rdots, ao);
  u.frame_noise = estimate_noise(frame, out.dots, ao);
  u.reference_dots.resize(rdots.size());
  u.frame_dots.resize(out.dots.size());
  u.points.resize(b.points().size());
  if (u.reference_noise.ok())
    for (std::size_t k = 0; k < rdots.size(); ++k) u.reference_dots[k] = centroid_sigma(reference, rdots[k], u.reference_noise.sigma, ao);
  if (u.frame_noise.ok())
    for (std::size_t k = 0; k < out.dots.size(); ++k) u.frame_dots[k] = centroid_sigma(frame, out.dots[k], u.frame_noise.sigma, ao);
  if (!u.reference_noise.ok() || !u.frame_noise.ok()) return u;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<Vec2> var(rdots.size(), Vec2{nan, nan});
  for (std::size_t j = 0; j < rdots.size(); ++j) {
    const int k = j < out.matches.ref_to_def.size() ? out.matches.ref_to_def[j] : -1;
    if (k < 0) continue;
    const CentroidSigma a = u.reference_dots[j], c = u.frame_dots[static_cast<std::size_t>(k)];
    var[j] = {a.x * a.x + c.x * c.x, a.y * a.y + c.y * c.y};
  }
  if (b.options().interp == Interp::mls)
    u.points = propagate_mls(b.mls_table(), b.reference_positions(), out.tracked, var, b.options().mls, out.fields);
  else
    u.points = propagate_fe(b.fe_table(), out.tracked, var, out.fields);
  return u;
}

}  // namespace dtflop::dct
