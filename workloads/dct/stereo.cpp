#include "workloads/dct/stereo.hpp"

#include <algorithm>
#include <cmath>
#include <string_view>
#include <type_traits>

#include <fmt/format.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "model/errors.hpp"

namespace dtflop::dct::stereo {

namespace {
cv::Matx33d rot_y(double a) {
  const double c = std::cos(a), s = std::sin(a);
  return {c, 0, s, 0, 1, 0, -s, 0, c};
}
}  // namespace

Rig make_rig(cv::Size size, double f, double baseline, double convergence_deg, double k1) {
  Rig r;
  for (Camera* c : {&r.left, &r.right}) {
    c->size = size;
    c->K = cv::Matx33d(f, 0, (size.width - 1) / 2.0, 0, f, (size.height - 1) / 2.0, 0, 0, 1);
    c->dist = cv::Mat::zeros(1, 5, CV_64F);
    c->dist.at<double>(0) = k1;
  }
  // The right camera's centre is (baseline, 0, 0) in the left frame; its axis turned toward the
  // left camera's by the convergence angle: x_right = R (x_left - C).
  r.R = rot_y(convergence_deg * CV_PI / 180.0);
  const cv::Vec3d C(baseline, 0, 0);
  r.T = -(r.R * C);
  return r;
}

std::vector<cv::Point3f> board_corners(const Board& b) {
  std::vector<cv::Point3f> p;
  if (b.target == Board::Target::circles) {
    const double h = b.square / 2;
    for (int i = 0; i < b.inner.height; ++i)
      for (int j = 0; j < b.inner.width; ++j)
        p.emplace_back(static_cast<float>((2 * j + i % 2) * h), static_cast<float>(i * h), 0.f);
    return p;
  }
  for (int y = 0; y < b.inner.height; ++y)
    for (int x = 0; x < b.inner.width; ++x)
      p.emplace_back(static_cast<float>(x * b.square), static_cast<float>(y * b.square), 0.f);
  return p;
}

Pose in_right(const Rig& rig, const Pose& left) {
  cv::Matx33d Rl;
  cv::Rodrigues(left.rvec, Rl);
  const cv::Matx33d Rr = rig.R * Rl;
  Pose p;
  cv::Rodrigues(Rr, p.rvec);
  p.tvec = rig.R * left.tvec + rig.T;
  return p;
}

namespace {

// Paints `level` over `img` (CV_64F) inside the polygon `poly` (image pixels; pixel c covers
// [c - 1/2, c + 1/2]), each pixel mixed by the area of it the polygon covers: exactly across
// each of kLines sample lines per pixel row (the spans between the outline's crossings, clipped
// to each pixel), the lines averaged. Even-odd rule.
void paint(cv::Mat& img, const std::vector<cv::Point2d>& poly, double level) {
  constexpr int kLines = 32;
  double y_lo = poly[0].y, y_hi = poly[0].y;
  for (const auto& p : poly) {
    y_lo = std::min(y_lo, p.y);
    y_hi = std::max(y_hi, p.y);
  }
  if (!(y_hi > -0.5 && y_lo < img.rows - 0.5)) return;  // off the image (or not finite)
  const int r0 = std::max(0, static_cast<int>(std::floor(y_lo + 0.5)));
  const int r1 = std::min(img.rows - 1, static_cast<int>(std::floor(y_hi + 0.5)));
  std::vector<double> cov(static_cast<std::size_t>(img.cols)), xs;
  for (int r = r0; r <= r1; ++r) {
    int c_lo = img.cols, c_hi = -1;
    for (int line = 0; line < kLines; ++line) {
      const double y = r - 0.5 + (line + 0.5) / kLines;
      xs.clear();
      for (std::size_t i = 0; i < poly.size(); ++i) {
        const cv::Point2d a = poly[i], b = poly[(i + 1) % poly.size()];
        if ((a.y <= y) != (b.y <= y)) xs.push_back(a.x + (y - a.y) * (b.x - a.x) / (b.y - a.y));
      }
      std::sort(xs.begin(), xs.end());
      for (std::size_t i = 0; i + 1 < xs.size(); i += 2) {
        const double xl = std::max(xs[i], -0.5), xr = std::min(xs[i + 1], img.cols - 0.5);
        if (!(xr > xl)) continue;
        const int cl = static_cast<int>(std::floor(xl + 0.5)), cr = std::min(img.cols - 1, static_cast<int>(std::floor(xr + 0.5)));
        for (int c = cl; c <= cr; ++c) {
          const double w = std::min(xr, c + 0.5) - std::max(xl, c - 0.5);
          if (w > 0) cov[static_cast<std::size_t>(c)] += w / kLines;
        }
        c_lo = std::min(c_lo, cl);
        c_hi = std::max(c_hi, cr);
      }
    }
    auto* row = img.ptr<double>(r);
    for (int c = c_lo; c <= c_hi; ++c) {
      double& k = cov[static_cast<std::size_t>(c)];
      row[c] += (level - row[c]) * std::min(k, 1.0);
      k = 0;
    }
  }
}

}  // namespace

cv::Mat render_board(const Camera& camera, const Board& b, const Pose& pose) {
  cv::Mat img(camera.size, CV_64F, cv::Scalar(110));
  auto project = [&](const std::vector<cv::Point3d>& outline) {
    std::vector<cv::Point2d> q;
    cv::projectPoints(outline, pose.rvec, pose.tvec, camera.K, camera.dist, q);
    return q;
  };
  // One square (board units, corners x0..x1, y0..y1), edges cut every 1/8 side so that the lens
  // distortion bends them.
  auto square = [&](double x0, double y0, double x1, double y1) {
    std::vector<cv::Point3d> edge;
    constexpr int n = 8;
    for (int i = 0; i < n; ++i) edge.emplace_back(x0 + (x1 - x0) * i / n, y0, 0.0);
    for (int i = 0; i < n; ++i) edge.emplace_back(x1, y0 + (y1 - y0) * i / n, 0.0);
    for (int i = 0; i < n; ++i) edge.emplace_back(x1 - (x1 - x0) * i / n, y1, 0.0);
    for (int i = 0; i < n; ++i) edge.emplace_back(x0, y1 - (y1 - y0) * i / n, 0.0);
    for (auto& p : edge) p *= b.square;
    return project(edge);
  };
  if (b.target == Board::Target::circles) {
    // The white board: the circles' grid and a margin of one pitch; dark discs of radius square / 5.
    const double w = (2 * b.inner.width) * 0.5, h = (b.inner.height - 1) * 0.5;  // extent, in squares
    paint(img, square(-1, -1, w + 0.5, h + 1), 215);
    for (const cv::Point3f& c : board_corners(b)) {
      std::vector<cv::Point3d> ring;
      for (int k = 0; k < 128; ++k) {
        const double a = 2 * CV_PI * k / 128;
        ring.emplace_back(c.x + 0.2 * b.square * std::cos(a), c.y + 0.2 * b.square * std::sin(a), 0.0);
      }
      paint(img, project(ring), 40);
    }
  } else {
    const int cols = b.inner.width + 1, rows = b.inner.height + 1;  // squares
    // The white board: the squares and a margin of one square.
    paint(img, square(-2, -2, cols, rows), 215);
    for (int y = 0; y < rows; ++y)
      for (int x = 0; x < cols; ++x)
        if ((x + y) % 2 == 0) paint(img, square(x - 1, y - 1, x, y), 40);
  }
  cv::Mat out;
  img.convertTo(out, CV_8U);  // rounded
  return out;
}

namespace {

bool find_corners(const cv::Mat& img, const Board& b, std::vector<cv::Point2f>& corners) {
  if (b.target == Board::Target::circles) {
    cv::SimpleBlobDetector::Params p;
    p.maxArea = 1e6f;  // large discs of close views
    return cv::findCirclesGrid(img, b.inner, corners, cv::CALIB_CB_ASYMMETRIC_GRID, cv::SimpleBlobDetector::create(p));
  }
  if (!cv::findChessboardCorners(img, b.inner, corners, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE))
    return false;
  cv::cornerSubPix(img, corners, {7, 7}, {-1, -1},
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 200, 1e-4));
  return true;
}

cv::Matx33d skew(const cv::Vec3d& t) { return {0, -t[2], t[1], t[2], 0, -t[0], -t[1], t[0], 0}; }

}  // namespace

