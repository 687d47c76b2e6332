#include "workloads/dct/stereo_dots.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>

#include <fmt/format.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "workloads/dct/kernels.hpp"
#include "workloads/dct/tracking.hpp"

namespace dtflop::dct::stereo {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::vector<cv::Point2d> as_points(const std::vector<Vec2>& v) {
  std::vector<cv::Point2d> p;
  p.reserve(v.size());
  for (const auto& x : v) p.emplace_back(x.x, x.y);
  return p;
}

std::vector<Vec2> as_vec2(const std::vector<cv::Point2d>& v) {
  std::vector<Vec2> p;
  p.reserve(v.size());
  for (const auto& x : v) p.emplace_back(x.x, x.y);
  return p;
}

}  // namespace

void validate(const StereoMatchOptions& o) {
  if (!std::isfinite(o.epipolar_tolerance) || o.epipolar_tolerance <= 0 || o.epipolar_tolerance > 100)
    throw InputError(fmt::format("stereo epipolar tolerance {} px is not in (0, 100]; 1.5 suits a good calibration",
                                 o.epipolar_tolerance));
  if (!std::isfinite(o.disparity_tolerance) || o.disparity_tolerance <= 0 || o.disparity_tolerance >= 0.5)
    throw InputError(fmt::format("stereo disparity tolerance {} (x the dot spacing) is not in (0, 0.5); 0.3 is usual",
                                 o.disparity_tolerance));
  if (o.neighbours < 2 || o.neighbours > 32)
    throw InputError(fmt::format("stereo neighbours {} is not in 2..32; 6 is usual", o.neighbours));
}

std::string to_string(StereoLost r) {
  switch (r) {
    case StereoLost::none: return "";
    case StereoLost::nothing_on_row: return "nothing on its epipolar row";
    case StereoLost::ambiguous: return "ambiguous";
    case StereoLost::claimed_by_other: return "right dot claimed by another";
    case StereoLost::off_surface: return "no candidate fits its neighbours' disparity";
    case StereoLost::lost_left: return "lost by the left camera's tracking";
    case StereoLost::lost_right: return "its partner lost by the right camera's tracking";
    case StereoLost::off_epipolar: return "deformed pair off its epipolar row";
  }
  return "?";
}

Rectification rectify(const Rig& rig) {
  cv::Mat R1, R2, P1, P2, Q;
  cv::stereoRectify(cv::Mat(rig.left.K), rig.left.dist, cv::Mat(rig.right.K), rig.right.dist, rig.left.size,
                    cv::Mat(rig.R), cv::Mat(rig.T), R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, -1);
  Rectification r;
  r.R1 = cv::Matx33d(R1);
  r.R2 = cv::Matx33d(R2);
  r.P1 = cv::Matx34d(P1);
  r.P2 = cv::Matx34d(P2);
  r.vertical = std::abs(r.P2(1, 3)) > std::abs(r.P2(0, 3));
  const double t = r.vertical ? r.P2(1, 3) : r.P2(0, 3);
  // x_right = x_left + t / Z, so left - right = -t / Z.
  r.sign = t < 0 ? 1 : -1;
  return r;
}

std::vector<cv::Point2d> rectified(const Rig& rig, const Rectification& r, bool right,
                                   const std::vector<cv::Point2d>& points) {
  if (points.empty()) return {};
  std::vector<cv::Point2d> out;
  const Camera& c = right ? rig.right : rig.left;
  cv::undistortPoints(points, out, cv::Mat(c.K), c.dist, cv::Mat(right ? r.R2 : r.R1), cv::Mat(right ? r.P2 : r.P1));
  return out;
}

