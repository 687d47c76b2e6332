#include "workloads/dct/specimen.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <functional>
#include <random>

#include <fmt/format.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "model/errors.hpp"
#include "model/units.hpp"

namespace dtflop::dct {
namespace {

constexpr double kPi = std::numbers::pi;

class Identity final : public Deformation {
 public:
  Vec2 displacement(Vec2) const override { return {}; }
  Gradient gradient(Vec2) const override { return {}; }
  std::string describe() const override { return "reference (no deformation)"; }
};

class Translation final : public Deformation {
 public:
  Translation(double dx, double dy) : d_{dx, dy} {}
  Vec2 displacement(Vec2) const override { return d_; }
  Gradient gradient(Vec2) const override { return {}; }
  std::string describe() const override { return fmt::format("translation ({}, {}) px", d_.x, d_.y); }

 private:
  Vec2 d_;
};

class Rotation final : public Deformation {
 public:
  Rotation(Vec2 c, double t) : c_(c), t_(t) {}
  Vec2 displacement(Vec2 X) const override {
    const double dx = X.x - c_.x, dy = X.y - c_.y, c = std::cos(t_), s = std::sin(t_);
    return {c * dx - s * dy - dx, s * dx + c * dy - dy};
  }
  Gradient gradient(Vec2) const override {
    const double c = std::cos(t_), s = std::sin(t_);
    return {c - 1, -s, s, c - 1};
  }
  std::string describe() const override {
    return fmt::format("rotation {} deg about ({}, {})", t_ * 180 / kPi, c_.x, c_.y);
  }

 private:
  Vec2 c_;
  double t_;
};

class Uniform final : public Deformation {
 public:
  Uniform(Vec2 c, double exx, double eyy, double exy) : c_(c), exx_(exx), eyy_(eyy), exy_(exy) {}
  Vec2 displacement(Vec2 X) const override {
    const double dx = X.x - c_.x, dy = X.y - c_.y;
    return {exx_ * dx + exy_ * dy, exy_ * dx + eyy_ * dy};
  }
  Gradient gradient(Vec2) const override { return {exx_, exy_, exy_, eyy_}; }
  std::string describe() const override {
    return fmt::format("uniform strain e_xx={:g} e_yy={:g} e_xy={:g}", exx_, eyy_, exy_);
  }

 private:
  Vec2 c_;
  double exx_, eyy_, exy_;
};

class Bending final : public Deformation {
 public:
  Bending(Vec2 c, double k, double nu) : c_(c), k_(k), nu_(nu) {}
  Vec2 displacement(Vec2 X) const override {
    const double x = X.x - c_.x, y = X.y - c_.y;
    return {-k_ * x * y, 0.5 * k_ * (x * x + nu_ * y * y)};
  }
  Gradient gradient(Vec2 X) const override {
    const double x = X.x - c_.x, y = X.y - c_.y;
    return {-k_ * y, -k_ * x, k_ * x, k_ * nu_ * y};
  }
  std::string describe() const override {
    return fmt::format("pure bending, curvature {:g} /px, nu {}", k_, nu_);
  }

 private:
  Vec2 c_;
  double k_, nu_;
};

// Kirsch's solution in a local frame whose x axis is the load direction (angle phi).
class Kirsch final : public Deformation {
 public:
  Kirsch(Vec2 c, double a, double e0, double nu, double phi)
      : c_(c), a_(a), e0_(e0), nu_(nu), cp_(std::cos(phi)), sp_(std::sin(phi)), along_y_(phi != 0) {}

  Vec2 displacement(Vec2 X) const override {
    const Vec2 l = to_local(X);
    const double r = std::max(std::hypot(l.x, l.y), 1e-9 * a_), t = std::atan2(l.y, l.x);
    const double kappa = (3 - nu_) / (1 + nu_);
    // T a / (8 mu) with T / mu = 2 (1 + nu) e0.
    const double f = 2 * (1 + nu_) * e0_ * a_ / 8;
    const double q = a_ / r, q3 = q * q * q;
    const double ux = f * ((r / a_) * (kappa + 1) * std::cos(t) +
                           2 * q * ((1 + kappa) * std::cos(t) + std::cos(3 * t)) - 2 * q3 * std::cos(3 * t));
    const double uy = f * ((r / a_) * (kappa - 3) * std::sin(t) +
                           2 * q * ((1 - kappa) * std::sin(t) + std::sin(3 * t)) - 2 * q3 * std::sin(3 * t));
    return {cp_ * ux - sp_ * uy, sp_ * ux + cp_ * uy};
  }