Calibration calibrate(const std::vector<cv::Mat>& left, const std::vector<cv::Mat>& right, const Board& b) {
  if (left.size() != right.size() || left.empty())
    throw InputError("stereo calibration needs as many right views as left views, at least 3 pairs");
  const cv::Size size = left.front().size();
  std::vector<std::vector<cv::Point3f>> obj;
  std::vector<std::vector<cv::Point2f>> pl, pr;
  std::vector<std::size_t> used;  // the view each entry of obj, pl and pr came from
  Calibration c;
  for (std::size_t i = 0; i < left.size(); ++i) {
    if (left[i].size() != size || right[i].size() != size)
      throw InputError(fmt::format("calibration view {} is {}x{} / {}x{} and the first {}x{}; give views of one size",
                                   i + 1, left[i].cols, left[i].rows, right[i].cols, right[i].rows, size.width,
                                   size.height));
    std::vector<cv::Point2f> a, bb;
    if (!find_corners(left[i], b, a) || !find_corners(right[i], b, bb)) {
      c.notes.push_back(fmt::format("view {}: the {}x{} target is not wholly seen in both images; left out", i + 1,
                                    b.inner.width, b.inner.height));
      continue;
    }
    obj.push_back(board_corners(b));
    used.push_back(i);
    pl.push_back(std::move(a));
    pr.push_back(std::move(bb));
  }
  c.views_used = static_cast<int>(obj.size());
  if (c.views_used < 3)
    throw InputError(fmt::format("only {} view pair(s) show the whole {}x{} board in both cameras; take at least 3 (10-20 "
                                 "at varied tilts is good)",
                                 c.views_used, b.inner.width, b.inner.height));
  const int flags = cv::CALIB_FIX_K3 | cv::CALIB_ZERO_TANGENT_DIST;
  cv::Mat K1, D1, K2, D2, E, F, R, T;
  // Each camera alone, then the pair, each with every view's reprojection RMS. A view whose RMS
  // is kOutlier times the median view's, and over kOutlierFloor px, holds a misdetected target (a
  // circle grid's blobs taken in the wrong order, a stray blob taken for a circle, a board one
  // camera saw mirrored): it pulls the whole calibration, so it is left out, said in a note, and
  // the calibration redone without it.
  constexpr double kOutlier = 5, kOutlierFloor = 0.25;
  auto cameras = [&](std::vector<double>* per_view) {
    std::vector<cv::Mat> rv, tv;
    cv::Mat sd_in, sd_ex, el, er;
    c.rms_left = cv::calibrateCamera(obj, pl, size, K1, D1, rv, tv, sd_in, sd_ex, el, flags);
    c.rms_right = cv::calibrateCamera(obj, pr, size, K2, D2, rv, tv, sd_in, sd_ex, er, flags);
    per_view->clear();
    for (std::size_t i = 0; i < obj.size(); ++i)
      per_view->push_back(std::max(el.at<double>(static_cast<int>(i)), er.at<double>(static_cast<int>(i))));
  };
  auto pair = [&](std::vector<double>* per_view) {
    cv::Mat errors;  // a row per view: its RMS in the left and in the right image
    c.rms_stereo = cv::stereoCalibrate(obj, pl, pr, K1, D1, K2, D2, size, R, T, E, F, errors,
                                       cv::CALIB_USE_INTRINSIC_GUESS | flags,
                                       cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-10));
    per_view->clear();
    for (int i = 0; i < errors.rows; ++i) per_view->push_back(std::max(errors.at<double>(i, 0), errors.at<double>(i, 1)));
  };
  // Leaves out the views whose error is an outlier; true if there were any.
  auto leave_out = [&](const std::vector<double>& err, std::string_view fit) {
    std::vector<double> sorted = err;
    std::sort(sorted.begin(), sorted.end());
    const double median = sorted[sorted.size() / 2], limit = std::max(kOutlier * median, kOutlierFloor);
    std::vector<std::size_t> keep;
    for (std::size_t i = 0; i < err.size(); ++i) {
      if (err[i] <= limit) {
        keep.push_back(i);
        continue;
      }
      c.notes.push_back(fmt::format("view {}: its target reprojects {:.2f} px off in the {} calibration (the median view "
                                    "{:.3f} px): misdetected, left out",
                                    used[i] + 1, err[i], fit, median));
    }
    if (keep.size() == err.size()) return false;
    if (keep.size() < 3)
      throw InputError(fmt::format("only {} view pair(s) hold a well-detected {}x{} board in both cameras; take at "
                                   "least 3 (10-20 at varied tilts is good)",
                                   keep.size(), b.inner.width, b.inner.height));
    auto pick = [&keep](auto& v) {
      std::remove_reference_t<decltype(v)> kept;
      for (std::size_t i : keep) kept.push_back(std::move(v[i]));
      v = std::move(kept);
    };
    pick(obj);
    pick(pl);
    pick(pr);
    pick(used);
    c.views_used = static_cast<int>(obj.size());
    return true;
  };
  std::vector<double> err;
  cameras(&err);
  if (leave_out(err, "one-camera")) cameras(&err);
  pair(&err);
  if (leave_out(err, "stereo")) {
    cameras(&err);
    pair(&err);
  }
  c.rig.left = {cv::Matx33d(K1), D1.clone(), size};
  c.rig.right = {cv::Matx33d(K2), D2.clone(), size};
  c.rig.R = cv::Matx33d(R);
  c.rig.T = cv::Vec3d(T);
  // Epipolar error on undistorted points: distance of each right corner to the line of its left one.
  const cv::Matx33d Fu = c.rig.right.K.inv().t() * skew(c.rig.T) * c.rig.R * c.rig.left.K.inv();
  double se = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < pl.size(); ++i) {
    std::vector<cv::Point2d> ul, ur, l(pl[i].begin(), pl[i].end()), r(pr[i].begin(), pr[i].end());
    cv::undistortPoints(l, ul, c.rig.left.K, c.rig.left.dist, cv::noArray(), c.rig.left.K);
    cv::undistortPoints(r, ur, c.rig.right.K, c.rig.right.dist, cv::noArray(), c.rig.right.K);
    for (std::size_t k = 0; k < ul.size(); ++k) {
      const cv::Vec3d line = Fu * cv::Vec3d(ul[k].x, ul[k].y, 1);
      const double d = (line[0] * ur[k].x + line[1] * ur[k].y + line[2]) / std::hypot(line[0], line[1]);
      se += d * d;
      ++n;
    }
  }
  c.epipolar_rms = std::sqrt(se / static_cast<double>(n));
  for (auto& s : judge(c)) c.notes.push_back(std::move(s));
  return c;
}

