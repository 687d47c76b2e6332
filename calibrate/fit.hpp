// Fitting the DTFLOP model's parameters to measured samples (Ceres), with 95% intervals from
// ceres::Covariance, and choosing a model variant by k-fold cross-validation.
//
// The fit minimizes, over the parameters the samples' counts exercise, the sum of a robust
// loss of relative residuals (predicted - measured) / measured: one residual per sample for
// the total and one for each measured component the sample's counts exercise (CG, GC, G, C).
// Parameters are estimated in log space, theta = log(value / start), so they stay positive and
// the problem is scaled. Predictions come from model/predict.hpp itself: what is fitted is
// exactly what `dtflop predict` computes.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "calibrate/sample.hpp"
#include "model/calibration.hpp"
#include "model/predict.hpp"
#include "model/profile.hpp"

namespace dtflop::calib {

enum class Loss { none, huber, cauchy };
std::string_view to_string(Loss l);

struct FitOptions {
  Variant variant = Variant::extended;
  Loss loss = Loss::huber;
  double loss_scale = 0.05;      // relative residual where the robust loss starts to bend
  // Measured components that give residuals besides the total (only where a sample has them
  // and its counts exercise them).
  std::vector<Component> components = {Component::CG, Component::GC, Component::G, Component::C};
  int max_iterations = 200;
  double flag_ratio = 1.5;       // fitted / probed outside [1/r, r] is flagged
  // The extended variant's max() terms have kinks: started from probed peaks, a term that
  // never wins has no gradient and could never be fitted. So extended starts from the latency
  // variant's fit to the same samples (the start profile stays the reference for the flags).
  bool warm_start = true;
  // A prior on every probed parameter: log(fitted / probed) is taken as normal with this standard
  // deviation, weighed against the samples' own scatter (the rms relative residual of the fit
  // without it). Where the samples cannot tell two parameters apart (two steps that come in a
  // fixed ratio in every configuration) or barely feel one, it stays near what the probe measured
  // instead of absorbing the other's time or running to a bound; where the samples do determine a
  // parameter, they outweigh it. Parameters without a probed value get none. 0: no prior.
  double prior_log_sigma = 0;
};

struct FittedParameter {
  Param id{};
  bool fitted = false;           // false: kept at its start value (not identifiable, or kept_at_probe)
  bool kept_at_probe = false;    // exercised, but kept at the probe by rule (kept_at_probe() in fit.cpp)
  double value = 0;              // fitted value (or the kept one)
  std::optional<double> probed;  // the start profile's value, when it had one
  bool has_interval = false;
  double lo95 = 0, hi95 = 0;     // 95% interval (fitted and covariance available)
  double log_sigma = 0;          // standard deviation of log(value)
  bool flagged = false;          // fitted and probed disagree by more than flag_ratio
  // The physical range the fit kept it in (physical_bounds()), and whether it ended on an end of
  // it: then the value says less about the machine than about the counts (a bandwidth above
  // any the probes saw means the counts overstate the traffic that bounds the backend).
  double lo_bound = 0, hi_bound = 0;
  bool at_physical_bound = false;
  std::string bound_reason;      // why the range is what it is
  std::string note;
};

// The range a fitted parameter must stay in, from the start profile (the probes) where it has a
// value of the parameter, else from what the parameter is (docs/calibration.md, "Bounds"):
//   bandwidths and rates: at most kBoundAbove x the probed value (no path is faster than the
//     fastest the probes saw; the margin covers probe noise and clock boost), at least 1e-4 x;
//   latencies: 0.02x .. 100x the probed value (a launch in a stream of launches costs less
//     than the probe's lone one);
//   unprobed: a cost ratio (K_CW, K_GR) 0.1 .. 100; a latency 0.1 ns .. 10 ms; a size 1 B .. 1 GiB;
//     a bandwidth or rate a million-fold either side of its start.
struct Bound {
  double lo = 0, hi = 0;
  std::string reason;
};
inline constexpr double kBoundAbove = 1.25;
Bound physical_bounds(Param p, const MachineProfile& start, double start_value);

struct FitResult {
  Variant variant = Variant::extended;
  int samples = 0;
  int residuals = 0;
  int free_parameters = 0;
  std::vector<FittedParameter> params;  // every parameter the samples' counts exercise
  std::string termination;              // Ceres' one-line report
  double prior_log_sigma = 0;           // the prior the fit was solved with: FitOptions', or where a fit
                                        // without one did not converge, the fallback's (fit.cpp); 0: none
  int iterations = 0;
  double rms_relative = 0;              // sqrt(mean squared relative residual), no loss applied
  int at_physical_bounds = 0;           // parameters that ended on an end of their physical range
  bool covariance_ok = false;
  std::string covariance_note;
  MachineProfile profile;               // the start profile with the fitted values written in
};

// A fit without a prior that does not converge within its iterations is solved again with the
// probes as a prior (sigma 0.5; FitResult::prior_log_sigma and its termination say so).
// Throws InputError for: no samples; fewer samples than free parameters; a solve that fails or
// does not converge; a sample whose counts need a parameter with no start value (neither in
// the start profile nor guessable).
FitResult fit(const std::vector<Sample>& samples, const MachineProfile& start, const FitOptions& options);

struct CvResult {
  Variant variant = Variant::extended;
  int folds = 0;
  int held_out = 0;                 // predictions scored
  double mean_rel = 0;              // mean |relative error| of the total over held-out samples
  double max_rel = 0;
  double se = 0;                    // standard error of the per-fold means
  double rms_log = 0;               // root mean square of log(predicted / measured) over held-out samples
  std::vector<double> fold_means;
  int failed_folds = 0;             // folds whose fit failed (then the variant is not eligible)
  std::string failure;              // the first failure's message
};

// k-fold cross-validation of each variant: samples are shuffled (deterministically, `seed`)
// into k folds; each fold is predicted by a fit to the others. Needs k >= 2 and at least k
// samples.
std::vector<CvResult> cross_validate(const std::vector<Sample>& samples, const MachineProfile& start,
                                     const FitOptions& base, const std::vector<Variant>& variants,
                                     int k, std::uint64_t seed);

// The sweep plans the samples come from, in order of first appearance.
std::vector<std::string> plans_of(const std::vector<Sample>& samples);
// Leave one plan out: each plan's samples predicted by a fit of `options.variant` to the other plans'.
// Random k-fold folds share every plan, so they measure interpolation among configurations like the
// training ones; this measures how far a fit carries to a kind of configuration it was not fitted to,
// which is what a held-out set of other configurations asks of it. Needs samples of >= 2 plans.
CvResult cross_validate_by_plan(const std::vector<Sample>& samples, const MachineProfile& start,
                                const FitOptions& options);

struct VariantChoice {
  Variant chosen = Variant::extended;
  std::string reason;  // one paragraph: the CV errors and the rule applied
};
// The simplest variant (seed < latency < extended) whose cross-validated mean error lies within
// one standard error of the best one's (the one-standard-error rule). Throws InputError when no
// variant could be cross-validated.
VariantChoice choose_variant(const std::vector<CvResult>& cv);

// The fit as a backend calibration (model/calibration.hpp): each parameter the fit determined as a
// factor of the start profile's value of it where the start profile has one (a probe measured
// it), else as its value; parameters it could not determine are kept at the probe (factor 1).
// `error` is the chosen variant's cross-validated error; `workload`, `backend` and `match` name
// what the samples were.
Calibration to_calibration(const FitResult& r, const std::string& workload, const std::string& backend,
                           const std::vector<std::string>& match, const ErrorFigure& error);
// The cross-validated error of `cv` as an ErrorFigure.
ErrorFigure error_figure(const CvResult& cv, int samples);
// The same of a leave-one-plan-out result (cross_validate_by_plan).
ErrorFigure plan_error_figure(const CvResult& cv, int samples);

}  // namespace dtflop::calib