  // Strain from the closed-form stresses (plane stress Hooke); the rotation part from the
  // displacement's central difference (only the inverse mapping uses it).
  Gradient gradient(Vec2 X) const override {
    const Vec2 l = to_local(X);
    const double r = std::max(std::hypot(l.x, l.y), 1e-9 * a_), t = std::atan2(l.y, l.x);
    const double q2 = (a_ / r) * (a_ / r), q4 = q2 * q2;
    const double T = 1.0;  // stresses in units of T; strains scale by e0 = T / E
    const double srr = T / 2 * (1 - q2) + T / 2 * (1 - 4 * q2 + 3 * q4) * std::cos(2 * t);
    const double stt = T / 2 * (1 + q2) - T / 2 * (1 + 3 * q4) * std::cos(2 * t);
    const double srt = -T / 2 * (1 + 2 * q2 - 3 * q4) * std::sin(2 * t);
    const double c = std::cos(t), s = std::sin(t);
    const double sxx = srr * c * c + stt * s * s - 2 * srt * s * c;
    const double syy = srr * s * s + stt * c * c + 2 * srt * s * c;
    const double sxy = (srr - stt) * s * c + srt * (c * c - s * s);
    const double exx = e0_ * (sxx - nu_ * syy), eyy = e0_ * (syy - nu_ * sxx), exy = e0_ * (1 + nu_) * sxy;
    // Rotation w = (duy/dx - dux/dy) / 2 in the local frame, by central differences.
    const double h = 1e-4 * a_;
    const Vec2 ex{cp_ * h, sp_ * h}, ey{-sp_ * h, cp_ * h};
    auto local_u = [this](Vec2 P) {
      const Vec2 u = displacement(P);
      return Vec2{cp_ * u.x + sp_ * u.y, -sp_ * u.x + cp_ * u.y};
    };
    const Vec2 upx = local_u({X.x + ex.x, X.y + ex.y}), umx = local_u({X.x - ex.x, X.y - ex.y});
    const Vec2 upy = local_u({X.x + ey.x, X.y + ey.y}), umy = local_u({X.x - ey.x, X.y - ey.y});
    const double w = 0.5 * ((upx.y - umx.y) - (upy.x - umy.x)) / (2 * h);
    // Local gradient G' = [[exx, exy - w], [exy + w, eyy]]; global G = R G' R^T.
    const double g00 = exx, g01 = exy - w, g10 = exy + w, g11 = eyy;
    const double a00 = cp_ * g00 - sp_ * g10, a01 = cp_ * g01 - sp_ * g11;
    const double a10 = sp_ * g00 + cp_ * g10, a11 = sp_ * g01 + cp_ * g11;
    return {a00 * cp_ - a01 * sp_, a00 * sp_ + a01 * cp_, a10 * cp_ - a11 * sp_, a10 * sp_ + a11 * cp_};
  }

  bool in_material(Vec2 X) const override { return std::hypot(X.x - c_.x, X.y - c_.y) >= a_; }
  std::string describe() const override {
    return fmt::format("Kirsch plate, hole radius {} px at ({}, {}), far-field strain {:g} along {}, nu {}",
                       a_, c_.x, c_.y, e0_, along_y_ ? "y" : "x", nu_);
  }