std::vector<std::string> judge(const Calibration& c) {
  auto verdict = [](double px) {
    return px < 0.1 ? "good" : px <= 0.5 ? "usable" : "poor: redo it (sharper views, a board that does not move, more and more varied tilts)";
  };
  return {fmt::format("reprojection RMS: left {:.3f} px ({}), right {:.3f} px ({}), stereo {:.3f} px ({})", c.rms_left,
                      verdict(c.rms_left), c.rms_right, verdict(c.rms_right), c.rms_stereo, verdict(c.rms_stereo)),
          fmt::format("epipolar RMS {:.3f} px ({}) over {} view pairs", c.epipolar_rms, verdict(c.epipolar_rms),
                      c.views_used)};
}

void write_rig(const std::string& path, const Calibration& c) {
  cv::FileStorage fs(path, cv::FileStorage::WRITE | cv::FileStorage::FORMAT_YAML);
  if (!fs.isOpened()) throw InputError(fmt::format("cannot write the calibration to '{}'; give a writable path", path));
  fs << "dtflop_stereo_calibration" << 1;
  fs << "image_width" << c.rig.left.size.width << "image_height" << c.rig.left.size.height;
  fs << "K_left" << cv::Mat(c.rig.left.K) << "dist_left" << c.rig.left.dist;
  fs << "K_right" << cv::Mat(c.rig.right.K) << "dist_right" << c.rig.right.dist;
  fs << "R" << cv::Mat(c.rig.R) << "T" << cv::Mat(c.rig.T);
  fs << "rms_left" << c.rms_left << "rms_right" << c.rms_right << "rms_stereo" << c.rms_stereo;
  fs << "epipolar_rms" << c.epipolar_rms << "views_used" << c.views_used;
}