std::string StereoMatches::summary() const {
  std::array<int, 8> n{};
  for (StereoLost r : lost) ++n[static_cast<std::size_t>(r)];
  std::string s = fmt::format("{} of {} left dots matched to the right view", matched, left_to_right.size());
  std::string lostp;
  for (StereoLost r : {StereoLost::nothing_on_row, StereoLost::ambiguous, StereoLost::claimed_by_other,
                       StereoLost::off_surface})
    if (n[static_cast<std::size_t>(r)])
      lostp += fmt::format("{}{} {}", lostp.empty() ? "" : ", ", n[static_cast<std::size_t>(r)], to_string(r));
  if (!lostp.empty()) s += "; lost: " + lostp;
  s += fmt::format("; {} right dots unmatched", unmatched_right.size());
  return s;
}

StereoMatches match_stereo(const Rig& rig, const std::vector<cv::Point2d>& left, const std::vector<cv::Point2d>& right,
                           const StereoMatchOptions& o) {
  validate(o);
  if (left.empty() || right.empty())
    throw InputError(fmt::format("stereo matching needs dots in both views (left {}, right {}); check both cameras "
                                 "see the dots",
                                 left.size(), right.size()));
  const std::size_t n = left.size();
  const Rectification rc = rectify(rig);
  const auto rl = rectified(rig, rc, false, left), rr = rectified(rig, rc, true, right);
  auto along = [&](const cv::Point2d& p) { return rc.vertical ? p.y : p.x; };
  auto across = [&](const cv::Point2d& p) { return rc.vertical ? p.x : p.y; };
  const double spacing_r = median_spacing(as_vec2(rr));
  const double dtol = o.disparity_tolerance * (spacing_r > 0 ? spacing_r : 1e9);

  // Candidates: right dots on the left dot's row (within the tolerance), in front of both cameras.
  std::vector<std::size_t> by_row(rr.size());
  std::iota(by_row.begin(), by_row.end(), 0);
  std::sort(by_row.begin(), by_row.end(), [&](auto a, auto b) { return across(rr[a]) < across(rr[b]); });
  std::vector<double> rows(by_row.size());
  for (std::size_t k = 0; k < by_row.size(); ++k) rows[k] = across(rr[by_row[k]]);
  struct Cand {
    int j;
    double d;
  };
  std::vector<std::vector<Cand>> cand(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double v = across(rl[i]);
    auto lo = std::lower_bound(rows.begin(), rows.end(), v - o.epipolar_tolerance);
    for (auto it = lo; it != rows.end() && *it <= v + o.epipolar_tolerance; ++it) {
      const std::size_t j = by_row[static_cast<std::size_t>(it - rows.begin())];
      const double d = along(rl[i]) - along(rr[j]);
      if (rc.sign * d > 0) cand[i].push_back({static_cast<int>(j), d});
    }
  }
  // Each left dot's neighbours in the left image.
  const std::vector<Vec2> lv = as_vec2(left);
  const PointIndex index(lv);
  const int k = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(o.neighbours) + 1, n));
  std::vector<std::vector<std::uint32_t>> nbr(n);
  {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    for (std::size_t i = 0; i < n; ++i) {
      index.knn(lv[i], k, idx, d2);
      for (auto q : idx)
        if (q != i) nbr[i].push_back(q);
    }
  }
  // The candidate of dot q that fits the mean disparity of its matched neighbours: its index in
  // cand[q], -1 none fits, -2 two fit, -3 no matched neighbour.
  auto choose = [&](std::size_t q, const std::vector<int>& a, const std::vector<double>& disp) {
    double sum = 0;
    int m = 0;
    for (auto p : nbr[q])
      if (a[p] >= 0) {
        sum += disp[p];
        ++m;
      }
    if (m == 0) return -3;
    const double pred = sum / m;
    int best = -1, fits = 0;
    double bd = 1e300;
    for (std::size_t c = 0; c < cand[q].size(); ++c) {
      const double e = std::abs(cand[q][c].d - pred);
      if (e <= dtol) ++fits;
      if (e < bd) {
        bd = e;
        best = static_cast<int>(c);
      }
    }
    if (fits == 0) return -1;
    if (fits > 1) return -2;
    return best;
  };
  // Grows the matching from seed dot s taking candidate c; returns the right index per left dot.
  auto grow = [&](std::size_t s, std::size_t c, std::vector<int>& a, std::vector<double>& disp) {
    a.assign(n, -1);
    disp.assign(n, 0);
    a[s] = cand[s][c].j;
    disp[s] = cand[s][c].d;
    std::vector<std::size_t> queue = {s};
    int reach = 1;
    for (std::size_t h = 0; h < queue.size(); ++h) {
      for (auto q : nbr[queue[h]]) {
        if (a[q] >= 0) continue;
        const int b = choose(q, a, disp);
        if (b < 0) continue;  // tried again when another neighbour is matched
        a[q] = cand[q][static_cast<std::size_t>(b)].j;
        disp[q] = cand[q][static_cast<std::size_t>(b)].d;
        queue.push_back(q);
        ++reach;
      }
    }
    return reach;
  };
  // Seeds: up to three dots with candidates, nearest the left dots' centre and halfway to two corners.
  cv::Point2d centre(0, 0);
  for (const auto& p : left) centre += p;
  centre *= 1.0 / static_cast<double>(n);
  const cv::Rect2d box = cv::boundingRect(std::vector<cv::Point2f>(left.begin(), left.end()));
  const cv::Point2d aims[] = {centre, (centre + box.tl()) * 0.5, (centre + box.br()) * 0.5};
  std::vector<std::size_t> seeds;
  for (const auto& aim : aims) {
    std::size_t best = n;
    double bd = 1e300;
    for (std::size_t i = 0; i < n; ++i)
      if (!cand[i].empty() && cv::norm(left[i] - aim) < bd &&
          std::find(seeds.begin(), seeds.end(), i) == seeds.end()) {
        bd = cv::norm(left[i] - aim);
        best = i;
      }
    if (best < n) seeds.push_back(best);
  }
  StereoMatches m;
  m.left_to_right.assign(n, -1);
  m.lost.assign(n, StereoLost::none);
  m.row_offset_px.assign(n, kNaN);
  std::vector<std::vector<int>> hyp;
  std::vector<int> reach;
  std::vector<int> a;
  std::vector<double> disp;
  for (auto s : seeds)
    for (std::size_t c = 0; c < cand[s].size(); ++c) {
      reach.push_back(grow(s, c, a, disp));
      hyp.push_back(a);
    }
  m.seeds_tried = static_cast<int>(hyp.size());
  std::size_t best = 0;
  for (std::size_t h = 1; h < hyp.size(); ++h)
    if (reach[h] > reach[best]) best = h;
  if (!hyp.empty()) {
    m.best_reach = reach[best];
    // The best competitor: a matching that differs from the best on most of the dots both match.
    for (std::size_t h = 0; h < hyp.size(); ++h) {
      if (h == best) continue;
      int both = 0, same = 0;
      for (std::size_t i = 0; i < n; ++i)
        if (hyp[h][i] >= 0 && hyp[best][i] >= 0) {
          ++both;
          same += hyp[h][i] == hyp[best][i];
        }
      if (same * 2 < both || both == 0) m.second_reach = std::max(m.second_reach, reach[h]);
    }
  }
  const bool tie = hyp.empty() || m.best_reach < 3 || m.second_reach >= m.best_reach;
  if (!hyp.empty()) a = hyp[best];
  else a.assign(n, -1);
  // Final pass with every match known: dots the growth left out get their reason.
  disp.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i)
    if (a[i] >= 0) disp[i] = along(rl[i]) - along(rr[static_cast<std::size_t>(a[i])]);
  for (std::size_t i = 0; i < n; ++i) {
    if (cand[i].empty()) {
      m.lost[i] = StereoLost::nothing_on_row;
      a[i] = -1;
    } else if (tie) {
      m.lost[i] = m.best_reach >= 3 ? StereoLost::ambiguous : StereoLost::off_surface;
      a[i] = -1;
    } else if (a[i] < 0) {
      const int b = choose(i, a, disp);
      m.lost[i] = b == -2 ? StereoLost::ambiguous : StereoLost::off_surface;
    }
  }
  std::vector<int> users(right.size(), 0);
  for (std::size_t i = 0; i < n; ++i)
    if (a[i] >= 0) ++users[static_cast<std::size_t>(a[i])];
  for (std::size_t i = 0; i < n; ++i) {
    if (a[i] < 0) continue;
    const auto j = static_cast<std::size_t>(a[i]);
    if (users[j] > 1) {
      m.lost[i] = StereoLost::claimed_by_other;
      continue;
    }
    m.left_to_right[i] = a[i];
    m.row_offset_px[i] = across(rr[j]) - across(rl[i]);
    ++m.matched;
  }
  std::vector<std::uint8_t> taken(right.size(), 0);
  for (int j : m.left_to_right)
    if (j >= 0) taken[static_cast<std::size_t>(j)] = 1;
  for (std::size_t j = 0; j < right.size(); ++j)
    if (!taken[j]) m.unmatched_right.push_back(static_cast<int>(j));
  return m;
}