 private:
  Vec2 to_local(Vec2 X) const {
    const double dx = X.x - c_.x, dy = X.y - c_.y;
    return {cp_ * dx + sp_ * dy, -sp_ * dx + cp_ * dy};
  }
  Vec2 c_;
  double a_, e0_, nu_, cp_, sp_;
  bool along_y_;
};

void check_area(const PatternArea& a) {
  if (!(a.x1 > a.x0) || !(a.y1 > a.y0))
    throw InputError(fmt::format("dot pattern area [{}, {}] x [{}, {}] is empty; give a larger image "
                                 "or a smaller margin", a.x0, a.x1, a.y0, a.y1));
}

bool kept_out(const PatternArea& a, Vec2 p, double r) {
  if (!a.keep_out_centre) return false;
  return std::hypot(p.x - a.keep_out_centre->x, p.y - a.keep_out_centre->y) < a.keep_out_radius + r;
}

}  // namespace

std::optional<Vec2> Deformation::inverse(Vec2 x) const {
  const Vec2 u0 = displacement(x);
  Vec2 X{x.x - u0.x, x.y - u0.y};
  for (int it = 0; it < 30; ++it) {
    const Vec2 u = displacement(X);
    const double rx = X.x + u.x - x.x, ry = X.y + u.y - x.y;
    if (std::abs(rx) < 1e-11 && std::abs(ry) < 1e-11) return X;
    const Gradient g = gradient(X);
    const double f00 = 1 + g.ux_x, f01 = g.ux_y, f10 = g.uy_x, f11 = 1 + g.uy_y;
    const double det = f00 * f11 - f01 * f10;
    if (!(std::abs(det) > 1e-12)) return std::nullopt;
    X.x -= (f11 * rx - f01 * ry) / det;
    X.y -= (-f10 * rx + f00 * ry) / det;
  }
  const Vec2 u = displacement(X);
  if (std::hypot(X.x + u.x - x.x, X.y + u.y - x.y) < 1e-8) return X;
  return std::nullopt;
}

std::unique_ptr<Deformation> make_identity() { return std::make_unique<Identity>(); }
std::unique_ptr<Deformation> make_translation(double dx, double dy) {
  return std::make_unique<Translation>(dx, dy);
}
std::unique_ptr<Deformation> make_rotation(Vec2 c, double radians) {
  return std::make_unique<Rotation>(c, radians);
}
std::unique_ptr<Deformation> make_uniform(Vec2 c, double exx, double eyy, double exy) {
  return std::make_unique<Uniform>(c, exx, eyy, exy);
}
std::unique_ptr<Deformation> make_bending(Vec2 c, double k, double nu) {
  return std::make_unique<Bending>(c, k, nu);
}
std::unique_ptr<Deformation> make_kirsch(Vec2 c, double a, double e0, double nu, bool load_along_y) {
  if (!(a > 0)) throw InputError(fmt::format("Kirsch hole radius a = {} px must be > 0", a));
  if (!(nu > -1 && nu < 0.5)) throw InputError(fmt::format("Poisson's ratio {} must lie in (-1, 0.5)", nu));
  return std::make_unique<Kirsch>(c, a, e0, nu, load_along_y ? kPi / 2 : 0.0);
}

std::vector<Dot> grid_pattern(const PatternArea& area, double pitch, double radius) {
  check_area(area);
  if (!(radius > 0) || !(pitch > 2 * radius))
    throw InputError(fmt::format("grid pitch {} px must exceed the dot diameter {} px (radius > 0)", pitch,
                                 2 * radius));
  const int nx = static_cast<int>(std::floor((area.x1 - area.x0 - 2 * radius) / pitch)) + 1;
  const int ny = static_cast<int>(std::floor((area.y1 - area.y0 - 2 * radius) / pitch)) + 1;
  if (nx < 1 || ny < 1) throw InputError("the grid pattern area holds no dot; enlarge it or shrink the dots");
  const double ox = 0.5 * (area.x0 + area.x1) - 0.5 * (nx - 1) * pitch;
  const double oy = 0.5 * (area.y0 + area.y1) - 0.5 * (ny - 1) * pitch;
  std::vector<Dot> dots;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const Vec2 p{ox + i * pitch, oy + j * pitch};
      if (!kept_out(area, p, radius)) dots.push_back({p, radius});
    }
  return dots;
}

