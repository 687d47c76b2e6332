#include "probes/centroid_specimen.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>

#include <fmt/format.h>

#include "kernels/dot_centroid.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes::centroid {

namespace {

// A flat background at a whole level: a sloped one rounds to 8 bits in steps that correlate with
// the position and moved the centroids by up to 0.016 px.
constexpr double kBackground = 40, kAmplitude = 160;
constexpr int kSamples = 16;  // a pixel's samples a side, where the dot's edge crosses it

// The dot's share of pixel (x, y): 1 or 0 where the pixel lies wholly inside or outside the circle
// of radius `r` about (cx, cy), else the fraction of its 16 x 16 samples within it.
double coverage(int x, int y, double cx, double cy, double r) {
  const double d = std::hypot(x - cx, y - cy);
  if (d + std::numbers::sqrt2 / 2 <= r) return 1;
  if (d - std::numbers::sqrt2 / 2 >= r) return 0;
  int in = 0;
  for (int j = 0; j < kSamples; ++j)
    for (int i = 0; i < kSamples; ++i) {
      const double dx = x - 0.5 + (i + 0.5) / kSamples - cx, dy = y - 0.5 + (j + 0.5) / kSamples - cy;
      in += dx * dx + dy * dy <= r * r;
    }
  return static_cast<double>(in) / (kSamples * kSamples);
}

}  // namespace

Specimen make_specimen(double radius, int dots, std::uint64_t seed) {
  if (!(radius >= 3 && radius <= 40) || dots < 1 || dots > 20000)
    throw std::invalid_argument(fmt::format("centroid specimen: radius {} px and {} dots; use 3..40 px and 1..20000",
                                            radius, dots));
  Specimen s;
  s.radius = radius;
  const int grow = kMargin + kernels::kRingWidth;
  const int pitch = static_cast<int>(std::ceil(3 * radius)) + 1;        // centres >= 3 r apart, with the jitter
  const int edge = static_cast<int>(std::ceil(radius)) + grow + 2;      // windows inside the image
  const int cols = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(dots))));
  const int rows = (dots + cols - 1) / cols;
  gpu::CentroidFrame& f = s.frame;
  f.width = 2 * edge + (cols - 1) * pitch + 1;
  f.height = 2 * edge + (rows - 1) * pitch + 1;
  const auto pixels = static_cast<std::size_t>(f.width) * static_cast<std::size_t>(f.height);
  f.labels.assign(pixels, -1);
  std::vector<double> level(pixels, kBackground);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> jitter(-0.5, 0.5);
  const int reach = static_cast<int>(std::ceil(radius)) + 1;
  for (int k = 0; k < dots; ++k) {
    const double cx = edge + (k % cols) * pitch + jitter(rng), cy = edge + (k / cols) * pitch + jitter(rng);
    s.centres.insert(s.centres.end(), {cx, cy});
    int x0 = f.width, y0 = f.height, x1 = -1, y1 = -1;
    for (int y = static_cast<int>(cy) - reach; y <= static_cast<int>(cy) + reach; ++y)
      for (int x = static_cast<int>(cx) - reach; x <= static_cast<int>(cx) + reach; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * f.width + x;
        level[i] += kAmplitude * coverage(x, y, cx, cy, radius);
        if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= radius * radius) {
          f.labels[i] = k;
          x0 = std::min(x0, x); y0 = std::min(y0, y); x1 = std::max(x1, x); y1 = std::max(y1, y);
        }
      }
    x0 = std::max(x0 - grow, 0);
    y0 = std::max(y0 - grow, 0);
    x1 = std::min(x1 + grow, f.width - 1);
    y1 = std::min(y1 + grow, f.height - 1);
    f.windows.insert(f.windows.end(), {x0, y0, x1 - x0 + 1, y1 - y0 + 1});
    f.component.push_back(k);
    s.window_pixels += static_cast<std::int64_t>(x1 - x0 + 1) * (y1 - y0 + 1);
  }
  f.image.resize(pixels);
  for (std::size_t i = 0; i < pixels; ++i)
    f.image[i] = static_cast<std::uint8_t>(std::lround(std::min(level[i], 255.0)));

  // The host's centroids: the device's arithmetic in float64.
  for (int k = 0; k < dots; ++k) {
    const int* q = &f.windows[4 * static_cast<std::size_t>(k)];
    auto label = [&](int x, int y) {
      if (x < 0 || y < 0 || x >= f.width || y >= f.height) return -1;
      return f.labels[static_cast<std::size_t>(y) * f.width + x];
    };
    const double cx = q[0] + 0.5 * (q[2] - 1), cy = q[1] + 0.5 * (q[3] - 1);
    auto value = [&](int x, int y) { return static_cast<double>(f.image[static_cast<std::size_t>(y) * f.width + x]); };
    kernels::RingSums<double> ring;
    for (int y = q[1]; y < q[1] + q[3]; ++y)
      for (int x = q[0]; x < q[0] + q[2]; ++x)
        if (kernels::classify_pixel(label, x, y, k, kMargin) == kernels::kRing) ring.add(x - cx, y - cy, value(x, y));
    double a = 0, b = 0, c = 0;
    kernels::solve_plane(ring, a, b, c);
    kernels::WeightSums<double> ws;
    for (int y = q[1]; y < q[1] + q[3]; ++y)
      for (int x = q[0]; x < q[0] + q[2]; ++x)
        if (kernels::classify_pixel(label, x, y, k, kMargin) == kernels::kWeighted)
          ws.add(x - cx, y - cy, value(x, y), a, b, c, false);
    s.host.insert(s.host.end(), {cx + ws.wx / ws.w, cy + ws.wy / ws.w});
  }
  return s;
}

void check(const Specimen& s, const std::vector<double>& got, double tol, const char* who) {
  if (got.size() != s.host.size())
    throw ValidationError(
        fmt::format("the {} centroids are {} numbers for {} dots", who, got.size(), s.host.size() / 2));
  for (std::size_t k = 0; 2 * k < got.size(); ++k) {
    const double d = std::hypot(got[2 * k] - s.host[2 * k], got[2 * k + 1] - s.host[2 * k + 1]);
    if (!(d <= tol))
      throw ValidationError(fmt::format("the {} centroid of dot {} (radius {} px) is ({:.4f}, {:.4f}), the host's "
                                        "float64 one ({:.4f}, {:.4f}): {:.3g} px apart, more than {:.3g}",
                                        who, k, s.radius, got[2 * k], got[2 * k + 1], s.host[2 * k], s.host[2 * k + 1],
                                        d, tol));
  }
}

}  // namespace dtflop::probes::centroid