// ---------------------------------------------------------------------------------------------

StereoPipeline::StereoPipeline(Rig rig, const std::string& backend, const PipelineOptions& o, StereoMatchOptions so)
    : rig_(std::move(rig)), so_(so) {
  validate(so_);
  rect_ = rectify(rig_);
  left_ = make_backend(backend, o);
  right_ = make_backend(backend, o);
}

StereoPipeline::~StereoPipeline() = default;

namespace {
void check_pair(const Rig& rig, const cv::Mat& l, const cv::Mat& r) {
  if (l.size() != r.size())
    throw InputError(fmt::format("the left frame is {}x{} and the right {}x{}; give two cameras of one image size",
                                 l.cols, l.rows, r.cols, r.rows));
  if (l.size() != rig.left.size)
    throw InputError(fmt::format("the stereo calibration is of {}x{} images and the frames are {}x{}; use the "
                                 "calibration of this camera pair at this image size",
                                 rig.left.size.width, rig.left.size.height, l.cols, l.rows));
}

// The point where the left camera's ray through image point p meets the plane.
cv::Vec3d on_plane(const Rig& rig, const PlaneFrame& f, const cv::Point2d& p) {
  std::vector<cv::Point2d> in = {p}, out;
  cv::undistortPoints(in, out, cv::Mat(rig.left.K), rig.left.dist);
  const cv::Vec3d ray(out[0].x, out[0].y, 1);
  const double t = f.n.dot(f.origin) / f.n.dot(ray);
  return t * ray;
}
}  // namespace