namespace {
// Dart throwing with a background grid; `spacing(p)` is the least centre distance a dot at
// p needs to its neighbours (the larger of the two dots' needs is used).
std::vector<Dot> dart_throw(const PatternArea& area, int count, std::uint64_t seed, double max_spacing,
                            const std::function<double(Vec2)>& spacing,
                            const std::function<double(Vec2)>& radius) {
  check_area(area);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(area.x0, area.x1), uy(area.y0, area.y1);
  const double cell = max_spacing;
  const int gx = static_cast<int>((area.x1 - area.x0) / cell) + 1, gy = static_cast<int>((area.y1 - area.y0) / cell) + 1;
  std::vector<std::vector<int>> grid(static_cast<std::size_t>(gx) * gy);
  std::vector<Dot> dots;
  std::vector<double> need;
  const std::int64_t tries = count > 0 ? 200LL * count : 200000LL;
  int misses = 0;
  for (std::int64_t t = 0; t < tries && (count <= 0 || static_cast<int>(dots.size()) < count); ++t) {
    const Vec2 p{ux(rng), uy(rng)};
    const double r = radius(p);
    if (p.x - r < area.x0 || p.x + r > area.x1 || p.y - r < area.y0 || p.y + r > area.y1) continue;
    if (kept_out(area, p, r)) continue;
    const double s = spacing(p);
    const int cx = static_cast<int>((p.x - area.x0) / cell), cy = static_cast<int>((p.y - area.y0) / cell);
    bool ok = true;
    for (int y = std::max(0, cy - 1); ok && y <= std::min(gy - 1, cy + 1); ++y)
      for (int x = std::max(0, cx - 1); ok && x <= std::min(gx - 1, cx + 1); ++x)
        for (int k : grid[static_cast<std::size_t>(y) * gx + x]) {
          const double d = std::hypot(dots[k].centre.x - p.x, dots[k].centre.y - p.y);
          if (d < std::max(s, need[k])) { ok = false; break; }
        }
    if (!ok) {
      if (count <= 0 && ++misses > 4000) break;
      continue;
    }
    misses = 0;
    grid[static_cast<std::size_t>(cy) * gx + cx].push_back(static_cast<int>(dots.size()));
    dots.push_back({p, r});
    need.push_back(s);
  }
  if (count > 0 && static_cast<int>(dots.size()) < count)
    throw InputError(fmt::format("only {} of {} random dots fit the area with the requested gap; ask "
                                 "for fewer dots, smaller dots or a smaller gap",
                                 dots.size(), count));
  return dots;
}
}  // namespace

std::vector<Dot> random_pattern(const PatternArea& area, double radius, double min_gap, int count,
                                std::uint64_t seed) {
  if (!(radius > 0) || !(min_gap >= 0))
    throw InputError(fmt::format("random dots need radius > 0 and gap >= 0 (got {} and {})", radius, min_gap));
  const double s = 2 * radius + min_gap;
  return dart_throw(area, count, seed, s, [s](Vec2) { return s; }, [radius](Vec2) { return radius; });
}

std::vector<Dot> graded_pattern(const PatternArea& area, const Graded& g, std::uint64_t seed) {
  if (!(g.radius_near > 0 && g.radius_far >= g.radius_near && g.pitch_near > 2 * g.radius_near &&
        g.pitch_far >= g.pitch_near && g.pitch_far > 2 * g.radius_far && g.grade_length > 0))
    throw InputError("graded pattern needs 0 < radius_near <= radius_far, pitches above the dot "
                     "diameters with pitch_near <= pitch_far, and grade_length > 0");
  auto frac = [&g](Vec2 p) {
    return std::min(1.0, std::hypot(p.x - g.focus.x, p.y - g.focus.y) / g.grade_length);
  };
  return dart_throw(
      area, 0, seed, g.pitch_far,
      [&](Vec2 p) { return g.pitch_near + (g.pitch_far - g.pitch_near) * frac(p); },
      [&](Vec2 p) { return g.radius_near + (g.radius_far - g.radius_near) * frac(p); });
}

void validate(const RenderOptions& o) {
  if (o.width < 8 || o.height < 8 || o.width > 16384 || o.height > 16384 ||
      static_cast<std::int64_t>(o.width) * o.height > 24'000'000LL + 1'000'000LL)
    throw InputError(fmt::format("image size {}x{} is outside 8x8 .. 24 MP (sides up to 16384)", o.width,
                                 o.height));
  if (o.bit_depth != 8 && o.bit_depth != 16)
    throw InputError(fmt::format("bit depth {} is not supported; use 8 or 16", o.bit_depth));
  if (o.supersample < 1 || o.supersample > 64)
    throw InputError(fmt::format("supersample {} must lie in 1..64", o.supersample));
  if (!(o.blur_sigma >= 0) || !(o.noise_sigma >= 0) || !(std::abs(o.lighting) < 1))
    throw InputError("blur and noise must be >= 0 and the lighting gradient within (-1, 1)");
  for (double v : {o.ground, o.ink, o.hole_level})
    if (!(v >= 0 && v <= 255)) throw InputError(fmt::format("grey level {} is outside 0..255", v));
}

