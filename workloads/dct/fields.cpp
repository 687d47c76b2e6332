#include "workloads/dct/fields.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <set>

#include <fmt/format.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "model/errors.hpp"
#include "workloads/dct/analysis.hpp"
#include "workloads/dct/tracking.hpp"

namespace dtflop::dct {
namespace {

// How far inside a support's edge a dot must lie, relative to the radius, for its scaled distance
// to stay below 1 when the device computes it in float32 (a few float32 roundings: ~5e-7).
constexpr double kFloat32Edge = 1e-4;

}  // namespace

std::vector<Vec2> grid_points(double x0, double y0, double x1, double y1, int nx, int ny) {
  if (nx < 1 || ny < 1 || static_cast<std::int64_t>(nx) * ny > 16'777'216)
    throw InputError(fmt::format("interpolation grid {}x{} must have 1..16M points", nx, ny));
  std::vector<Vec2> p;
  p.reserve(static_cast<std::size_t>(nx) * ny);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      p.push_back({nx == 1 ? 0.5 * (x0 + x1) : x0 + (x1 - x0) * i / (nx - 1),
                   ny == 1 ? 0.5 * (y0 + y1) : y0 + (y1 - y0) * j / (ny - 1)});
  return p;
}

std::vector<Vec2> grid_points_over(const std::vector<Vec2>& dots, int nx, int ny, double inset) {
  if (dots.empty()) throw InputError("no dots to place interpolation points over");
  double x0 = dots[0].x, x1 = x0, y0 = dots[0].y, y1 = y0;
  for (const auto& d : dots) {
    x0 = std::min(x0, d.x); x1 = std::max(x1, d.x);
    y0 = std::min(y0, d.y); y1 = std::max(y1, d.y);
  }
  if (x1 - x0 > 2 * inset) { x0 += inset; x1 -= inset; }
  if (y1 - y0 > 2 * inset) { y0 += inset; y1 -= inset; }
  return grid_points(x0, y0, x1, y1, nx, ny);
}

std::string Support::str() const {
  return kind == Kind::dots ? fmt::format("{}dots", dots) : fmt::format("{:g}px", radius);
}

Support parse_support(const std::string& text) {
  Support s;
  auto number = [&](const std::string& t) {
    try {
      std::size_t used = 0;
      const double v = std::stod(t, &used);
      if (used != t.size()) throw std::invalid_argument("trailing");
      return v;
    } catch (const std::exception&) {
      throw InputError(fmt::format("support '{}' is not understood; write e.g. 60dots or 12.5px", text));
    }
  };
  auto ends = [&](const char* suffix) {
    const std::string sfx(suffix);
    return text.size() > sfx.size() && text.compare(text.size() - sfx.size(), sfx.size(), sfx) == 0;
  };
  if (ends("px")) {
    s.kind = Support::Kind::radius;
    s.radius = number(text.substr(0, text.size() - 2));
    if (!(s.radius > 0) || !(s.radius <= 16384))
      throw InputError(fmt::format("support radius {} must be a finite number in (0, 16384] px", text));
  } else {
    const std::string t = ends("dots") ? text.substr(0, text.size() - 4) : text;
    const double v = number(t);
    if (v != std::floor(v) || v < 6 || v > 4096)
      throw InputError(fmt::format("support of {} dots must be a whole number in 6..4096 (the quadratic basis "
                                   "needs at least 6)", t));
    s.kind = Support::Kind::dots;
    s.dots = static_cast<int>(v);
  }
  return s;
}

std::string to_string(Interp i) { return i == Interp::mls ? "mls" : "fe"; }
Interp interp_from_string(const std::string& s) {
  if (s == "mls") return Interp::mls;
  if (s == "fe") return Interp::fe;
  throw InputError(fmt::format("interpolation '{}' is unknown; use mls or fe", s));
}
std::string to_string(Weight w) {
  switch (w) {
    case Weight::cubic_spline: return "cubic";
    case Weight::quartic: return "quartic";
    case Weight::gaussian: return "gaussian";
  }
  return "?";
}
Weight weight_from_string(const std::string& s) {
  if (s == "cubic") return Weight::cubic_spline;
  if (s == "quartic") return Weight::quartic;
  if (s == "gaussian") return Weight::gaussian;
  throw InputError(fmt::format("weight function '{}' is unknown; use cubic, quartic or gaussian", s));
}
std::string to_string(PointStatus s) {
  switch (s) {
    case PointStatus::ok: return "ok";
    case PointStatus::too_few_dots: return "too_few_dots";
    case PointStatus::ill_conditioned: return "ill_conditioned";
    case PointStatus::outside_mesh: return "outside_mesh";
    case PointStatus::lost_vertex: return "lost_vertex";
    case PointStatus::far_from_dots: return "far_from_dots";
  }
  return "?";
}

MlsTable build_mls_table(const std::vector<Vec2>& reference, const std::vector<Vec2>& points, const MlsOptions& o) {
  if (reference.size() < 6)
    throw InputError(fmt::format("the reference frame holds {} dot(s); MLS needs at least 6", reference.size()));
  // The default support (200 dots) shrinks to the dots there are; one asked for does not.
  const int count = o.support.kind == Support::Kind::dots && o.support_at_most_found
                        ? std::min(o.support.dots, static_cast<int>(reference.size()))
                        : o.support.dots;
  if (o.support.kind == Support::Kind::dots && count > static_cast<int>(reference.size()))
    throw InputError(fmt::format("support of {} dots asks for more than the {} dots found; give a smaller --support "
                                 "(e.g. {}dots)",
                                 o.support.dots, reference.size(), std::max<std::size_t>(6, reference.size() / 3)));
  PointIndex index(reference);
  const double gap = o.max_gap * median_spacing(reference);
  MlsTable t;
  t.points = points;
  t.offsets.assign(1, 0);
  t.rho.reserve(points.size());
  t.geometry.reserve(points.size());
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  std::vector<std::pair<std::uint32_t, double>> hits;
  for (const auto& p : points) {
    double rho;
    if (o.support.kind == Support::Kind::dots) {
      index.knn(p, count + 1, idx, d2);
      const double dn = std::sqrt(d2[static_cast<std::size_t>(count) - 1]);
      const double dn1 = idx.size() > static_cast<std::size_t>(count) ? std::sqrt(d2.back()) : dn * 1.05;
      // Halfway to the next dot, and at least kFloat32Edge of dn beyond the N-th: where the two
      // are nearly equidistant, the N-th dot's scaled distance dn / rho must stay below 1 in
      // float32 too, or its weight W(1) = 0 drops it on the device and not on the host (the
      // support counts then differed, 40 against 39, on one H200 specimen in 50). Only the N
      // listed dots are used, so a radius reaching the (N+1)-th changes nothing else.
      rho = std::max(0.5 * (dn + dn1), dn * (1 + kFloat32Edge));
      idx.resize(static_cast<std::size_t>(count));
      for (auto k : idx) t.dots.push_back(static_cast<std::int32_t>(k));
      t.geometry.push_back(gap > 0 && std::sqrt(d2[0]) > gap ? PointStatus::far_from_dots : PointStatus::ok);
    } else {
      // The same edge for a radius: a dot within kFloat32Edge of it is left out of the table
      // (both backends read the table), since its scaled distance may round to 1 in float32 and
      // its weight to 0 on the device alone (the support counts differed, 18 against 17, and the
      // strain by 4.9e-6, on one H100 specimen in 50 with a 45 px Gaussian support). Its weight is
      // W(1 - 1e-4): below 4e-12 of the peak for the splines, 3e-8 for the Gaussian.
      rho = o.support.radius;
      index.within(p, rho, hits);
      const double edge = rho * (1 - kFloat32Edge);
      for (const auto& h : hits)
        if (h.second < edge * edge) t.dots.push_back(static_cast<std::int32_t>(h.first));
      index.knn(p, 1, idx, d2);
      t.geometry.push_back(gap > 0 && std::sqrt(d2[0]) > gap ? PointStatus::far_from_dots : PointStatus::ok);
    }
    t.rho.push_back(rho);
    t.offsets.push_back(static_cast<std::int32_t>(t.dots.size()));
  }
  return t;
}

std::vector<FieldValue<double>> evaluate_mls(const MlsTable& t, const std::vector<Vec2>& reference,
                                             const std::vector<Vec2>& disp, const std::vector<std::uint8_t>& tracked,
                                             const MlsOptions& o, int threads) {
  const std::size_t n = t.points.size();
  std::vector<FieldValue<double>> out(n);
  const kernels::MlsSupports<Vec2> supports{t.offsets.data(), t.dots.data(), t.points.data(), t.rho.data(),
                                            t.geometry.data()};
  const kernels::MlsDots<Vec2> dots{reference.data(), disp.data(), tracked.data()};
  const kernels::MlsSettings settings{o.weight, o.min_dots, o.min_pivot_ratio};
  // The loop the cpu-mls probe times (kernels/point_fields.hpp).
  auto work = [&](const cv::Range& r) { kernels::mls_fields(supports, dots, settings, r.start, r.end, out.data()); };
  if (threads > 1)
    with_opencv_threads(threads, [&] { cv::parallel_for_(cv::Range(0, static_cast<int>(n)), work); });
  else work(cv::Range(0, static_cast<int>(n)));
  return out;
}

FeTable build_fe_table(const std::vector<Vec2>& reference, const std::vector<Vec2>& points, double max_gap,
                       const MlsOptions& recovery) {
  if (reference.size() < 3)
    throw InputError(fmt::format("the reference frame holds {} dot(s); FE needs at least 3", reference.size()));
  double x0 = reference[0].x, x1 = x0, y0 = reference[0].y, y1 = y0;
  for (const auto& d : reference) {
    x0 = std::min(x0, d.x); x1 = std::max(x1, d.x);
    y0 = std::min(y0, d.y); y1 = std::max(y1, d.y);
  }
  for (const auto& p : points) {
    x0 = std::min(x0, p.x); x1 = std::max(x1, p.x);
    y0 = std::min(y0, p.y); y1 = std::max(y1, p.y);
  }
  cv::Subdiv2D sub(cv::Rect(static_cast<int>(std::floor(x0)) - 2, static_cast<int>(std::floor(y0)) - 2,
                            static_cast<int>(std::ceil(x1 - x0)) + 5, static_cast<int>(std::ceil(y1 - y0)) + 5));
  std::vector<int> vertex_dot;
  for (std::size_t j = 0; j < reference.size(); ++j) {
    const int v = sub.insert(cv::Point2f(static_cast<float>(reference[j].x), static_cast<float>(reference[j].y)));
    if (v >= static_cast<int>(vertex_dot.size())) vertex_dot.resize(static_cast<std::size_t>(v) + 1, -1);
    if (vertex_dot[v] < 0) vertex_dot[v] = static_cast<int>(j);
  }
  const double spacing = median_spacing(reference);
  const double gap = max_gap * spacing;
  auto vdot = [&](int v) { return v >= 0 && v < static_cast<int>(vertex_dot.size()) ? vertex_dot[v] : -1; };
  auto len = [&](int i, int j) { return std::hypot(reference[i].x - reference[j].x, reference[i].y - reference[j].y); };
  // Barycentric coordinates of p in triangle (a, b, c) of dots; false if degenerate.
  auto bary = [&](int a, int b, int c, Vec2 p, double* N, double* Nx, double* Ny) {
    const Vec2 A = reference[a], B = reference[b], C = reference[c];
    const double det = (B.x - A.x) * (C.y - A.y) - (C.x - A.x) * (B.y - A.y);
    if (std::abs(det) < 1e-9) return false;
    Nx[0] = (B.y - C.y) / det; Ny[0] = (C.x - B.x) / det;
    Nx[1] = (C.y - A.y) / det; Ny[1] = (A.x - C.x) / det;
    Nx[2] = (A.y - B.y) / det; Ny[2] = (B.x - A.x) / det;
    N[0] = ((B.x - p.x) * (C.y - p.y) - (C.x - p.x) * (B.y - p.y)) / det;
    N[1] = ((C.x - p.x) * (A.y - p.y) - (A.x - p.x) * (C.y - p.y)) / det;
    N[2] = 1 - N[0] - N[1];
    return true;
  };
  FeTable t;
  t.points = points;
  // The triangles: every face of the subdivision whose three vertices are dots, once.
  // getLeadingEdgeList() gives one directed edge per face (the face on its left), so each face
  // is taken from its own leading edge; the face across it (the reversed edge) is looked at too
  // and every face is kept the first time its vertex triple is seen. (Keeping a face only from
  // the edge whose origin is its smallest dot, as before, lost a third of the triangles: their
  // holes in the tiling left each bordering dot's displacement in the recovered gradient, a
  // noise that grew with the support; docs/dct.md "FE".)
  std::vector<Vec2> centroid;
  std::vector<double> area;
  std::vector<std::uint8_t> sound;
  {
    std::vector<int> lead;
    sub.getLeadingEdgeList(lead);
    std::set<std::array<int, 3>> seen;
    for (int e0 : lead)
      for (int e : {e0, sub.rotateEdge(e0, 2)}) {
        const int e1 = sub.getEdge(e, cv::Subdiv2D::NEXT_AROUND_LEFT);
        const int e2 = sub.getEdge(e1, cv::Subdiv2D::NEXT_AROUND_LEFT);
        if (sub.getEdge(e2, cv::Subdiv2D::NEXT_AROUND_LEFT) != e) continue;
        const int a = vdot(sub.edgeOrg(e)), b = vdot(sub.edgeOrg(e1)), c = vdot(sub.edgeOrg(e2));
        if (a < 0 || b < 0 || c < 0) continue;
        std::array<int, 3> key = {a, b, c};
        std::sort(key.begin(), key.end());
        if (!seen.insert(key).second) continue;
        double n[3], gx[3], gy[3];
        if (!bary(a, b, c, reference[static_cast<std::size_t>(a)], n, gx, gy)) continue;
        const Vec2 A = reference[a], B = reference[b], C = reference[c];
        const double det = (B.x - A.x) * (C.y - A.y) - (C.x - A.x) * (B.y - A.y);
        t.tri_dots.insert(t.tri_dots.end(), {a, b, c});
        t.tri_gx.insert(t.tri_gx.end(), gx, gx + 3);
        t.tri_gy.insert(t.tri_gy.end(), gy, gy + 3);
        centroid.push_back({(A.x + B.x + C.x) / 3, (A.y + B.y + C.y) / 3});
        area.push_back(0.5 * std::abs(det));
        const double longest = std::max({len(a, b), len(b, c), len(c, a)});
        sound.push_back(!(max_gap > 0 && longest > 2 * max_gap * spacing));
      }
    t.triangles = static_cast<std::int64_t>(area.size());
  }
  // The support radius per point, as MLS would choose it.
  MlsOptions ro = recovery;
  ro.max_gap = 0;
  if (ro.support.kind == Support::Kind::dots)
    ro.support.dots = std::min<int>(ro.support.dots, static_cast<int>(reference.size()));
  const MlsTable radii = build_mls_table(reference, points, ro);
  PointIndex index(reference);
  if (centroid.empty()) {  // no triangle (collinear dots): a far sentinel the index can hold
    centroid.push_back({x0 - 1e9, y0 - 1e9});
    sound.push_back(0);
  }
  const PointIndex tri_index(centroid);  // keeps a reference to `centroid`
  // Each triangle's weight in the recovery, besides the MLS weight of its centroid's distance:
  // its area x a taper that rises from 0 on the dots' convex hull to 1 one support radius
  // inside it. With area weights the recovered gradient sum_t c(x_t) A_t G_t is a quadrature of
  // the integral of c grad u_h over the tiled hull, which integrates by parts to -integral
  // u_h grad c: each dot's displacement enters through the smooth kernel's gradient times the
  // dot's area, and the terms of neighbouring triangles cancel. Any factor that varies from
  // triangle to triangle (a shape quality, a missing triangle) breaks that cancellation and
  // leaves each dot's displacement times c itself, a noise that grows against the smooth part
  // as the support widens; where c does not vanish on the hull the same term stays along it,
  // hence the taper (over the whole support radius: a steeper one concentrates the kernel near
  // the hull). Measured on independent renders (`dct_quality fe-sd`, `fe-ratio`; docs/dct.md
  // "FE"). A linear field is still recovered exactly (any weights do).
  constexpr double kFeHullTaper = 1.0;  // of the point's support radius
  std::vector<double> tri_weight(centroid.size(), 0.0), hull_dist(centroid.size(), 0.0);
  {
    std::vector<cv::Point2f> pts2, hull;
    for (const auto& d : reference) pts2.emplace_back(static_cast<float>(d.x), static_cast<float>(d.y));
    cv::convexHull(pts2, hull);
    for (std::size_t k = 0; k < tri_weight.size(); ++k) {
      if (!sound[k]) continue;
      tri_weight[k] = area[k];
      if (hull.size() >= 3)
        hull_dist[k] = cv::pointPolygonTest(
            hull, cv::Point2f(static_cast<float>(centroid[k].x), static_cast<float>(centroid[k].y)), true);
    }
  }
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  std::vector<std::pair<std::uint32_t, double>> hits;
  t.offsets.assign(1, 0);
  for (std::size_t m = 0; m < points.size(); ++m) {
    const Vec2 p = points[m];
    double N[3] = {};
    int tri[3] = {-1, -1, -1};
    PointStatus st = PointStatus::outside_mesh;
    int edge = 0, vertex = 0;
    const int loc = sub.locate(cv::Point2f(static_cast<float>(p.x), static_cast<float>(p.y)), edge, vertex);
    std::vector<int> edges;
    if (loc == cv::Subdiv2D::PTLOC_INSIDE || loc == cv::Subdiv2D::PTLOC_ON_EDGE) {
      edges = {edge, sub.rotateEdge(edge, 2)};
    } else if (loc == cv::Subdiv2D::PTLOC_VERTEX) {
      int e0 = 0;
      sub.getVertex(vertex, &e0);
      int e = e0;
      for (int guard = 0; guard < 64; ++guard) {
        edges.push_back(e);
        e = sub.getEdge(e, cv::Subdiv2D::NEXT_AROUND_ORG);
        if (e == e0) break;
      }
    }
    for (int e : edges) {
      const int e2 = sub.getEdge(e, cv::Subdiv2D::NEXT_AROUND_LEFT);
      const int a = vdot(sub.edgeOrg(e)), b = vdot(sub.edgeDst(e)), c = vdot(sub.edgeDst(e2));
      if (a < 0 || b < 0 || c < 0) continue;
      double n[3], nx[3], ny[3];
      if (!bary(a, b, c, p, n, nx, ny)) continue;
      if (n[0] < -1e-9 || n[1] < -1e-9 || n[2] < -1e-9) continue;
      std::copy(n, n + 3, N);
      tri[0] = a; tri[1] = b; tri[2] = c;
      st = PointStatus::ok;
      break;
    }
    index.knn(p, 1, idx, d2);
    if (st == PointStatus::ok && gap > 0 && std::sqrt(d2[0]) > gap) st = PointStatus::far_from_dots;
    // The recovery: fit G0 + G1 (x - p) to the sound triangles' gradients at their centroids,
    // weights area x W(|c_t - p| / rho); in coordinates scaled by rho, q_t = [1, xi, eta].
    if (st == PointStatus::ok) {
      const double rho = radii.rho[m];
      tri_index.within(p, rho, hits);
      cv::Matx33d M = cv::Matx33d::zeros();
      std::vector<std::pair<int, cv::Vec3d>> rows;
      for (const auto& h : hits) {
        if (!sound[h.first]) continue;
        const double xi = (centroid[h.first].x - p.x) / rho, eta = (centroid[h.first].y - p.y) / rho;
        double w = 0, dws = 0;
        weight_fn(recovery.weight, std::sqrt(xi * xi + eta * eta), w, dws);
        if (!(w > 0)) continue;
        w *= tri_weight[h.first] * std::clamp(hull_dist[h.first] / (kFeHullTaper * rho), 0.0, 1.0);
        if (!(w > 0)) continue;
        const cv::Vec3d q(1, xi, eta);
        M += w * (q * q.t());
        rows.push_back({static_cast<int>(h.first), w * q});
      }
      if (rows.size() < 3) {
        st = PointStatus::too_few_dots;
      } else {
        cv::Matx33d Mi;
        const cv::Vec3d ev = [&] { cv::Vec3d v; cv::eigen(M, v); return v; }();
        if (!(ev[2] > recovery.min_pivot_ratio * ev[0])) {
          st = PointStatus::ill_conditioned;
        } else {
          Mi = M.inv(cv::DECOMP_CHOLESKY);
          const cv::Vec3d r0(Mi(0, 0), Mi(0, 1), Mi(0, 2));
          for (const auto& [k, wq] : rows) {
            t.support.push_back(k);
            t.coef.push_back(r0.dot(wq));
          }
        }
      }
    }
    for (int k = 0; k < 3; ++k) {
      t.tri.push_back(tri[k]);
      t.N.push_back(N[k]);
    }
    t.geometry.push_back(st);
    t.offsets.push_back(static_cast<std::int32_t>(t.support.size()));
  }
  return t;
}

std::vector<FieldValue<double>> evaluate_fe(const FeTable& t, const std::vector<Vec2>& disp,
                                            const std::vector<std::uint8_t>& tracked, int threads) {
  const std::size_t n = t.points.size();
  std::vector<FieldValue<double>> out(n);
  auto work = [&](const cv::Range& r) {
    for (int m = r.start; m < r.end; ++m) {
      FieldValue<double>& f = out[static_cast<std::size_t>(m)];
      f.status = t.geometry[m];
      if (f.status != PointStatus::ok) continue;
      const int* tri = &t.tri[3 * static_cast<std::size_t>(m)];
      if (!tracked[tri[0]] || !tracked[tri[1]] || !tracked[tri[2]]) {
        f.status = PointStatus::lost_vertex;
        continue;
      }
      FePoint<double> fp;
      double Ux[3], Uy[3];
      for (int k = 0; k < 3; ++k) { Ux[k] = disp[tri[k]].x; Uy[k] = disp[tri[k]].y; }
      fp.own(&t.N[3 * static_cast<std::size_t>(m)], Ux, Uy);
      for (int e = t.offsets[m]; e < t.offsets[m + 1]; ++e) {
        const std::size_t q = 3 * static_cast<std::size_t>(t.support[e]);
        const int* v = &t.tri_dots[q];
        if (!tracked[v[0]] || !tracked[v[1]] || !tracked[v[2]]) continue;
        for (int k = 0; k < 3; ++k) { Ux[k] = disp[v[k]].x; Uy[k] = disp[v[k]].y; }
        fp.add(t.coef[e], &t.tri_gx[q], &t.tri_gy[q], Ux, Uy);
      }
      f = fp.field();
    }
  };
  if (threads > 1)
    with_opencv_threads(threads, [&] { cv::parallel_for_(cv::Range(0, static_cast<int>(n)), work); });
  else work(cv::Range(0, static_cast<int>(n)));
  return out;
}

}  // namespace dtflop::dct
