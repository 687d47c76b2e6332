#include "tune/accuracy.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <fmt/format.h>

#include "model/errors.hpp"

namespace dtflop::tune {

namespace {

// A workload without an accuracy model: every configuration is as accurate as any other.
class NoAccuracy final : public AccuracyModel {
 public:
  std::string error_name() const override { return "none"; }
  std::string error_unit() const override { return ""; }
  AccuracyJudgement judge(const workload::Backend&, const workload::Config&) override { return {}; }
  nlohmann::json needs() const override { return nlohmann::json::object(); }
};

struct Entry {
  std::string_view workload;
  std::unique_ptr<AccuracyModel> (*make)(const nlohmann::json&);
};
// The one list of accuracy models.
constexpr Entry kModels[] = {
    {"rbe", make_rbe_accuracy},
    {"dct", make_dct_accuracy},
};

// Midpoints of n equal cells over mean +- 7 sd and their normal weights (one node when sd is 0).
std::vector<std::pair<double, double>> normal_nodes(double mean, double sd, int n) {
  if (sd == 0) return {{mean, 1.0}};
  std::vector<std::pair<double, double>> out;
  const double lo = mean - 7 * sd, h = 14 * sd / n;
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    const double x = lo + (i + 0.5) * h, z = (x - mean) / sd;
    out.emplace_back(x, std::exp(-0.5 * z * z));
    sum += out.back().second;
  }
  for (auto& p : out) p.second /= sum;
  return out;
}

}  // namespace

void accuracy_field_error(const std::string& field, const std::string& what) {
  throw InputError(fmt::format("scenario: accuracy.{}: {}", field, what));
}

std::unique_ptr<AccuracyModel> make_accuracy_model(std::string_view workload, const nlohmann::json& needs) {
  if (needs.empty()) return std::make_unique<NoAccuracy>();  // a scenario that needs no accuracy
  for (const Entry& e : kModels)
    if (e.workload == workload) return e.make(needs);
  throw InputError(fmt::format("scenario: accuracy: workload {} has no accuracy model, so the block cannot be "
                                 "judged; remove it",
                                 workload));
}

double kernel_mass(std::int64_t ix, std::int64_t iy, double cell_x, double cell_y, double dt, double v_mean,
                   double v_sd, double h_mean, double h_sd) {
  // Offsets -(I-1)/2 .. I-1-(I-1)/2 cells, each covering half a cell either side of it.
  const auto range = [](std::int64_t i, double cell) {
    const double c = static_cast<double>((i - 1) / 2);
    return std::pair{(-c - 0.5) * cell, (static_cast<double>(i - 1) - c + 0.5) * cell};
  };
  const auto [x_lo, x_hi] = range(ix, cell_x);
  const auto [y_lo, y_hi] = range(iy, cell_y);
  const auto speeds = normal_nodes(v_mean, v_sd, 600);
  const auto headings = normal_nodes(h_mean, h_sd, 1200);
  double mass = 0;
  for (const auto& [h, wh] : headings) {
    const double c = std::cos(h) * dt, s = std::sin(h) * dt;
    for (const auto& [v, wv] : speeds) {
      const double dx = v * c, dy = v * s;
      if (dx >= x_lo && dx < x_hi && dy >= y_lo && dy < y_hi) mass += wh * wv;
    }
  }
  return std::min(1.0, mass);
}

double kernel_mass_cartesian(std::int64_t ix, std::int64_t iy, double cell_x, double cell_y, double dt,
                             double vx_mean, double vx_sd, double vy_mean, double vy_sd) {
  const auto share = [dt](std::int64_t i, double cell, double mean, double sd) {
    const double c = static_cast<double>((i - 1) / 2);
    const double lo = (-c - 0.5) * cell, hi = (static_cast<double>(i - 1) - c + 0.5) * cell;
    const double m = mean * dt, s = sd * dt;
    if (s == 0) return m >= lo && m < hi ? 1.0 : 0.0;
    const auto cdf = [&](double x) { return 0.5 * std::erfc(-(x - m) / (s * std::numbers::sqrt2)); };
    return cdf(hi) - cdf(lo);
  };
  return share(ix, cell_x, vx_mean, vx_sd) * share(iy, cell_y, vy_mean, vy_sd);
}

}  // namespace dtflop::tune