namespace {

// Coverage of a disc (reference centre Xc, radius r) over pixel centres in `box`, deformed
// by `def`, written into `tile` (CV_32F, box-sized).
void cover_disc(const Deformation& def, Vec2 Xc, double r, int n, cv::Rect box, cv::Mat& tile) {
  tile.create(box.height, box.width, CV_32F);
  tile.setTo(0);
  const Vec2 xc = def.map(Xc);
  const Gradient gc = def.gradient(Xc);
  for (int i = 0; i < box.height; ++i)
    for (int j = 0; j < box.width; ++j) {
      const Vec2 p{static_cast<double>(box.x + j), static_cast<double>(box.y + i)};
      // A cheap exclusion with the centre's Jacobian before the exact pre-image.
      const double f00 = 1 + gc.ux_x, f01 = gc.ux_y, f10 = gc.uy_x, f11 = 1 + gc.uy_y;
      const double det = f00 * f11 - f01 * f10;
      const double dx = p.x - xc.x, dy = p.y - xc.y;
      const double lx = (f11 * dx - f01 * dy) / det, ly = (-f10 * dx + f00 * dy) / det;
      if (std::hypot(lx, ly) > r + 3) continue;
      const auto X = def.inverse(p);
      if (!X) {
        // No pre-image (Kirsch's field is singular at the hole's centre): deep inside by the
        // centre's Jacobian is inside.
        if (std::hypot(lx, ly) < r - 3) tile.at<float>(i, j) = 1.f;
        continue;
      }
      const Gradient g = def.gradient(*X);
      const double a00 = 1 + g.ux_x, a01 = g.ux_y, a10 = g.uy_x, a11 = 1 + g.uy_y;
      const double dt = a00 * a11 - a01 * a10;
      const double i00 = a11 / dt, i01 = -a01 / dt, i10 = -a10 / dt, i11 = a00 / dt;
      // Half diagonal of the pixel's pre-image.
      const double h = 0.5 * (std::hypot(i00, i10) + std::hypot(i01, i11)) + 1e-9;
      const double d = std::hypot(X->x - Xc.x, X->y - Xc.y);
      float c;
      if (d <= r - h) {
        c = 1.f;
      } else if (d >= r + h) {
        c = 0.f;
      } else {
        int in = 0;
        for (int sy = 0; sy < n; ++sy)
          for (int sx = 0; sx < n; ++sx) {
            const double ox = (sx + 0.5) / n - 0.5, oy = (sy + 0.5) / n - 0.5;
            const double qx = X->x + i00 * ox + i01 * oy - Xc.x, qy = X->y + i10 * ox + i11 * oy - Xc.y;
            in += qx * qx + qy * qy <= r * r;
          }
        c = static_cast<float>(in) / static_cast<float>(n * n);
      }
      tile.at<float>(i, j) = c;
    }
}

cv::Rect deformed_box(const Deformation& def, Vec2 Xc, double r, cv::Size size) {
  const Vec2 xc = def.map(Xc);
  const Gradient g = def.gradient(Xc);
  const double s = 1 + std::abs(g.ux_x) + std::abs(g.ux_y) + std::abs(g.uy_x) + std::abs(g.uy_y);
  const double R = r * s + 3;
  // Clamped as doubles: near a singular field (a hole's centre under Kirsch's solution) the
  // mapped centre can be far outside any int, and converting such a double to int is undefined.
  if (!std::isfinite(xc.x) || !std::isfinite(xc.y) || !std::isfinite(R)) return {};
  const double w = size.width, h = size.height;
  const int x0 = static_cast<int>(std::clamp(std::floor(xc.x - R), 0.0, w));
  const int y0 = static_cast<int>(std::clamp(std::floor(xc.y - R), 0.0, h));
  const int x1 = static_cast<int>(std::clamp(std::ceil(xc.x + R), -1.0, w - 1));
  const int y1 = static_cast<int>(std::clamp(std::ceil(xc.y + R), -1.0, h - 1));
  if (x1 < x0 || y1 < y0) return {};
  return {x0, y0, x1 - x0 + 1, y1 - y0 + 1};
}

}  // namespace

