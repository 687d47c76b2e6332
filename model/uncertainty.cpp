#include "model/uncertainty.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "model/predict.hpp"
#include "model/terms.hpp"

namespace dtflop {

namespace {
constexpr double kZ95 = 1.959963984540054;

double normal_cdf(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

// Does the prediction of `counts` have device terms (a GPU backend's), by the term table?
bool uses_device(const CostCounts& c) {
  for (Phase p : all_phases())
    if (p != Phase::C && p != Phase::net && counts_phase(c, p)) return true;
  return false;
}

double metadata_number(const MachineProfile& p, const char* key) {
  auto it = p.metadata.find(key);
  if (it == p.metadata.end()) return -1;
  char* end = nullptr;
  const double v = std::strtod(it->second.c_str(), &end);
  if (end == it->second.c_str() || !std::isfinite(v) || v < 0) return -1;
  return v;
}
}  // namespace

double normal_quantile(double p) {
  if (!(p > 0 && p < 1)) throw InputError(fmt::format("a probability must lie strictly between 0 and 1, got {}", p));
  // Bisection on the CDF: exact to double precision in 80 halvings of [-40, 40].
  double lo = -40, hi = 40;
  for (int i = 0; i < 80; ++i) {
    const double mid = 0.5 * (lo + hi);
    (normal_cdf(mid) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

BasisError basis_of(const MachineProfile& profile, const CostCounts& counts, Variant variant,
                    const std::optional<BasisError>& probe_only) {
  BasisError b;
  bool fitted = false;
  for (Param id : priced_params(profile, counts, variant))
    if (const Parameter* par = profile.find(id)) fitted = fitted || par->provenance == Provenance::fitted;
  if (!fitted && probe_only) {
    b = *probe_only;
    b.basis = Basis::probe_only;
    return b;
  }
  if (!fitted) {
    b.basis = Basis::probe_only;
    b.sigma = uses_device(counts) ? kProbeOnlySigma.gpu : kProbeOnlySigma.cpu;
    b.source = "measured error of probe-only predictions (docs/PERFORMANCE.md, Prediction portability)";
    return b;
  }
  b.basis = Basis::calibrated;
  if (const double cv = metadata_number(profile, "fit_cv_rms_log"); cv >= 0) {
    ErrorFigure own;  // as a calibration of this fit would carry it (to_calibration)
    own.rms_log = cv;
    own.round_log_sd = std::max(0.0, metadata_number(profile, "fit_round_log_sd"));
    b.sigma = own.sigma();
    b.source = own.round_log_sd > 0 ? "the calibration's cross-validated error on this machine and its drift between "
                                      "the fit's rounds"
                                    : "the calibration's cross-validated error on this machine";
  } else if (const double rms = metadata_number(profile, "fit_rms_relative"); rms >= 0) {
    b.sigma = std::log1p(rms);
    b.source = "the fit's rms residual (the profile records no cross-validated error: refit it with `dtflop "
               "calibrate` for an honest one)";
  } else {
    b.sigma = uses_device(counts) ? kTransferSigma.gpu : kTransferSigma.cpu;
    b.source = "no error recorded with the fitted profile: the figure of a carried calibration";
  }
  return b;
}

BasisError basis_of(const Calibration& c, Basis applied, const std::optional<BasisError>& carried) {
  BasisError b;
  b.basis = applied;
  b.from = hardware_class(c.fitted_on, uses_gpu(c));
  const double own = c.fit_error.sigma();
  if (applied == Basis::calibrated) {
    b.sigma = own;
    b.source = c.fit_error.round_log_sd > 0
                   ? fmt::format("the calibration's own error ({}) and the machine's drift between its fit's rounds",
                                 c.fit_error.how)
                   : fmt::format("the calibration's own error ({})", c.fit_error.how);
    return b;
  }
  if (c.transfer_error) {
    b.sigma = c.transfer_error->rms_log;
    b.source = fmt::format("its error measured when carried to {} ({})", c.transfer_measured_on, c.transfer_error->how);
  } else if (carried) {
    b.sigma = std::hypot(own, carried->sigma);
    b.source = fmt::format("its own error ({}) and the {}", c.fit_error.how, carried->source);
  } else {
    b.sigma = std::hypot(own, uses_gpu(c) ? kTransferSigma.gpu : kTransferSigma.cpu);
    b.source = fmt::format("its own error ({}) and the measured error of carried calibrations "
                           "(docs/PERFORMANCE.md, Prediction portability)",
                           c.fit_error.how);
  }
  return b;
}

double parameter_log_sigma(const MachineProfile& profile, const CostCounts& counts, Variant variant) {
  const double h = 0.01;  // a 1% step in log space
  double var = 0;
  for (Param id : priced_params(profile, counts, variant)) {
    const Parameter* par = profile.find(id);
    if (!par || !(par->value > 0)) continue;
    double s = 0;
    if (par->uncertainty && *par->uncertainty > 0) s = std::log1p(*par->uncertainty / par->value) / kZ95;
    else if (par->spread && *par->spread > 0) s = *par->spread / 1.349;  // an interquartile range
    if (s == 0) continue;
    MachineProfile up = profile, down = profile;
    Parameter pu = *par, pd = *par;
    pu.value = par->value * std::exp(h);
    pd.value = par->value * std::exp(-h);
    up.set(id, pu);
    down.set(id, pd);
    const double tu = predict(up, counts, variant).total, td = predict(down, counts, variant).total;
    if (!(tu > 0 && td > 0)) continue;
    const double elasticity = (std::log(tu) - std::log(td)) / (2 * h);
    var += elasticity * elasticity * s * s;
  }
  return std::sqrt(var);
}

Interval interval_of(const Prediction& p, const MachineProfile& profile, const CostCounts& counts,
                     const BasisError& basis, double level) {
  Interval iv;
  iv.level = level;
  iv.sigma_params = parameter_log_sigma(profile, counts, p.variant);
  iv.sigma_basis = basis.sigma;
  iv.sigma = std::hypot(iv.sigma_params, iv.sigma_basis);
  const double z = normal_quantile(0.5 + level / 2);
  iv.lo = p.total * std::exp(-z * iv.sigma);
  iv.hi = p.total * std::exp(z * iv.sigma);
  return iv;
}

std::string_view to_string(Verdict v) {
  switch (v) {
    case Verdict::met: return "met";
    case Verdict::missed: return "missed";
    case Verdict::uncertain: return "uncertain";
  }
  return "?";
}

DeadlineVerdict judge_deadline(double predicted, const Interval& iv, double deadline, double confidence) {
  DeadlineVerdict d;
  if (!(predicted > 0)) {
    d.probability_met = 1;
  } else if (iv.sigma <= 0) {
    d.probability_met = predicted <= deadline ? 1 : 0;
  } else {
    d.probability_met = normal_cdf((std::log(deadline) - std::log(predicted)) / iv.sigma);
  }
  d.verdict = d.probability_met >= confidence    ? Verdict::met
              : d.probability_met <= 1 - confidence ? Verdict::missed
                                                    : Verdict::uncertain;
  return d;
}

}  // namespace dtflop
