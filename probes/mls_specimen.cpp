#include "probes/mls_specimen.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <utility>

#include <fmt/format.h>

#include "probes/probe.hpp"

namespace dtflop::probes::mls {

Xy displacement(double x, double y) {
  return {1e-3 * x + 4e-4 * y + 2e-7 * x * x - 1e-7 * x * y + 3e-7 * y * y,
          -5e-4 * x + 2e-3 * y + 1e-7 * x * x + 2e-7 * x * y - 1e-7 * y * y};
}
std::array<double, 4> gradient(double x, double y) {
  return {1e-3 + 4e-7 * x - 1e-7 * y, 4e-4 - 1e-7 * x + 6e-7 * y, -5e-4 + 2e-7 * x + 2e-7 * y,
          2e-3 + 2e-7 * x - 2e-7 * y};
}

Specimen make_specimen() {
  Specimen s;
  std::mt19937_64 rng(20261127);
  std::uniform_real_distribution<double> jitter(-kJitter, kJitter);
  for (int j = 0; j < kGrid; ++j)  // raster order, as the labelling numbers a frame's dots
    for (int i = 0; i < kGrid; ++i) {
      const Xy p{(i + 0.5) * kPitch + jitter(rng), (j + 0.5) * kPitch + jitter(rng)};
      s.reference.push_back(p);
      s.disp.push_back(displacement(p.x, p.y));
    }
  s.tracked.assign(s.reference.size(), 1);
  // Points over the middle half, so that every support lies within the dots.
  const double lo = 0.25 * kGrid * kPitch, hi = 0.75 * kGrid * kPitch;
  for (int j = 0; j < kPointsSide; ++j)
    for (int i = 0; i < kPointsSide; ++i)
      s.points.push_back({lo + (hi - lo) * i / (kPointsSide - 1), lo + (hi - lo) * j / (kPointsSide - 1)});
  const int most = *std::max_element(kSupports.begin(), kSupports.end());
  std::vector<std::vector<std::pair<double, std::int32_t>>> nearest(s.points.size());
  std::vector<std::pair<double, std::int32_t>> d(s.reference.size());
  for (std::size_t m = 0; m < s.points.size(); ++m) {
    for (std::size_t k = 0; k < s.reference.size(); ++k) {
      const double dx = s.reference[k].x - s.points[m].x, dy = s.reference[k].y - s.points[m].y;
      d[k] = {dx * dx + dy * dy, static_cast<std::int32_t>(k)};
    }
    std::partial_sort(d.begin(), d.begin() + most + 1, d.end());
    nearest[m].assign(d.begin(), d.begin() + most + 1);
  }
  for (int n : kSupports) {
    Table t;
    t.support = n;
    t.offsets.push_back(0);
    for (const auto& near : nearest) {
      for (int k = 0; k < n; ++k) t.dots.push_back(near[static_cast<std::size_t>(k)].second);
      t.offsets.push_back(static_cast<std::int32_t>(t.dots.size()));
      t.rho.push_back(0.5 * (std::sqrt(near[static_cast<std::size_t>(n) - 1].first) +
                             std::sqrt(near[static_cast<std::size_t>(n)].first)));
      t.geometry.push_back(kernels::PointStatus::ok);
    }
    t.flops = static_cast<double>(kernels::flops_per_support_dot(kernels::Weight::cubic_spline)) *
                  static_cast<double>(t.dots.size()) +
              static_cast<double>(kernels::kFlopsPerPoint) * static_cast<double>(s.points.size());
    s.flops += t.flops;
    s.tables.push_back(std::move(t));
  }
  return s;
}

template <class T>
void check(const Specimen& s, const Table& t, const std::vector<kernels::FieldValue<T>>& out, double du_max,
           double de_max, const char* who) {
  for (std::size_t m = 0; m < s.points.size(); ++m) {
    const kernels::FieldValue<T>& f = out[m];
    const Xy u = displacement(s.points[m].x, s.points[m].y);
    const auto g = gradient(s.points[m].x, s.points[m].y);
    kernels::FieldValue<double> want;
    kernels::strain_from_gradient(g[0], g[1], g[2], g[3], want);
    const double du = std::max(std::abs(f.ux - u.x), std::abs(f.uy - u.y));
    const double de = std::max({std::abs(f.exx - want.exx), std::abs(f.eyy - want.eyy), std::abs(f.exy - want.exy)});
    if (f.status != kernels::PointStatus::ok || f.support != t.support || !(du <= du_max) || !(de <= de_max))
      throw ValidationError(fmt::format(
          "the {} MLS field at point {} of the {}-dot supports is off: status {}, {} of {} dots, displacement {:.3g} px "
          "and strain {:.3g} from the quadratic field's (allowed {:.3g} px, {:.3g})",
          who, m, t.support, static_cast<int>(f.status), f.support, t.support, du, de, du_max, de_max));
  }
}

template void check<double>(const Specimen&, const Table&, const std::vector<kernels::FieldValue<double>>&, double,
                            double, const char*);
template void check<float>(const Specimen&, const Table&, const std::vector<kernels::FieldValue<float>>&, double,
                           double, const char*);

}  // namespace dtflop::probes::mls