Rig read_rig(const std::string& path, std::optional<cv::Size> expect) {
  cv::FileStorage fs;
  try {
    fs.open(path, cv::FileStorage::READ);
  } catch (const cv::Exception& e) {
    throw InputError(fmt::format("calibration '{}' is not readable YAML ({}); give a file written by dtflop", path,
                                 e.what()));
  }
  if (!fs.isOpened() || fs["dtflop_stereo_calibration"].empty())
    throw InputError(fmt::format("'{}' is not a dtflop stereo calibration; give one written by dtflop", path));
  auto mat = [&](const char* key, int rows, int cols) {
    cv::Mat m;
    fs[key] >> m;
    if (m.rows != rows || m.cols != cols || m.type() != CV_64F || !cv::checkRange(m))
      throw InputError(fmt::format("calibration '{}': '{}' is missing, not {}x{} or not finite; recalibrate", path, key,
                                   rows, cols));
    return m;
  };
  Rig r;
  int w = 0, h = 0;
  fs["image_width"] >> w;
  fs["image_height"] >> h;
  if (w < 1 || h < 1 || w > 16384 || h > 16384)
    throw InputError(fmt::format("calibration '{}': image size {}x{} is not 1..16384 a side; recalibrate", path, w, h));
  r.left.size = r.right.size = {w, h};
  r.left.K = cv::Matx33d(mat("K_left", 3, 3));
  r.right.K = cv::Matx33d(mat("K_right", 3, 3));
  r.left.dist = mat("dist_left", 1, 5);
  r.right.dist = mat("dist_right", 1, 5);
  r.R = cv::Matx33d(mat("R", 3, 3));
  r.T = cv::Vec3d(mat("T", 3, 1));
  if (cv::norm(cv::Mat(r.R * r.R.t() - cv::Matx33d::eye())) > 1e-6 || std::abs(cv::determinant(r.R) - 1) > 1e-6)
    throw InputError(fmt::format("calibration '{}': R is not a rotation; recalibrate", path));
  for (const Camera* c : {&r.left, &r.right})
    if (!(c->K(0, 0) > 0 && c->K(1, 1) > 0))
      throw InputError(fmt::format("calibration '{}': a focal length is not positive; recalibrate", path));
  if (expect && *expect != r.left.size)
    throw InputError(fmt::format("calibration '{}' is of {}x{} images and these are {}x{}; use the calibration of this "
                                 "camera pair at this image size",
                                 path, w, h, expect->width, expect->height));
  return r;
}