void StereoPipeline::set_reference(const cv::Mat& left, const cv::Mat& right) {
  check_pair(rig_, left, right);
  left_->set_reference(left);
  right_->set_reference(right);
  const auto lp = as_points(left_->reference_positions()), rp = as_points(right_->reference_positions());
  ref_match_ = match_stereo(rig_, lp, rp, so_);
  if (ref_match_.matched < 6)
    throw InputError(fmt::format("the reference frames: {}; u_z needs at least 6 matched dots: check the calibration "
                                 "is of this camera pair, and that both cameras see the plate",
                                 ref_match_.summary()));
  std::vector<cv::Point2d> ml, mr;
  std::vector<std::size_t> which;
  for (std::size_t i = 0; i < lp.size(); ++i)
    if (ref_match_.left_to_right[i] >= 0) {
      ml.push_back(lp[i]);
      mr.push_back(rp[static_cast<std::size_t>(ref_match_.left_to_right[i])]);
      which.push_back(i);
    }
  const auto X = triangulate(rig_, ml, mr);
  ref3d_.assign(lp.size(), cv::Point3d(kNaN, kNaN, kNaN));
  for (std::size_t k = 0; k < which.size(); ++k) ref3d_[which[k]] = X[k];
  plane_ = fit_plane(X);
  ref_plane_.assign(lp.size(), cv::Vec2d(kNaN, kNaN));
  std::vector<Vec2> plate;  // matched dots' plate coordinates
  for (std::size_t k = 0; k < which.size(); ++k) {
    const cv::Vec3d d = cv::Vec3d(X[k].x, X[k].y, X[k].z) - plane_.origin;
    ref_plane_[which[k]] = cv::Vec2d(d.dot(plane_.e1), d.dot(plane_.e2));
    plate.emplace_back(d.dot(plane_.e1), d.dot(plane_.e2));
  }
  // Each point's support: the nearest matched dots on the plate (the MLS support's size).
  const MlsOptions& mo = left_->options().mls;
  const PointIndex index(plate);
  const double spacing = median_spacing(plate);
  uz_gap_ = mo.max_gap * spacing;
  int count = mo.support.kind == Support::Kind::dots ? mo.support.dots : 0;
  if (count == 0) {
    // A support of R px: as many dots as a disc of R px holds at the left image's dot density.
    const double spacing_px = median_spacing(left_->reference_positions());
    count = static_cast<int>(std::lround(CV_PI * mo.support.radius * mo.support.radius / (spacing_px * spacing_px)));
  }
  count = std::clamp(count, 6, static_cast<int>(plate.size()));
  support_.clear();
  point_plane_.clear();
  rho_.clear();
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  for (const Vec2& p : left_->points()) {
    const cv::Vec3d P = on_plane(rig_, plane_, {p.x, p.y}) - plane_.origin;
    const Vec2 s(P.dot(plane_.e1), P.dot(plane_.e2));
    point_plane_.emplace_back(s.x, s.y);
    index.knn(s, count, idx, d2);
    std::vector<std::int32_t> sup;
    for (auto q : idx) sup.push_back(static_cast<std::int32_t>(which[q]));
    support_.push_back(std::move(sup));
    rho_.push_back(d2.empty() ? 0.0 : 1.05 * std::sqrt(d2.back()) + 1e-9);
    if (!d2.empty() && std::sqrt(d2.front()) > uz_gap_) rho_.back() = -1;  // far from the dots
  }
}

