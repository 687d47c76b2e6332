// The independent renderer (render.hpp). Standard library and OpenCV core/imgproc only.
#include "render.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace dct_indep {
namespace {

constexpr double kPi = 3.14159265358979323846;

class None final : public Field {
 public:
  P2 u(P2) const override { return {}; }
  Grad grad(P2) const override { return {}; }
  std::string describe() const override { return "none"; }
};

// Uniaxial strain e along x with Poisson contraction about c.
class Tension final : public Field {
 public:
  Tension(P2 c, double e, double nu) : c_(c), e_(e), nu_(nu) {}
  P2 u(P2 X) const override { return {e_ * (X.x - c_.x), -nu_ * e_ * (X.y - c_.y)}; }
  Grad grad(P2) const override { return {e_, 0, 0, -nu_ * e_}; }
  std::string describe() const override { return "tension e_xx=" + std::to_string(e_); }

 private:
  P2 c_;
  double e_, nu_;
};

// Pure in-plane bending (beam along x, neutral axis y = c.y): u_x = -k x y,
// u_y = k (x^2 + nu y^2) / 2, so e_xx = -k y, e_yy = nu k y, e_xy = 0.
class Bending final : public Field {
 public:
  Bending(P2 c, double k, double nu) : c_(c), k_(k), nu_(nu) {}
  P2 u(P2 X) const override {
    const double x = X.x - c_.x, y = X.y - c_.y;
    return {-k_ * x * y, 0.5 * k_ * (x * x + nu_ * y * y)};
  }
  Grad grad(P2 X) const override {
    const double x = X.x - c_.x, y = X.y - c_.y;
    return {-k_ * y, -k_ * x, k_ * x, k_ * nu_ * y};
  }
  std::string describe() const override { return "bending k=" + std::to_string(k_) + "/px"; }

 private:
  P2 c_;
  double k_, nu_;
};

class Rotation final : public Field {
 public:
  Rotation(P2 c, double t) : c_(c), cs_(std::cos(t)), sn_(std::sin(t)) {}
  P2 u(P2 X) const override {
    const double x = X.x - c_.x, y = X.y - c_.y;
    return {cs_ * x - sn_ * y - x, sn_ * x + cs_ * y - y};
  }
  Grad grad(P2) const override { return {cs_ - 1, -sn_, sn_, cs_ - 1}; }
  std::string describe() const override { return "rigid rotation"; }

 private:
  P2 c_;
  double cs_, sn_;
};

// Kirsch: infinite plate with a circular hole of radius a, plane stress, remote uniaxial
// stress S = E e along y. Displacements (polar, load along the local x' axis):
//   u_r = e (1 + nu) / 2 [ r ((k - 1) / 2 + cos 2t) + a^2 / r (1 + (1 + k) cos 2t) - a^4 / r^3 cos 2t ]
//   u_t = e (1 + nu) / 2 [ (1 - k) a^2 / r - r - a^4 / r^3 ] sin 2t,      k = (3 - nu) / (1 + nu),
// with x' = y - c.y, y' = -(x - c.x) (the load turned onto y). The gradient is taken by
// central differences of this closed form (step 1e-3 px; truncation ~1e-12).
class Kirsch final : public Field {
 public:
  Kirsch(P2 c, double a, double e, double nu) : c_(c), a_(a), e_(e), nu_(nu) {}
  P2 u(P2 X) const override {
    const double xp = X.y - c_.y, yp = -(X.x - c_.x);
    const double r = std::max(std::hypot(xp, yp), 0.5 * a_), t = std::atan2(yp, xp);
    const double k = (3 - nu_) / (1 + nu_), f = e_ * (1 + nu_) / 2, a2 = a_ * a_, a4 = a2 * a2;
    const double c2 = std::cos(2 * t), s2 = std::sin(2 * t);
    const double ur = f * (r * ((k - 1) / 2 + c2) + a2 / r * (1 + (1 + k) * c2) - a4 / (r * r * r) * c2);
    const double ut = f * ((1 - k) * a2 / r - r - a4 / (r * r * r)) * s2;
    const double uxp = ur * std::cos(t) - ut * std::sin(t), uyp = ur * std::sin(t) + ut * std::cos(t);
    return {-uyp, uxp};  // back from the primed axes
  }
  Grad grad(P2 X) const override {
    const double h = 1e-3;
    const P2 px = u({X.x + h, X.y}), mx = u({X.x - h, X.y}), py = u({X.x, X.y + h}), my = u({X.x, X.y - h});
    return {(px.x - mx.x) / (2 * h), (py.x - my.x) / (2 * h), (px.y - mx.y) / (2 * h), (py.y - my.y) / (2 * h)};
  }
  bool material(P2 X) const override { return std::hypot(X.x - c_.x, X.y - c_.y) >= a_; }
  std::string describe() const override { return "Kirsch plate, hole radius " + std::to_string(a_) + " px, load y"; }