std::vector<cv::Point3d> triangulate(const Rig& rig, const std::vector<cv::Point2d>& left,
                                     const std::vector<cv::Point2d>& right) {
  if (left.size() != right.size())
    throw InputError(fmt::format("{} left and {} right points: triangulation needs matched pairs", left.size(),
                                 right.size()));
  if (left.empty()) return {};
  std::vector<cv::Point2d> nl, nr;  // normalized, undistorted
  cv::undistortPoints(left, nl, rig.left.K, rig.left.dist);
  cv::undistortPoints(right, nr, rig.right.K, rig.right.dist);
  cv::Matx34d P1 = cv::Matx34d::eye(), P2;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) P2(i, j) = rig.R(i, j);
    P2(i, 3) = rig.T[i];
  }
  cv::Mat X;
  cv::triangulatePoints(P1, P2, nl, nr, X);  // 4xN, CV_64F
  std::vector<cv::Point3d> out;
  for (int k = 0; k < X.cols; ++k) {
    const double w = X.at<double>(3, k);
    out.emplace_back(X.at<double>(0, k) / w, X.at<double>(1, k) / w, X.at<double>(2, k) / w);
  }
  return out;
}

PlaneFrame fit_plane(const std::vector<cv::Point3d>& points) {
  if (points.size() < 3) throw InputError("a plane needs at least 3 points");
  cv::Point3d mean(0, 0, 0);
  for (const auto& p : points) mean += p;
  mean *= 1.0 / static_cast<double>(points.size());
  cv::Mat A(static_cast<int>(points.size()), 3, CV_64F);
  for (int i = 0; i < A.rows; ++i) {
    const cv::Point3d d = points[static_cast<std::size_t>(i)] - mean;
    A.at<double>(i, 0) = d.x;
    A.at<double>(i, 1) = d.y;
    A.at<double>(i, 2) = d.z;
  }
  cv::SVD svd(A, cv::SVD::FULL_UV);
  PlaneFrame f;
  f.origin = cv::Vec3d(mean.x, mean.y, mean.z);
  f.n = cv::Vec3d(svd.vt.at<double>(2, 0), svd.vt.at<double>(2, 1), svd.vt.at<double>(2, 2));
  if (f.n.dot(f.origin) > 0) f.n = -f.n;  // toward the camera (the origin)
  const cv::Vec3d x(1, 0, 0);
  f.e1 = x - x.dot(f.n) * f.n;
  f.e1 /= cv::norm(f.e1);
  f.e2 = f.n.cross(f.e1);
  return f;
}