cv::Mat render(const std::vector<Dot>& dots, const Deformation& def, const RenderOptions& o,
               const std::optional<std::pair<Vec2, double>>& hole) {
  validate(o);
  const cv::Size size(o.width, o.height);
  cv::Mat dot_cov(size, CV_32F, cv::Scalar(0)), hole_cov(size, CV_32F, cv::Scalar(0));
  std::vector<cv::Rect> boxes(dots.size());
  std::vector<cv::Mat> tiles(dots.size());
  cv::parallel_for_(cv::Range(0, static_cast<int>(dots.size())), [&](const cv::Range& range) {
    for (int k = range.start; k < range.end; ++k) {
      boxes[k] = deformed_box(def, dots[k].centre, dots[k].radius, size);
      if (boxes[k].area() > 0) cover_disc(def, dots[k].centre, dots[k].radius, o.supersample, boxes[k], tiles[k]);
    }
  });
  for (std::size_t k = 0; k < dots.size(); ++k)
    if (boxes[k].area() > 0) {
      cv::Mat roi = dot_cov(boxes[k]);
      roi += tiles[k];
    }
  if (hole) {
    const cv::Rect box = deformed_box(def, hole->first, hole->second, size);
    if (box.area() > 0) {
      cv::Mat tile;
      cover_disc(def, hole->first, hole->second, o.supersample, box, tile);
      tile.copyTo(hole_cov(box));
    }
  }
  cv::min(dot_cov, 1.0, dot_cov);
  const bool light = o.polarity == Polarity::light_dots;
  const double ground = light ? std::min(o.ground, o.ink) : std::max(o.ground, o.ink);
  const double ink = light ? std::max(o.ground, o.ink) : std::min(o.ground, o.ink);
  cv::Mat img(size, CV_32F);
  cv::parallel_for_(cv::Range(0, o.height), [&](const cv::Range& rows) {
    for (int i = rows.start; i < rows.end; ++i) {
      const float* dc = dot_cov.ptr<float>(i);
      const float* hc = hole_cov.ptr<float>(i);
      float* out = img.ptr<float>(i);
      for (int j = 0; j < o.width; ++j) {
        const double L = 1 + o.lighting * (static_cast<double>(j) / std::max(1, o.width - 1) - 0.5);
        const double h = hc[j], d = std::min<double>(dc[j], 1 - h);
        out[j] = static_cast<float>(L * (ground * (1 - d - h) + ink * d + o.hole_level * h));
      }
    }
  });
  if (o.blur_sigma > 0) cv::GaussianBlur(img, img, cv::Size(0, 0), o.blur_sigma, o.blur_sigma, cv::BORDER_REFLECT);
  if (o.noise_sigma > 0) {
    cv::Mat noise(size, CV_32F);
    cv::RNG rng(o.seed);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, o.noise_sigma);
    img += noise;
  }
  cv::Mat out;
  if (o.bit_depth == 8)
    img.convertTo(out, CV_8U);  // rounds and saturates
  else
    img.convertTo(out, CV_16U, 257.0);
  return out;
}

std::vector<Vec2> Specimen::reference_centres() const {
  std::vector<Vec2> v;
  v.reserve(dots.size());
  for (const auto& d : dots) v.push_back(d.centre);
  return v;
}

std::vector<Vec2> Specimen::deformed_centres() const {
  std::vector<Vec2> v;
  v.reserve(dots.size());
  for (const auto& d : dots) v.push_back(deformation->map(d.centre));
  return v;
}

cv::Mat Specimen::reference_image() const {
  RenderOptions o = render;
  return dct::render(dots, *make_identity(), o, hole);
}

cv::Mat Specimen::deformed_image() const {
  RenderOptions o = render;
  o.seed = render.seed + 1;  // independent sensor noise
  return dct::render(dots, *deformation, o, hole);
}

namespace {

// The value of `key` (or `fallback` when absent), a finite number in [lo, hi] (whole when `whole`);
// throws InputError naming the key and its range otherwise.
double num(const std::map<std::string, std::string>& kv, const std::string& key, double fallback, double lo, double hi,
           bool whole = false) {
  const auto it = kv.find(key);
  if (it == kv.end()) return fallback;
  double v = 0;
  try {
    std::size_t used = 0;
    v = std::stod(it->second, &used);
    if (used != it->second.size() || !std::isfinite(v)) throw std::invalid_argument("trailing");
  } catch (const std::exception&) {
    throw InputError(fmt::format("specimen key '{}={}' is not a finite number; give one in [{}, {}]", key,
                                 it->second.substr(0, 40), lo, hi));
  }
  if (v < lo || v > hi || (whole && v != std::floor(v)))
    throw InputError(fmt::format("specimen key '{}={}' is outside [{}, {}]{}; give a value inside it", key, it->second,
                                 lo, hi, whole ? " (a whole number)" : ""));
  return v;
}

std::string str(const std::map<std::string, std::string>& kv, const std::string& key, const std::string& fallback) {
  const auto it = kv.find(key);
  return it == kv.end() ? fallback : it->second;
}

// Refuses `key` when given: it does not apply to this specimen (`why`), and ignoring it would
// render something else than asked.
void refuse(const std::map<std::string, std::string>& kv, const std::string& key, const std::string& why) {
  if (kv.count(key))
    throw InputError(fmt::format("specimen key '{}' {}; drop it", key, why));
}

// Dots a pattern of centre spacing `spacing` would place in `area`; refused above kMaxDots before
// anything is allocated, with the estimate in the message.
constexpr double kMaxDots = 1e6;
void check_dot_estimate(const PatternArea& area, double spacing) {
  const double w = std::max(0.0, area.x1 - area.x0), h = std::max(0.0, area.y1 - area.y0);
  const double est = (w / spacing + 1) * (h / spacing + 1);
  if (!(est <= kMaxDots))
    throw InputError(fmt::format("the specimen would hold about {:.3g} dots (spacing {:.3g} px over {:.0f}x{:.0f} px), "
                                 "more than the {:.0f} dtflop renders; make the dots larger or the image smaller",
                                 est, spacing, w, h, kMaxDots));
}

}  // namespace