 private:
  P2 c_;
  double a_, e_, nu_;
};

// The reference point X with X + u(X) = x (fixed point; |grad u| << 1 here).
P2 inverse(const Field& f, P2 x) {
  P2 X = x;
  for (int it = 0; it < 60; ++it) {
    const P2 d = f.u(X);
    const P2 n{x.x - d.x, x.y - d.y};
    const double step = std::hypot(n.x - X.x, n.y - X.y);
    X = n;
    if (step < 1e-13) break;
  }
  return X;
}

// Area of the square [cx - h/2, cx + h/2] x [cy - h/2, cy + h/2] where v + gx (x - cx) +
// gy (y - cy) <= 0: the square clipped by the half-plane (Sutherland-Hodgman), shoelace area.
double half_plane_area(double h, double v, double gx, double gy) {
  const double q = h / 2;
  P2 poly[8] = {{-q, -q}, {q, -q}, {q, q}, {-q, q}};
  int n = 4;
  P2 out[8];
  int m = 0;
  auto val = [&](P2 p) { return v + gx * p.x + gy * p.y; };
  for (int i = 0; i < n; ++i) {
    const P2 a = poly[i], b = poly[(i + 1) % n];
    const double fa = val(a), fb = val(b);
    if (fa <= 0) out[m++] = a;
    if ((fa <= 0) != (fb <= 0)) {
      const double t = fa / (fa - fb);
      out[m++] = {a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)};
    }
  }
  double area = 0;
  for (int i = 0; i < m; ++i) {
    const P2 a = out[i], b = out[(i + 1) % m];
    area += a.x * b.y - b.x * a.y;
  }
  return std::abs(area) / 2;
}

// Covered area of the cell centred at (cx, cy) of side h, for the signed distance `sd` (< 0
// inside) whose Lipschitz constant is at most L.
template <class SD>
double cover(const SD& sd, double cx, double cy, double h, double leaf, double L) {
  const double v = sd(cx, cy);
  const double reach = L * h * 0.7071067811865476;
  if (v >= reach) return 0;
  if (v <= -reach) return h * h;
  if (h <= leaf * 1.000001) {
    const double e = h / 4;
    const double gx = (sd(cx + e, cy) - sd(cx - e, cy)) / (2 * e);
    const double gy = (sd(cx, cy + e) - sd(cx, cy - e)) / (2 * e);
    return half_plane_area(h, v, gx, gy);
  }
  const double q = h / 4;
  return cover(sd, cx - q, cy - q, h / 2, leaf, L) + cover(sd, cx + q, cy - q, h / 2, leaf, L) +
         cover(sd, cx - q, cy + q, h / 2, leaf, L) + cover(sd, cx + q, cy + q, h / 2, leaf, L);
}

// Adds the coverage of the disc (reference centre C, radius R) mapped by the field (or not)
// into `cov` (CV_64F).
void add_disc(const Scene& s, bool deformed, P2 C, double R, cv::Mat& cov) {
  const Field& f = *s.field;
  const P2 c = deformed ? s.deformed(C) : C;
  const double grow = deformed ? 1.1 : 1.0;
  const int x0 = std::max(0, static_cast<int>(std::floor(c.x - grow * R - 2)));
  const int x1 = std::min(cov.cols - 1, static_cast<int>(std::ceil(c.x + grow * R + 2)));
  const int y0 = std::max(0, static_cast<int>(std::floor(c.y - grow * R - 2)));
  const int y1 = std::min(cov.rows - 1, static_cast<int>(std::ceil(c.y + grow * R + 2)));
  const double L = deformed ? 1.05 : 1.0;
  auto sd = [&](double x, double y) {
    if (!deformed) return std::hypot(x - C.x, y - C.y) - R;
    const P2 X = inverse(f, {x, y});
    return std::hypot(X.x - C.x, X.y - C.y) - R;
  };
  for (int y = y0; y <= y1; ++y) {
    double* row = cov.ptr<double>(y);
    for (int x = x0; x <= x1; ++x) row[x] += cover(sd, x, y, 1.0, s.p.leaf, L);
  }
}

}  // namespace

