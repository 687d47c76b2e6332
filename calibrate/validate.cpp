#include "calibrate/validate.hpp"

#include <cmath>

#include <fmt/format.h>

#include "model/errors.hpp"

namespace dtflop::calib {

double SampleError::rel(Component c) const {
  auto it = per_step.find(c);
  if (it == per_step.end() || !(it->second.second > 0)) return 0;
  return (it->second.first - it->second.second) / it->second.second;
}

Validation validate(const std::vector<Sample>& samples, const MachineProfile& profile, Variant variant) {
  Validation v;
  v.variant = variant;
  for (const auto& s : samples) {
    Prediction p;
    try {
      p = predict(profile, s.counts, variant);
    } catch (const InputError& e) {
      throw InputError(fmt::format("cannot predict sample '{}': {}", s.key, e.what()));
    }
    SampleError row;
    row.sample = &s;
    const double steps = static_cast<double>(s.steps);
    for (const auto& [c, st] : s.components) {
      if (!(st.median > 0)) continue;
      row.per_step[c] = {predicted(p, c) / steps, st.median / steps};
    }
    v.rows.push_back(std::move(row));
  }
  // Accumulate per group.
  std::map<std::string, std::map<Component, std::vector<std::pair<double, const SampleError*>>>> acc;
  for (const auto& row : v.rows) {
    const auto& s = *row.sample;
    for (const auto& [c, pm] : row.per_step) {
      for (const std::string& g : {std::string("all"), s.backend, s.backend + " / " + (s.plan.empty() ? "?" : s.plan)})
        acc[g][c].emplace_back(pm.first - pm.second, &row);
    }
  }
  for (const auto& [g, comps] : acc) {
    for (const auto& [c, errs] : comps) {
      ErrorStats e;
      double worst = -1;
      for (const auto& [diff, row] : errs) {
        const double meas = row->per_step.at(c).second;
        const double rel = diff / meas;
        e.n += 1;
        e.mean_abs += std::abs(diff);
        e.max_abs = std::max(e.max_abs, std::abs(diff));
        e.mean_rel += std::abs(rel);
        e.bias += rel;
        if (std::abs(rel) > worst) {
          worst = std::abs(rel);
          e.worst = row->sample->key;
        }
      }
      e.max_rel = worst;
      e.mean_abs /= e.n;
      e.mean_rel /= e.n;
      e.bias /= e.n;
      v.groups[g][c] = e;
    }
  }
  return v;
}

}  // namespace dtflop::calib