StereoFrame StereoPipeline::process(const cv::Mat& left, const cv::Mat& right) {
  check_pair(rig_, left, right);
  StereoFrame f;
  double t0 = now_s();
  f.left = left_->process(left);
  double t1 = now_s();
  f.right = right_->process(right);
  const double t2 = now_s();
  for (const auto& [k, v] : f.left.seconds) f.seconds["left: " + k] = v;
  for (const auto& [k, v] : f.right.seconds) f.seconds["right: " + k] = v;
  f.seconds["left"] = t1 - t0;
  f.seconds["right"] = t2 - t1;
  const auto& lref = left_->reference_positions();
  const auto& rref = right_->reference_positions();
  const std::size_t n = lref.size();
  f.position.assign(n, cv::Point3d(kNaN, kNaN, kNaN));
  f.uz.assign(n, kNaN);
  f.why.assign(n, StereoLost::none);
  f.right_dot.assign(n, -1);
  std::vector<cv::Point2d> pl, pr;
  std::vector<std::size_t> which;
  for (std::size_t i = 0; i < n; ++i) {
    const int j = ref_match_.left_to_right[i];
    if (j < 0) {
      f.why[i] = ref_match_.lost[i];
      continue;
    }
    const auto ju = static_cast<std::size_t>(j);
    if (!f.left.tracked[i]) {
      f.why[i] = StereoLost::lost_left;
      continue;
    }
    if (!f.right.tracked[ju]) {
      f.why[i] = StereoLost::lost_right;
      continue;
    }
    f.right_dot[i] = f.right.matches.ref_to_def[ju];
    pl.emplace_back(lref[i].x + f.left.displacement[i].x, lref[i].y + f.left.displacement[i].y);
    pr.emplace_back(rref[ju].x + f.right.displacement[ju].x, rref[ju].y + f.right.displacement[ju].y);
    which.push_back(i);
  }
  // Pairs that left their epipolar rows (a camera moved, or a tracking slip) are not triangulated.
  const auto ql = rectified(rig_, rect_, false, pl), qr = rectified(rig_, rect_, true, pr);
  std::vector<cv::Point2d> gl, gr;
  std::vector<std::size_t> good;
  for (std::size_t k = 0; k < which.size(); ++k) {
    const double off = rect_.vertical ? qr[k].x - ql[k].x : qr[k].y - ql[k].y;
    if (std::abs(off) > so_.epipolar_tolerance) {
      f.why[which[k]] = StereoLost::off_epipolar;
      continue;
    }
    gl.push_back(pl[k]);
    gr.push_back(pr[k]);
    good.push_back(which[k]);
  }
  const auto X = triangulate(rig_, gl, gr);
  for (std::size_t k = 0; k < good.size(); ++k) {
    const std::size_t i = good[k];
    f.position[i] = X[k];
    const cv::Point3d d = X[k] - ref3d_[i];
    f.uz[i] = plane_.n.dot(cv::Vec3d(d.x, d.y, d.z));
    ++f.triangulated;
  }
  // u_z and its gradient at the points: weighted quadratic least squares on the plate, in
  // coordinates scaled by the support radius.
  const Weight wk = left_->options().mls.weight;
  f.fields.resize(support_.size());
  cv::Mat A, b, x;
  for (std::size_t p = 0; p < support_.size(); ++p) {
    UzValue& v = f.fields[p];
    if (rho_[p] < 0) {
      v.status = PointStatus::far_from_dots;
      continue;
    }
    const double rho = rho_[p];
    A.create(static_cast<int>(support_[p].size()), 6, CV_64F);
    b.create(A.rows, 1, CV_64F);
    int m = 0;
    for (auto i : support_[p]) {
      const auto iu = static_cast<std::size_t>(i);
      if (!std::isfinite(f.uz[iu])) continue;
      const double sx = (ref_plane_[iu][0] - point_plane_[p][0]) / rho, sy = (ref_plane_[iu][1] - point_plane_[p][1]) / rho;
      double w = 0, dw = 0;
      weight_fn(wk, std::hypot(sx, sy), w, dw);
      if (w <= 0) continue;
      const double r = std::sqrt(w);
      double* row = A.ptr<double>(m);
      row[0] = r;
      row[1] = r * sx;
      row[2] = r * sy;
      row[3] = r * sx * sx;
      row[4] = r * sx * sy;
      row[5] = r * sy * sy;
      b.at<double>(m) = r * f.uz[iu];
      ++m;
    }
    v.support = m;
    if (m < 6) {
      v.status = PointStatus::too_few_dots;
      continue;
    }
    cv::Mat Am = A.rowRange(0, m), bm = b.rowRange(0, m);
    cv::SVD svd(Am, cv::SVD::MODIFY_A);
    const double smax = svd.w.at<double>(0), smin = svd.w.at<double>(5);
    if (!(smin > 1e-6 * smax)) {
      v.status = PointStatus::ill_conditioned;
      continue;
    }
    svd.backSubst(bm, x);
    v.uz = x.at<double>(0);
    v.duz_dx = x.at<double>(1) / rho;
    v.duz_dy = x.at<double>(2) / rho;
  }
  f.seconds["stereo"] = now_s() - t2;
  return f;
}