P2 Scene::deformed(P2 X) const {
  const P2 d = field->u(X);
  return {X.x + d.x, X.y + d.y};
}

double coverage_error_bound(const Params& p) { return std::sqrt(2.0) * p.leaf * p.leaf / (4 * p.radius); }

Scene make_scene(const Params& p) {
  auto bad = [](const std::string& m) { throw std::invalid_argument(m); };
  if (p.width < 64 || p.height < 64 || p.width > 8192 || p.height > 8192) bad("size must be 64..8192 a side");
  if (!(p.radius >= 2 && p.radius <= 50)) bad("radius must lie in 2..50 px");
  if (p.dots < 1 || p.dots > 20000) bad("dots must lie in 1..20000");
  if (!(p.noise >= 0 && p.noise <= 50) || !(p.blur >= 0 && p.blur <= 10)) bad("noise 0..50, blur 0..10");
  if (!(p.leaf > 0 && p.leaf <= 0.25)) bad("leaf must lie in (0, 0.25] px");
  Scene s;
  s.p = p;
  s.centre = {0.5 * (p.width - 1), 0.5 * (p.height - 1)};
  if (p.deformation == "none") s.field = std::make_unique<None>();
  else if (p.deformation == "tension") s.field = std::make_unique<Tension>(s.centre, p.strain, p.nu);
  else if (p.deformation == "bending") s.field = std::make_unique<Bending>(s.centre, p.curvature, p.nu);
  else if (p.deformation == "rotation") s.field = std::make_unique<Rotation>(s.centre, p.angle_deg * kPi / 180);
  else if (p.deformation == "kirsch") s.field = std::make_unique<Kirsch>(s.centre, p.hole, p.strain, p.nu);
  else bad("deformation must be none, tension, bending, rotation or kirsch");
  // Random dots, rejection sampling with a minimum centre distance; dots keep clear of the
  // edges (after deformation) and of the hole.
  std::mt19937_64 rng(p.seed);
  const double margin = p.radius + 16 + (p.deformation == "rotation" ? std::abs(p.angle_deg) * 0.02 * p.width : 0);
  std::uniform_real_distribution<double> ux(margin, p.width - 1 - margin), uy(margin, p.height - 1 - margin);
  const double dmin = 2 * p.radius + p.min_gap;
  const double cell = dmin;
  const int gx = static_cast<int>(p.width / cell) + 1, gy = static_cast<int>(p.height / cell) + 1;
  std::vector<std::vector<int>> grid(static_cast<std::size_t>(gx) * gy);
  const bool hole = p.deformation == "kirsch";
  for (long tries = 0; static_cast<int>(s.dots.size()) < p.dots; ++tries) {
    if (tries > 200L * p.dots + 100000) bad("the dots do not fit the image with that gap; fewer or smaller dots");
    const P2 c{ux(rng), uy(rng)};
    if (hole && std::hypot(c.x - s.centre.x, c.y - s.centre.y) < p.hole + p.radius + 6) continue;
    const int cx = static_cast<int>(c.x / cell), cy = static_cast<int>(c.y / cell);
    bool ok = true;
    for (int j = std::max(0, cy - 1); j <= std::min(gy - 1, cy + 1) && ok; ++j)
      for (int i = std::max(0, cx - 1); i <= std::min(gx - 1, cx + 1) && ok; ++i)
        for (int k : grid[static_cast<std::size_t>(j) * gx + i])
          if (std::hypot(s.dots[k].x - c.x, s.dots[k].y - c.y) < dmin) { ok = false; break; }
    if (!ok) continue;
    grid[static_cast<std::size_t>(cy) * gx + cx].push_back(static_cast<int>(s.dots.size()));
    s.dots.push_back(c);
  }
  // The map must stay close to an isometry for the cell test's Lipschitz bound (1.05).
  for (const P2& X : {P2{0, 0}, P2{double(p.width), 0}, P2{0, double(p.height)}, P2{double(p.width), double(p.height)},
                      P2{s.centre.x + p.hole, s.centre.y}})
    if (s.field->material(X)) {
      const Grad g = s.field->grad(X);
      if (std::max({std::abs(g.xx), std::abs(g.xy), std::abs(g.yx), std::abs(g.yy)}) > 0.02)
        bad("the deformation's gradient exceeds 0.02; use a smaller strain, curvature or angle");
    }
  return s;
}

