#include "camera.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace dct_indep {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Area of the polygon clipped to the pixel square [cx - 1/2, cx + 1/2] x [cy - 1/2, cy + 1/2]
// (Sutherland-Hodgman against the four sides, then the shoelace formula).
double clipped_area(const std::vector<cv::Point2d>& poly, double cx, double cy) {
  std::vector<cv::Point2d> a = poly, b;
  auto clip = [&](int axis, double bound, bool keep_below) {
    b.clear();
    auto in = [&](const cv::Point2d& p) {
      const double v = axis == 0 ? p.x : p.y;
      return keep_below ? v <= bound : v >= bound;
    };
    for (std::size_t i = 0; i < a.size(); ++i) {
      const cv::Point2d& p = a[i];
      const cv::Point2d& q = a[(i + 1) % a.size()];
      const bool ip = in(p), iq = in(q);
      if (ip) b.push_back(p);
      if (ip != iq) {
        const double vp = axis == 0 ? p.x : p.y, vq = axis == 0 ? q.x : q.y;
        const double t = (bound - vp) / (vq - vp);
        b.push_back(p + t * (q - p));
      }
    }
    std::swap(a, b);
  };
  clip(0, cx - 0.5, false);
  if (a.size() >= 3) clip(0, cx + 0.5, true);
  if (a.size() >= 3) clip(1, cy - 0.5, false);
  if (a.size() >= 3) clip(1, cy + 0.5, true);
  if (a.size() < 3) return 0;
  double s = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const cv::Point2d& p = a[i];
    const cv::Point2d& q = a[(i + 1) % a.size()];
    s += p.x * q.y - q.x * p.y;
  }
  return std::abs(s) / 2;
}

cv::Matx33d rot_y(double a) {
  const double c = std::cos(a), s = std::sin(a);
  return {c, 0, s, 0, 1, 0, -s, 0, c};
}

}  // namespace

CameraPair make_pair(cv::Size size, double f, double baseline_mm, double convergence_deg, double k1) {
  CameraPair p;
  for (CameraModel* c : {&p.left, &p.right}) {
    c->size = size;
    c->K = cv::Matx33d(f, 0, (size.width - 1) / 2.0, 0, f, (size.height - 1) / 2.0, 0, 0, 1);
    c->dist = cv::Mat::zeros(1, 5, CV_64F);
    c->dist.at<double>(0) = k1;
  }
  // Right camera centre C = (baseline, 0, 0) in the left frame, turned toward the left camera's
  // axis: x_right = R (x_left - C).
  p.R = rot_y(convergence_deg * kPi / 180);
  p.T = -(p.R * cv::Vec3d(baseline_mm, 0, 0));
  return p;
}

PlatePose right_pose(const CameraPair& pair, const PlatePose& left) {
  cv::Matx33d Rl;
  cv::Rodrigues(left.rvec, Rl);
  PlatePose r;
  cv::Rodrigues(cv::Mat(pair.R * Rl), r.rvec);
  r.tvec = pair.R * left.tvec + pair.T;
  return r;
}

std::vector<Shape> dot_shapes(const std::vector<cv::Point2d>& centres, double r, double level) {
  std::vector<Shape> out;
  for (const auto& c : centres) {
    Shape s;
    s.level = level;
    for (int k = 0; k < 128; ++k) {
      const double a = 2 * kPi * k / 128;
      s.outline.emplace_back(c.x + r * std::cos(a), c.y + r * std::sin(a), 0);
    }
    out.push_back(std::move(s));
  }
  return out;
}

std::vector<Shape> checkerboard_shapes(cv::Size inner, double square, double white, double black) {
  auto rect = [&](double x0, double y0, double x1, double y1, double level) {
    Shape s;
    s.level = level;
    constexpr int n = 16;
    for (int i = 0; i < n; ++i) s.outline.emplace_back(x0 + (x1 - x0) * i / n, y0, 0);
    for (int i = 0; i < n; ++i) s.outline.emplace_back(x1, y0 + (y1 - y0) * i / n, 0);
    for (int i = 0; i < n; ++i) s.outline.emplace_back(x1 - (x1 - x0) * i / n, y1, 0);
    for (int i = 0; i < n; ++i) s.outline.emplace_back(x0, y1 - (y1 - y0) * i / n, 0);
    return s;
  };
  const int cols = inner.width + 1, rows = inner.height + 1;
  std::vector<Shape> out = {rect(-2 * square, -2 * square, cols * square, rows * square, white)};
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < cols; ++x)
      if ((x + y) % 2 == 0) out.push_back(rect((x - 1) * square, (y - 1) * square, x * square, y * square, black));
  return out;
}

std::vector<cv::Point2d> project(const CameraModel& cam, const PlatePose& pose, const std::vector<cv::Point2d>& plate,
                                 const Displacement& u) {
  std::vector<cv::Point3d> X;
  for (const auto& p : plate) {
    const cv::Vec3d d = u ? u(p.x, p.y) : cv::Vec3d(0, 0, 0);
    X.emplace_back(p.x + d[0], p.y + d[1], d[2]);
  }
  std::vector<cv::Point2d> x;
  if (!X.empty()) cv::projectPoints(X, pose.rvec, pose.tvec, cam.K, cam.dist, x);
  return x;
}

cv::Point2d on_plate(const CameraModel& cam, const PlatePose& pose, cv::Point2d p) {
  std::vector<cv::Point2d> in = {p}, out;
  cv::undistortPoints(in, out, cam.K, cam.dist);
  cv::Matx33d R;
  cv::Rodrigues(pose.rvec, R);
  // Camera centre and ray in the plate frame; the plane Z = 0.
  const cv::Vec3d o = -(R.t() * pose.tvec), d = R.t() * cv::Vec3d(out[0].x, out[0].y, 1);
  const double t = -o[2] / d[2];
  return {o[0] + t * d[0], o[1] + t * d[1]};
}

cv::Mat render_view(const CameraModel& cam, const PlatePose& pose, const std::vector<Shape>& shapes, double background,
                    int depth, const Displacement& u) {
  cv::Mat img(cam.size, CV_64F, cv::Scalar(background));
  for (const Shape& s : shapes) {
    std::vector<cv::Point2d> plate;
    for (const auto& p : s.outline) plate.emplace_back(p.x, p.y);
    const auto poly = project(cam, pose, plate, u);
    std::vector<cv::Point2f> polyf(poly.begin(), poly.end());
    // Every pixel the outline may reach: its square reaches half a pixel beyond its centre.
    cv::Rect box = cv::boundingRect(polyf);
    box = cv::Rect(box.x - 1, box.y - 1, box.width + 2, box.height + 2) & cv::Rect(0, 0, cam.size.width, cam.size.height);
    for (int y = box.y; y < box.y + box.height; ++y) {
      double* row = img.ptr<double>(y);
      for (int x = box.x; x < box.x + box.width; ++x) {
        const double d = cv::pointPolygonTest(polyf, cv::Point2f(static_cast<float>(x), static_cast<float>(y)), true);
        double cov;
        if (d >= 0.75) cov = 1;
        else if (d <= -0.75) cov = 0;
        else cov = clipped_area(poly, x, y);
        row[x] += cov * (s.level - row[x]);
      }
    }
  }
  cv::Mat out;
  img.convertTo(out, depth, depth == CV_16U ? 257.0 : 1.0);
  return out;
}

}  // namespace dct_indep