namespace {
std::string num(double v, const char* fmtspec = "{:.6f}") {
  return std::isfinite(v) ? fmt::format(fmt::runtime(fmtspec), v) : std::string();
}
}  // namespace

void write_stereo_fields_csv(const std::filesystem::path& path, const std::vector<Vec2>& points,
                             const std::vector<FieldValue<double>>& fields, const std::vector<UzValue>& uz) {
  if (points.size() != fields.size() || points.size() != uz.size())
    throw InputError("points, fields and u_z differ in length");
  if (path.has_parent_path()) make_output_folder(path.parent_path(), fmt::format("'{}'", path.string()));
  std::string s = std::string(kStereoCsvHeader) + "\n";
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto& v = fields[i];
    if (v.status == PointStatus::ok)
      s += fmt::format("{:.3f},{:.3f},{:.6f},{:.6f},{:.6g},{:.6g},{:.6g},1,ok,{}", points[i].x, points[i].y, v.ux, v.uy,
                       v.exx * 1e6, v.eyy * 1e6, v.exy * 1e6, v.support);
    else
      s += fmt::format("{:.3f},{:.3f},,,,,,0,{},{}", points[i].x, points[i].y, dct::to_string(v.status), v.support);
    const auto& z = uz[i];
    if (z.status == PointStatus::ok)
      s += fmt::format(",{:.6f},{:.6g},{:.6g},ok,{}\n", z.uz, z.duz_dx, z.duz_dy, z.support);
    else
      s += fmt::format(",,,,{},{}\n", dct::to_string(z.status), z.support);
  }
  write_file_atomically(path, s);
}

