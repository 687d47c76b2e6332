// How sure a prediction is: an interval from the parameters' uncertainties and the measured
// error of the way the parameters were obtained (the prediction's basis), and the deadline
// verdict judged against that interval (docs/portability.md).
//
// The predicted time T is taken as log-normal around the model's value: log T has a standard
// deviation sigma = sqrt(sigma_params^2 + sigma_basis^2), where
//   sigma_params = sqrt(sum_i (d log T / d log p_i)^2 s_i^2) over the parameters p_i the
//                  prediction uses, s_i the standard deviation of log p_i (a fitted parameter's
//                  95% interval, a probed one's spread), elasticities by central differences;
//   sigma_basis  = the root mean square of log(predicted / measured) of predictions made the
//                  same way on runs they were not fitted to (ErrorFigure::rms_log); for a
//                  calibrated prediction with it, in quadrature, the machine's drift between the
//                  fit's rounds (ErrorFigure::round_log_sd, metadata fit_round_log_sd).
#pragma once

#include <optional>
#include <string>

#include "model/calibration.hpp"
#include "model/cost_counts.hpp"
#include "model/predict.hpp"
#include "model/profile.hpp"

namespace dtflop {

// The error a prediction's basis carries, and where that figure comes from.
struct BasisError {
  Basis basis = Basis::probe_only;
  double sigma = 0;       // of log T
  std::string source;     // one line: which measurement gave sigma
  std::string from;       // transferred: the machine the calibration was fitted on
};

// The measured error of the ways of predicting that carry no error figure of their own: the
// largest root mean square of log(predicted / measured) over the held-out sets docs/PERFORMANCE.md
// records ("Prediction portability"; results/portability/), per kind of backend, since GPU and
// CPU backends are predicted from their probes with very different success. The intervals built
// on them are wide because such predictions are: that is the point of stating them.
struct BasisSigma {
  double gpu;  // predictions with device terms (a GPU backend)
  double cpu;  // CPU backends
};
// Probe-only predictions: no calibration of the workload anywhere. GPU: 0.78 .. 1.66 measured
// (the seed variant: the probes then gave no K_GR, B_GS, L_atomic); CPU: cpu-seq 2.12 (2-vCPU VM) and
// 2.72 (the H100 machine's 16-thread host): its taps do not run at the probed FMA rate.
inline constexpr BasisSigma kProbeOnlySigma = {1.7, 2.8};
// A calibration carried to another machine whose own transfer error was never measured (added in
// quadrature to the calibration's own cross-validated error). GPU: H100 <-> H200, 0.026 .. 0.125;
// CPU: the VM's AMD EPYC fits carried to an Intel Xeon host, 0.87 (cpu-seq) and 1.29 (cpu-par).
inline constexpr BasisSigma kTransferSigma = {0.13, 1.3};

// The basis of a prediction of `counts` with `variant` from a profile alone: `calibrated` when a
// parameter the prediction uses was fitted (the profile's cross-validated error, metadata
// fit_cv_rms_log, or failing that its fit's rms residual), else `probe_only`.
// `probe_only`: the backend's own measured error of probe-only predictions, where it declares one
// (workload::Backend::probe_only_error); else kProbeOnlySigma stands for it.
BasisError basis_of(const MachineProfile& profile, const CostCounts& counts, Variant variant,
                    const std::optional<BasisError>& probe_only = std::nullopt);
// The basis of a prediction from `c` applied as `applied` (apply_calibration's basis). Carried to
// another machine: the error measured for this very calibration there (`dtflop validate
// --record-error`), else its own error and `carried`, the measured error of its backend's
// calibrations carried between machines (workload::Backend::transfer_error), added in quadrature;
// without that, kTransferSigma.
BasisError basis_of(const Calibration& c, Basis applied, const std::optional<BasisError>& carried = std::nullopt);

// Standard deviation of log(total) from the uncertainties of the parameters the prediction uses.
double parameter_log_sigma(const MachineProfile& profile, const CostCounts& counts, Variant variant);

struct Interval {
  double level = 0.90;
  double lo = 0, hi = 0;      // [s]
  double sigma_params = 0, sigma_basis = 0, sigma = 0;  // of log T
};
// The central `level` interval of the total of `p` (= predict(profile, counts, variant)).
Interval interval_of(const Prediction& p, const MachineProfile& profile, const CostCounts& counts,
                     const BasisError& basis, double level = 0.90);

enum class Verdict { met, missed, uncertain };
std::string_view to_string(Verdict v);
struct DeadlineVerdict {
  Verdict verdict = Verdict::uncertain;
  double probability_met = 0;  // P(T <= deadline) under the interval's distribution
};
// Met when P(T <= deadline) >= confidence, missed when it is <= 1 - confidence, uncertain between.
DeadlineVerdict judge_deadline(double predicted, const Interval& interval, double deadline, double confidence = 0.95);

// The standard normal quantile of p, 0 < p < 1.
double normal_quantile(double p);

}  // namespace dtflop
