#include "workloads/dct/support.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "workloads/dct/tracking.hpp"

namespace dtflop::dct {

// results/dct-quality/support.md: `dct_quality support-noise` (the mean of its three patterns
// per row) and `dct_quality kirsch cpu-par 10` (hole radius a = 300 px, L = 2a/7 = 85.7 px,
// amplitude 2 e0 = 4000 microstrain).
const std::vector<SupportNoiseRow>& support_noise_table() {
  static const std::vector<SupportNoiseRow> t = {
      {12, 3.73, 1.7607},  {20, 4.86, 0.6733},  {30, 6.05, 0.4110},  {45, 7.54, 0.2720},
      {60, 8.84, 0.2043},  {90, 11.12, 0.1307}, {120, 13.10, 0.0947}, {150, 14.92, 0.0727},
      {200, 17.70, 0.0520}, {250, 20.34, 0.0403}, {300, 22.90, 0.0330}, {400, 28.48, 0.0243},
  };
  return t;
}

// The rows where smoothing dominates (120 dots and up: the bias grows with the support); below,
// the hole edge's one-sided support and the noise make the bias small and irregular (-1.0% to
// -2.5% from 30 to 90 dots), which the fit leaves out.
const std::vector<SupportBiasRow>& support_bias_table() {
  static const std::vector<SupportBiasRow> t = {
      {206.5 / 85.71, 159.6 / 4000}, {228.8 / 85.71, 313.2 / 4000}, {261.8 / 85.71, 531.0 / 4000},
      {312.5 / 85.71, 778.5 / 4000},
  };
  return t;
}

namespace {

// Log-log interpolation of y(x) through (xs, ys), sorted by x; beyond the ends, the end
// segment's power law.
double loglog(const std::vector<double>& xs, const std::vector<double>& ys, double x) {
  std::size_t i = 1;
  while (i + 1 < xs.size() && x > xs[i]) ++i;
  const double p = std::log(ys[i] / ys[i - 1]) / std::log(xs[i] / xs[i - 1]);
  return ys[i - 1] * std::pow(x / xs[i - 1], p);
}

struct BiasFit {
  double beta = 0, p = 0;
};
BiasFit fit_bias() {
  const auto& t = support_bias_table();
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  const double n = static_cast<double>(t.size());
  for (const auto& r : t) {
    const double x = std::log(r.radius_over_length), y = std::log(r.relative_bias);
    sx += x; sy += y; sxx += x * x; sxy += x * y;
  }
  BiasFit f;
  f.p = (n * sxy - sx * sy) / (n * sxx - sx * sx);
  f.beta = std::exp((sy - f.p * sx) / n);
  return f;
}

}  // namespace

SupportSuggestion support_error(int dots, double displacement_sd_px, double spacing_px, const StrainFeature& feature) {
  const auto& t = support_noise_table();
  std::vector<double> n, k, r;
  for (const auto& row : t) {
    n.push_back(row.dots);
    k.push_back(row.noise_factor);
    r.push_back(row.radius_spacings);
  }
  SupportSuggestion s;
  s.dots = dots;
  const double x = static_cast<double>(dots);
  s.radius_px = loglog(n, r, x) * spacing_px;
  s.noise = loglog(n, k, x) * displacement_sd_px / spacing_px;
  if (feature.length_px > 0 && feature.amplitude > 0) {
    static const BiasFit fit = fit_bias();
    s.bias = feature.amplitude * fit.beta * std::pow(s.radius_px / feature.length_px, fit.p);
  }
  s.total = std::hypot(s.noise, s.bias);
  return s;
}

SupportSuggestion suggest_support(double displacement_sd_px, double spacing_px, int dots_available,
                                  const StrainFeature& feature) {
  if (!(displacement_sd_px > 0) || !std::isfinite(displacement_sd_px) || !(spacing_px > 0) || !std::isfinite(spacing_px))
    throw InputError(fmt::format("a support suggestion needs a finite positive displacement deviation and dot spacing "
                                 "(got {} px and {} px); measure a frame with enough dots for a noise estimate first",
                                 displacement_sd_px, spacing_px));
  if (dots_available < 6)
    throw InputError(fmt::format("a support suggestion needs at least 6 dots (the quadratic basis); {} were found",
                                 dots_available));
  const int top = std::min(dots_available, support_noise_table().back().dots);
  SupportSuggestion best;
  for (int d = 6; d <= top; ++d) {
    const SupportSuggestion s = support_error(d, displacement_sd_px, spacing_px, feature);
    if (best.dots == 0 || s.total < best.total) best = s;
  }
  return best;
}

double displacement_sd(const FrameOutput& out, const FrameUncertainty& u) {
  double var = 0;
  int k = 0;
  for (std::size_t j = 0; j < out.tracked.size() && j < u.reference_dots.size(); ++j) {
    const int d = out.matches.ref_to_def[j];
    if (!out.tracked[j] || d < 0 || static_cast<std::size_t>(d) >= u.frame_dots.size()) continue;
    const CentroidSigma a = u.reference_dots[j], c = u.frame_dots[static_cast<std::size_t>(d)];
    const double v = 0.5 * (a.x * a.x + c.x * c.x + a.y * a.y + c.y * c.y);
    if (!std::isfinite(v)) continue;
    var += v;
    ++k;
  }
  return k ? std::sqrt(var / k) : std::numeric_limits<double>::quiet_NaN();
}

StrainFeature estimate_feature(const std::vector<Vec2>& points, const std::vector<FieldValue<double>>& fields,
                               const std::vector<FieldSigma>& sd, int nx, int ny) {
  StrainFeature best;
  if (nx < 3 || ny < 3 || points.size() != static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny) ||
      fields.size() != points.size() || sd.size() != points.size())
    return best;
  auto ok = [&](int i, int j) {
    const std::size_t m = static_cast<std::size_t>(j) * nx + i;
    return fields[m].status == PointStatus::ok && std::isfinite(sd[m].exx);
  };
  for (int c = 0; c < 3; ++c) {
    auto val = [&](std::size_t m) { return c == 0 ? fields[m].exx : c == 1 ? fields[m].eyy : fields[m].exy; };
    auto dev = [&](std::size_t m) { return c == 0 ? sd[m].exx : c == 1 ? sd[m].eyy : sd[m].exy; };
    std::vector<double> v;
    double sd2 = 0;
    for (std::size_t m = 0; m < fields.size(); ++m)
      if (ok(static_cast<int>(m % nx), static_cast<int>(m / nx))) {
        v.push_back(val(m));
        sd2 += dev(m) * dev(m);
      }
    if (v.size() < 9) continue;
    const double noise = std::sqrt(sd2 / static_cast<double>(v.size()));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    const double median = v[v.size() / 2];
    double amp = 0, grad2 = 0;
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        if (!ok(i, j)) continue;
        const std::size_t m = static_cast<std::size_t>(j) * nx + i;
        // A deviation counts where it stands 5 of the point's own stated deviations clear (the
        // largest of ~1000 noisy values lies ~3.3 out; edge points are noisier than the rest).
        if (std::abs(val(m) - median) > 5 * dev(m)) amp = std::max(amp, std::abs(val(m) - median));
        if (i == 0 || j == 0 || i == nx - 1 || j == ny - 1 || !ok(i - 1, j) || !ok(i + 1, j) || !ok(i, j - 1) ||
            !ok(i, j + 1))
          continue;
        const std::size_t l = m - 1, r = m + 1, d = m - static_cast<std::size_t>(nx), u = m + static_cast<std::size_t>(nx);
        const double hx = points[r].x - points[l].x, hy = points[u].y - points[d].y;
        if (!(hx > 0) || !(hy > 0)) continue;
        const double gx = (val(r) - val(l)) / hx, gy = (val(u) - val(d)) / hy;
        // The differences' own noise, as if the neighbours' errors were independent.
        const double nx2 = (dev(r) * dev(r) + dev(l) * dev(l)) / (hx * hx);
        const double ny2 = (dev(u) * dev(u) + dev(d) * dev(d)) / (hy * hy);
        grad2 = std::max(grad2, gx * gx + gy * gy - nx2 - ny2);
      }
    if (!(amp > 5 * noise) || !(grad2 > 0)) continue;
    const double a = amp, length = a / std::sqrt(grad2);
    if (best.length_px <= 0 || length < best.length_px) best = {a, length};
  }
  return best;
}

FrameSuggestion suggest_for_frame(const Backend& b, const FrameOutput& out, const FrameUncertainty& u, int nx, int ny) {
  FrameSuggestion f;
  // Noiseless images still leave each centroid ~0.001 px off (the pixels' partial coverage,
  // docs/dct.md "Centroids"): below that the stated deviation understates the error, and a
  // suggestion from it would chase features of a few microstrain with tiny supports.
  f.displacement_sd_px = std::max(displacement_sd(out, u), kCentroidFloorPx);
  f.spacing_px = median_spacing(b.reference_positions());
  f.dots = static_cast<int>(b.reference_positions().size());
  if (!std::isfinite(f.displacement_sd_px) || !(f.displacement_sd_px > 0) || !(f.spacing_px > 0) || f.dots < 6) return f;
  f.feature = estimate_feature(b.points(), out.fields, u.points, nx, ny);
  f.suggestion = suggest_support(f.displacement_sd_px, f.spacing_px, f.dots, f.feature);
  return f;
}

}  // namespace dtflop::dct
