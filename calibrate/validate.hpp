// Predicted against measured on samples not used in a fit: per component and total, the mean
// and maximum absolute error (per step, like the seed's Tables 5.2-5.3) and relative error.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "calibrate/sample.hpp"
#include "model/predict.hpp"
#include "model/profile.hpp"

namespace dtflop::calib {

struct ErrorStats {
  int n = 0;
  double mean_abs = 0;   // mean |predicted - measured| per step [s]
  double max_abs = 0;
  double mean_rel = 0;   // mean |predicted - measured| / measured
  double max_rel = 0;
  double bias = 0;       // mean signed (predicted - measured) / measured
  std::string worst;     // key of the sample with the largest relative error
};

struct SampleError {
  const Sample* sample = nullptr;
  std::map<Component, std::pair<double, double>> per_step;  // component -> (predicted, measured) per step
  double rel(Component c) const;                            // signed relative error
};

struct Validation {
  Variant variant = Variant::extended;
  std::vector<SampleError> rows;
  // group ("all", a backend, a backend/plan) -> component -> statistics
  std::map<std::string, std::map<Component, ErrorStats>> groups;
};

// Throws InputError when a sample's counts need a parameter the profile lacks (naming it).
Validation validate(const std::vector<Sample>& samples, const MachineProfile& profile, Variant variant);

}  // namespace dtflop::calib
