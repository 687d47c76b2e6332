// RBE accuracy (the search-and-rescue scenario of the dissertation's Test 4, eq. 5.23 and Table
// 5.5): the grid covers the search area, so its size sets the cell; a configuration is accurate
// enough when
//   kernel-mass:  its motion kernel holds at least `kernel-mass` of the probability of the
//                 target's one-step displacement (speed and heading Gaussian, time step dt):
//                 mass outside the kernel is lost from the belief every step;
//   resolution:   its cell resolves the sensor's likelihood: at least `cells-per-sigma` cells
//                 per standard deviation of the sharpest likelihood the sensor gives.
//   separable:    a separable prediction (two 1D passes; cuda-resident, `prediction: separable`,
//                 and `auto` on the workload's synthetic kernel, which is separable) is exact only
//                 for a motion whose x and y displacements are independent: the target's
//                 velocity given as independent x and y Gaussians (`target-velocity`); a speed
//                 and heading (`target-speed`, `target-heading`, eq. 5.23) need the full 2D
//                 convolution (4.10).
// The figure of merit is the cell size in metres (the larger side).
#include <cmath>
#include <map>
#include <set>
#include <tuple>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "tune/accuracy.hpp"

namespace dtflop::tune {

namespace {

struct RbeNeeds {
  double area_x = 0, area_y = 0;   // km
  double dt = 0;                   // s
  double v_mean = 0.1, v_sd = 0.02;       // km/s (Table 5.5)
  double h_mean = 0, h_sd = 0.7;          // rad (Table 5.5)
  bool cartesian = false;          // target-velocity: independent x and y velocities
  double vx_mean = 0, vx_sd = 0, vy_mean = 0, vy_sd = 0;  // km/s
  double mass = 0.997;
  double sigma = 0;                // km
  double cells_per_sigma = 2;
};

double number(const nlohmann::json& j, const char* field, double lo, double hi, const char* expected) {
  if (!j.contains(field)) accuracy_field_error(field, fmt::format("missing; expected {}", expected));
  const auto& v = j[field];
  if (!v.is_number() || !(v.get<double>() >= lo && v.get<double>() <= hi))
    accuracy_field_error(field, fmt::format("{} is not {} in [{}, {}]", v.dump(), expected, lo, hi));
  return v.get<double>();
}

std::pair<double, double> pair(const nlohmann::json& j, const char* field, double lo0, double hi0, double lo1,
                               double hi1, const char* expected) {
  if (!j.contains(field)) accuracy_field_error(field, fmt::format("missing; expected {}", expected));
  const auto& v = j[field];
  if (!v.is_array() || v.size() != 2 || !v[0].is_number() || !v[1].is_number() ||
      !(v[0].get<double>() >= lo0 && v[0].get<double>() <= hi0) ||
      !(v[1].get<double>() >= lo1 && v[1].get<double>() <= hi1))
    accuracy_field_error(field, fmt::format("{} is not {}", v.dump(), expected));
  return {v[0].get<double>(), v[1].get<double>()};
}

class RbeAccuracy final : public AccuracyModel {
 public:
  explicit RbeAccuracy(const nlohmann::json& j) {
    static const std::set<std::string> known = {"area",         "time-step",        "target-speed", "target-heading", "target-velocity",
                                                "kernel-mass",  "likelihood-sigma", "cells-per-sigma"};
    for (const auto& [k, _] : j.items())
      if (!known.count(k))
        accuracy_field_error(k, "unknown field (expected area, time-step, target-speed, target-heading, target-velocity, kernel-mass, "
                "likelihood-sigma, cells-per-sigma)");
    std::tie(n_.area_x, n_.area_y) = pair(j, "area", 1e-3, 1e5, 1e-3, 1e5, "[x, y] in km, each in [0.001, 1e5]");
    n_.dt = number(j, "time-step", 1e-6, 1e6, "the time step in seconds");
    if (j.contains("target-speed"))
      std::tie(n_.v_mean, n_.v_sd) =
          pair(j, "target-speed", 0, 1e3, 0, 1e3, "[mean, standard deviation] in km/s, each in [0, 1000]");
    if (j.contains("target-heading"))
      std::tie(n_.h_mean, n_.h_sd) =
          pair(j, "target-heading", -10, 10, 0, 10, "[mean, standard deviation] in rad, mean in [-10, 10], sd in [0, 10]");
    if (j.contains("target-velocity")) {
      if (j.contains("target-speed") || j.contains("target-heading"))
        accuracy_field_error("target-velocity", "give either target-velocity (x and y) or target-speed and target-heading, not both");
      const auto& v = j["target-velocity"];
      if (!v.is_object() || !v.contains("x") || !v.contains("y") || v.size() != 2)
        accuracy_field_error("target-velocity", "expected {x: [mean, sd], y: [mean, sd]} in km/s");
      n_.cartesian = true;
      const char* what = "[mean, standard deviation] in km/s, mean in [-1000, 1000], sd in [0, 1000]";
      std::tie(n_.vx_mean, n_.vx_sd) = pair(v, "x", -1e3, 1e3, 0, 1e3, what);
      std::tie(n_.vy_mean, n_.vy_sd) = pair(v, "y", -1e3, 1e3, 0, 1e3, what);
    } else if (!(n_.v_mean > 0 || n_.v_sd > 0)) {
      accuracy_field_error("target-speed", "mean and spread are both 0: the target does not move");
    }
    if (j.contains("kernel-mass")) n_.mass = number(j, "kernel-mass", 0.5, 0.999999, "a probability");
    n_.sigma = number(j, "likelihood-sigma", 1e-9, 1e5, "the sharpest likelihood's standard deviation in km");
    if (j.contains("cells-per-sigma")) n_.cells_per_sigma = number(j, "cells-per-sigma", 0.1, 100, "a number");
  }
  std::string error_name() const override { return "cell size"; }
  std::string error_unit() const override { return "m"; }
  nlohmann::json needs() const override {
    nlohmann::json j = {{"area_km", {n_.area_x, n_.area_y}},
                        {"time_step_s", n_.dt},
                        {"kernel_mass", n_.mass},
                        {"likelihood_sigma_km", n_.sigma},
                        {"cells_per_sigma", n_.cells_per_sigma},
                        {"separable_motion", n_.cartesian}};
    if (n_.cartesian) {
      j["target_velocity_kmps"] = {{"x", {n_.vx_mean, n_.vx_sd}}, {"y", {n_.vy_mean, n_.vy_sd}}};
    } else {
      j["target_speed_kmps"] = {n_.v_mean, n_.v_sd};
      j["target_heading_rad"] = {n_.h_mean, n_.h_sd};
    }
    return j;
  }
  AccuracyJudgement judge(const workload::Backend& b, const workload::Config& c) override {
    const auto [nx, ny] = workload::get_size2(c, "grid");
    const auto [ix, iy] = workload::get_size2(c, "kernel");
    const double cx = n_.area_x / static_cast<double>(nx), cy = n_.area_y / static_cast<double>(ny);
    const auto key = std::tuple{ix, iy, nx, ny};
    auto it = mass_.find(key);
    if (it == mass_.end())
      it = mass_.emplace(key, n_.cartesian ? kernel_mass_cartesian(ix, iy, cx, cy, n_.dt, n_.vx_mean, n_.vx_sd,
                                                                   n_.vy_mean, n_.vy_sd)
                                           : kernel_mass(ix, iy, cx, cy, n_.dt, n_.v_mean, n_.v_sd, n_.h_mean, n_.h_sd))
               .first;
    const double mass = it->second, cell = std::max(cx, cy), cells = n_.sigma / cell;
    AccuracyJudgement a;
    a.error = cell * 1000;
    a.figures = {{"cell_m", {cx * 1000, cy * 1000}}, {"kernel_mass", mass}, {"cells_per_sigma", cells}};
    // Separable: cuda-resident always; the others by `prediction` (auto: the synthetic kernel is separable).
    const bool separable = !workload::has(c, "prediction") || workload::get_text(c, "prediction") != "full";
    if (separable && !n_.cartesian) {
      a.ok = false;
      a.constraint = "separable";
      a.reason = fmt::format("{} predicts by two 1D passes, exact only for independent x and y motion; the target's "
                             "speed and heading motion needs the full 2D convolution",
                             b.name());
    } else if (mass < n_.mass) {
      a.ok = false;
      a.constraint = "kernel-mass";
      a.reason = fmt::format("kernel {}x{} of {:.1f} m cells holds {:.4f} of a step's motion, under {}", ix, iy,
                             cx * 1000, mass, n_.mass);
    } else if (cells < n_.cells_per_sigma) {
      a.ok = false;
      a.constraint = "resolution";
      a.reason = fmt::format("{:.1f} m cells give {:.2f} cells per likelihood sigma ({} m), under {}", cell * 1000,
                             cells, n_.sigma * 1000, n_.cells_per_sigma);
    }
    return a;
  }

 private:
  RbeNeeds n_;
  std::map<std::tuple<std::int64_t, std::int64_t, std::int64_t, std::int64_t>, double> mass_;
};

}  // namespace

std::unique_ptr<AccuracyModel> make_rbe_accuracy(const nlohmann::json& needs) {
  return std::make_unique<RbeAccuracy>(needs);
}

}  // namespace dtflop::tune