cv::Mat render_clean(const Scene& s, bool deformed) {
  const Params& p = s.p;
  cv::Mat cov = cv::Mat::zeros(p.height, p.width, CV_64F);
  for (const P2& c : s.dots) add_disc(s, deformed, c, p.radius, cov);
  if (p.deformation == "kirsch") {
    // The hole shows the dark ground behind the plate: the disc of radius a, mapped.
    cv::Mat hole = cv::Mat::zeros(p.height, p.width, CV_64F);
    const Field& f = *s.field;
    const P2 O = s.centre;
    const double a = p.hole;
    auto sd = [&](double x, double y) {
      if (std::hypot(x - O.x, y - O.y) < 0.8 * a) return -0.2 * a;  // deep inside
      const P2 X = deformed ? inverse(f, {x, y}) : P2{x, y};
      return std::hypot(X.x - O.x, X.y - O.y) - a;
    };
    const int x0 = std::max(0, static_cast<int>(O.x - 1.1 * a - 3)), x1 = std::min(p.width - 1, static_cast<int>(O.x + 1.1 * a + 3));
    const int y0 = std::max(0, static_cast<int>(O.y - 1.1 * a - 3)), y1 = std::min(p.height - 1, static_cast<int>(O.y + 1.1 * a + 3));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) hole.at<double>(y, x) = cover(sd, x, y, 1.0, p.leaf, 1.05);
    cov += hole;
  }
  cv::min(cov, 1.0, cov);
  cv::Mat img = p.background - (p.background - p.ink) * cov;
  if (p.blur > 0) cv::GaussianBlur(img, img, cv::Size(0, 0), p.blur, p.blur, cv::BORDER_REPLICATE);
  return img;
}

cv::Mat finish(const cv::Mat& clean, double noise, std::uint64_t seed) {
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ULL + 12345);
  std::normal_distribution<double> n(0, noise);
  cv::Mat out(clean.size(), CV_8U);
  for (int y = 0; y < clean.rows; ++y) {
    const double* in = clean.ptr<double>(y);
    auto* o = out.ptr<std::uint8_t>(y);
    for (int x = 0; x < clean.cols; ++x) {
      const double v = std::round(in[x] + (noise > 0 ? n(rng) : 0.0));
      o[x] = static_cast<std::uint8_t>(std::clamp(v, 0.0, 255.0));
    }
  }
  return out;
}

void write_truth(const Scene& s, const std::string& dir, int nx, int ny) {
  std::filesystem::create_directories(dir);
  std::ofstream d(std::filesystem::path(dir) / "dots.csv");
  d.precision(10);
  d << "# pixel (c, r) is the unit square centred on (c, r); " << s.field->describe() << "\n";
  d << "id,x_ref_px,y_ref_px,x_def_px,y_def_px\n";
  for (std::size_t k = 0; k < s.dots.size(); ++k) {
    const P2 q = s.deformed(s.dots[k]);
    d << k << ',' << s.dots[k].x << ',' << s.dots[k].y << ',' << q.x << ',' << q.y << '\n';
  }
  std::ofstream t(std::filesystem::path(dir) / "truth.csv");
  t.precision(10);
  t << "# " << s.field->describe() << "; reference positions; strain = small-strain tensor of du/dX\n";
  t << "x_px,y_px,material,u_x_px,u_y_px,du_x_dx,du_x_dy,du_y_dx,du_y_dy,e_xx_microstrain,e_yy_microstrain,"
       "e_xy_microstrain\n";
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const P2 X{(s.p.width - 1) * (i + 0.5) / nx, (s.p.height - 1) * (j + 0.5) / ny};
      const bool m = s.field->material(X);
      const P2 u = m ? s.field->u(X) : P2{};
      const Grad g = m ? s.field->grad(X) : Grad{};
      t << X.x << ',' << X.y << ',' << m << ',' << u.x << ',' << u.y << ',' << g.xx << ',' << g.xy << ',' << g.yx
        << ',' << g.yy << ',' << 1e6 * exx(g) << ',' << 1e6 * eyy(g) << ',' << 1e6 * exy(g) << '\n';
    }
}

}  // namespace dct_indep