std::vector<double> out_of_plane(const std::vector<cv::Point3d>& reference, const std::vector<cv::Point3d>& deformed) {
  if (reference.size() != deformed.size() || reference.size() < 3)
    throw InputError("out-of-plane displacement needs the same points (at least 3) in both states");
  const PlaneFrame f = fit_plane(reference);
  std::vector<double> w;
  for (std::size_t i = 0; i < reference.size(); ++i) {
    const cv::Point3d d = deformed[i] - reference[i];
    w.push_back(f.n.dot(cv::Vec3d(d.x, d.y, d.z)));
  }
  return w;
}

std::vector<cv::Vec2d> out_of_plane_gradient(const std::vector<cv::Point3d>& reference, const std::vector<double>& uz,
                                             int neighbours) {
  if (reference.size() != uz.size() || neighbours < 3 || reference.size() < static_cast<std::size_t>(neighbours))
    throw InputError(fmt::format("the gradient of u_z needs one value per point and at least {} points (have {} and {})",
                                 std::max(neighbours, 3), uz.size(), reference.size()));
  const PlaneFrame f = fit_plane(reference);
  std::vector<cv::Point2d> s;
  for (const auto& p : reference) {
    const cv::Vec3d d = cv::Vec3d(p.x, p.y, p.z) - f.origin;
    s.emplace_back(d.dot(f.e1), d.dot(f.e2));
  }
  std::vector<cv::Vec2d> out;
  std::vector<std::pair<double, std::size_t>> by_distance(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    for (std::size_t j = 0; j < s.size(); ++j) by_distance[j] = {cv::norm(s[j] - s[i]), j};
    std::partial_sort(by_distance.begin(), by_distance.begin() + neighbours, by_distance.end());
    cv::Mat A(neighbours, 3, CV_64F), b(neighbours, 1, CV_64F), x;
    for (int k = 0; k < neighbours; ++k) {
      const std::size_t j = by_distance[static_cast<std::size_t>(k)].second;
      A.at<double>(k, 0) = 1;
      A.at<double>(k, 1) = s[j].x - s[i].x;
      A.at<double>(k, 2) = s[j].y - s[i].y;
      b.at<double>(k) = uz[j];
    }
    if (!cv::solve(A, b, x, cv::DECOMP_SVD)) x = cv::Mat::zeros(3, 1, CV_64F);
    out.emplace_back(x.at<double>(1), x.at<double>(2));
  }
  return out;
}

}  // namespace dtflop::dct::stereo