Specimen parse_specimen(const std::string& text) {
  const auto colon = text.find(':');
  const std::string kind = text.substr(0, colon);
  std::map<std::string, std::string> kv;
  if (colon != std::string::npos) {
    std::string rest = text.substr(colon + 1);
    std::size_t pos = 0;
    while (pos <= rest.size()) {
      const std::size_t comma = std::min(rest.find(',', pos), rest.size());
      const std::string item = rest.substr(pos, comma - pos);
      if (!item.empty()) {
        const auto eq = item.find('=');
        if (eq == std::string::npos || eq == 0)
          throw InputError(fmt::format("specimen item '{}' is not key=value", item.substr(0, 60)));
        if (!kv.emplace(item.substr(0, eq), item.substr(eq + 1)).second)
          throw InputError(fmt::format("specimen key '{}' is given twice; give it once", item.substr(0, eq)));
      }
      pos = comma + 1;
    }
  }
  static const char* known[] = {"size", "pattern", "pitch", "radius", "gap", "count", "seed", "polarity",
                                "blur", "noise", "lighting", "bits", "ground", "ink", "margin", "dx",
                                "dy", "deg", "strain", "nu", "k", "a", "load", "supersample"};
  for (const auto& entry : kv) {
    const std::string& k = entry.first;  // a plain name: clang 14 captures no structured binding
    if (std::find_if(std::begin(known), std::end(known), [&k](const char* s) { return k == s; }) == std::end(known))
      throw InputError(fmt::format("specimen key '{}' is unknown; known keys: size, pattern, pitch, radius, "
                                   "gap, count, seed, polarity, blur, noise, lighting, bits, ground, ink, "
                                   "margin, supersample, dx, dy, deg, strain, nu, k, a, load",
                                   k.substr(0, 40)));
  }

  Specimen s;
  const Size2 size = parse_size2(str(kv, "size", "1024x768"), "specimen size", 16384);
  s.render.width = static_cast<int>(size.x);
  s.render.height = static_cast<int>(size.y);
  s.render.blur_sigma = num(kv, "blur", 0, 0, 50);
  s.render.noise_sigma = num(kv, "noise", 0, 0, 255);
  s.render.lighting = num(kv, "lighting", 0, -0.99, 0.99);
  s.render.bit_depth = static_cast<int>(num(kv, "bits", 8, 8, 16, true));
  s.render.ground = num(kv, "ground", 200, 0, 255);
  s.render.ink = num(kv, "ink", 40, 0, 255);
  if (std::abs(s.render.ground - s.render.ink) < 10)
    throw InputError(fmt::format("specimen ground={} and ink={} differ by less than 10 grey levels: the dots would "
                                 "not show; set them further apart",
                                 s.render.ground, s.render.ink));
  s.render.supersample = static_cast<int>(num(kv, "supersample", 16, 1, 64, true));
  const auto seed = static_cast<std::uint64_t>(num(kv, "seed", 1, 0, 9007199254740992.0, true));
  s.render.seed = seed;
  const std::string pol = str(kv, "polarity", "dark");
  if (pol == "dark") s.render.polarity = Polarity::dark_dots;
  else if (pol == "light") s.render.polarity = Polarity::light_dots;
  else throw InputError(fmt::format("polarity '{}' is unknown; use dark or light", pol.substr(0, 40)));
  validate(s.render);

  // Each key applies to some kinds only; one given where it does not apply is refused.
  const bool kirsch = kind == "kirsch";
  if (kind != "translation") refuse(kv, "dx", "applies to translation only"), refuse(kv, "dy", "applies to translation only");
  if (kind != "rotation") refuse(kv, "deg", "applies to rotation only");
  if (kind != "uniform" && !kirsch) refuse(kv, "strain", "applies to uniform and kirsch only");
  if (kind != "uniform" && kind != "bending" && !kirsch) refuse(kv, "nu", "applies to uniform, bending and kirsch only");
  if (kind != "bending") refuse(kv, "k", "applies to bending only");
  if (!kirsch) refuse(kv, "a", "applies to kirsch only"), refuse(kv, "load", "applies to kirsch only");

  const Vec2 centre{0.5 * (s.render.width - 1), 0.5 * (s.render.height - 1)};
  const double side = std::min(s.render.width, s.render.height);
  const double nu = num(kv, "nu", 0.3, 0, 0.5);
  const double strain = num(kv, "strain", 1e-3, -0.1, 0.1);
  if (kind == "reference") {
    s.deformation = make_identity();
  } else if (kind == "translation") {
    s.deformation = make_translation(num(kv, "dx", 0.5, -side, side), num(kv, "dy", -0.25, -side, side));
  } else if (kind == "rotation") {
    s.deformation = make_rotation(centre, num(kv, "deg", 0.5, -180, 180) * kPi / 180);
  } else if (kind == "uniform") {
    s.deformation = make_uniform(centre, strain, -nu * strain);
  } else if (kind == "bending") {
    s.deformation = make_bending(centre, num(kv, "k", 2e-6, -1e-3, 1e-3), nu);
  } else if (kind == "kirsch") {
    const double a = num(kv, "a", 0.1 * side, 1, 0.4 * side);
    const std::string load = str(kv, "load", "x");
    if (load != "x" && load != "y") throw InputError(fmt::format("load '{}' must be x or y", load.substr(0, 40)));
    s.deformation = make_kirsch(centre, a, strain, nu, load == "y");
    s.hole = std::make_pair(centre, a);
  } else {
    throw InputError(fmt::format("specimen kind '{}' is unknown; use reference, translation, rotation, "
                                 "uniform, bending or kirsch",
                                 kind.substr(0, 40)));
  }

  const double radius = num(kv, "radius", 6, 1, 0.25 * side);
  const double margin = num(kv, "margin", std::min(4 * radius, 0.25 * side), 0, 0.25 * side);
  PatternArea area{margin, margin, s.render.width - 1 - margin, s.render.height - 1 - margin, {}, 0};
  const std::string pattern = str(kv, "pattern", "grid");
  if (pattern != "random") refuse(kv, "count", "applies to pattern=random only");
  if (pattern != "random" && !kirsch) refuse(kv, "gap", "applies to pattern=random and kirsch only");
  if (pattern == "random") refuse(kv, "pitch", "applies to pattern=grid and graded only");
  const double gap = num(kv, "gap", radius, 0, side);
  if (s.hole) {
    area.keep_out_centre = s.hole->first;
    area.keep_out_radius = s.hole->second + gap;
  }
  if (pattern == "grid") {
    const double pitch = num(kv, "pitch", 4 * radius, 2 * radius, side);
    check_dot_estimate(area, pitch);
    s.dots = grid_pattern(area, pitch, radius);
  } else if (pattern == "random") {
    check_dot_estimate(area, 2 * radius + gap);
    s.dots = random_pattern(area, radius, gap, static_cast<int>(num(kv, "count", 0, 1, kMaxDots, true)), seed);
  } else if (pattern == "graded") {
    const Vec2 focus = s.hole ? s.hole->first : centre;
    const double pitch = num(kv, "pitch", 4 * radius, 2 * radius, side);
    check_dot_estimate(area, pitch);
    s.dots = graded_pattern(area, {focus, pitch, 2 * pitch, radius, 2 * radius, 0.5 * side}, seed);
  } else {
    throw InputError(fmt::format("pattern '{}' is unknown; use grid, random or graded", pattern.substr(0, 40)));
  }
  if (s.dots.empty()) throw InputError("the specimen holds no dot; make the image larger or the dots smaller");
  return s;
}

}  // namespace dtflop::dct