void write_stereo_dots_csv(const std::filesystem::path& path, const StereoPipeline& p, const StereoFrame& f) {
  const auto& lref = p.left().reference_positions();
  const auto& rref = p.right().reference_positions();
  const auto& m = p.reference_matches();
  if (f.uz.size() != lref.size()) throw InputError("the stereo frame does not fit the reference dots");
  if (path.has_parent_path()) make_output_folder(path.parent_path(), fmt::format("'{}'", path.string()));
  std::string s = std::string(kStereoDotsCsvHeader) + "\n";
  for (std::size_t i = 0; i < lref.size(); ++i) {
    const int j = m.left_to_right[i];
    const bool ok = f.why[i] == StereoLost::none;
    const cv::Point3d& R = p.reference_positions()[i];
    std::string right_ref = j >= 0 ? fmt::format("{:.4f},{:.4f}", rref[static_cast<std::size_t>(j)].x,
                                                 rref[static_cast<std::size_t>(j)].y)
                                   : ",";
    std::string pos = ",,,,,,";
    if (ok) {
      const auto ju = static_cast<std::size_t>(j);
      pos = fmt::format("{:.4f},{:.4f},{:.4f},{:.4f},{:.5f},{:.5f},{:.5f}", lref[i].x + f.left.displacement[i].x,
                        lref[i].y + f.left.displacement[i].y, rref[ju].x + f.right.displacement[ju].x,
                        rref[ju].y + f.right.displacement[ju].y, f.position[i].x, f.position[i].y, f.position[i].z);
    }
    s += fmt::format("{},{},{},\"{}\",{:.4f},{:.4f},{},{},{},{},{},{},{}\n", i, j >= 0 ? std::to_string(j) : "",
                     ok ? "matched" : "lost", to_string(f.why[i]), lref[i].x, lref[i].y, right_ref,
                     num(R.x, "{:.5f}"), num(R.y, "{:.5f}"), num(R.z, "{:.5f}"), pos, num(f.uz[i], "{:.6f}"),
                     num(m.row_offset_px[i], "{:.4f}"));
  }
  for (int j : m.unmatched_right) {
    const auto ju = static_cast<std::size_t>(j);
    s += fmt::format(",{},unmatched_right,\"no left dot took it\",,,{:.4f},{:.4f},,,,,,,,,,,,\n", j, rref[ju].x,
                     rref[ju].y);
  }
  write_file_atomically(path, s);
}

}  // namespace dtflop::dct::stereo
