#include "calibrate/fit.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <numeric>
#include <random>

#include <ceres/ceres.h>
#include <glog/logging.h>
#include <fmt/format.h>

#include "model/errors.hpp"
#include "model/terms.hpp"
#include "model/units.hpp"

namespace dtflop::calib {

std::string_view to_string(Loss l) {
  switch (l) {
    case Loss::none: return "none";
    case Loss::huber: return "huber";
    case Loss::cauchy: return "cauchy";
  }
  return "?";
}

namespace {

constexpr double kZ95 = 1.959963984540054;  // two-sided 95% normal quantile
const double kFallbackPrior = 0.5;      // the prior a fit that did not converge without one is solved with,
const int kFallbackIterations = 50;      // in at least this many iterations
const double kLogBound = std::log(1e6);      // how far from its start a fitted value may go

// Start value for a parameter the start profile lacks: an order of magnitude typical of
// today's machines. Log-space steps make a factor of ten off harmless.
double default_start(Param p) {
  const auto unit = info(p).unit;
  if (p == Param::L_tree) return 30e-9;  // a step of a k-d tree: a few dependent loads
  if (p == Param::L_match) return 10e-9;  // a point binned or a query answered: a few loads
  if (p == Param::L_record) return 5e-9;  // a record tallied, placed or handed on: a few loads
  if (p == Param::L_pixel || p == Param::L_pixel_all || p == Param::L_scan || p == Param::L_scan_all)
    return 1e-9;  // a step of a scalar pixel loop: a few cycles
  if (p == Param::L_hist || p == Param::L_hist_all) return 0.5e-9;  // a histogram's count: a load and an increment
  if (p == Param::L_label || p == Param::L_label_all) return 5e-9;  // a labelled pixel: a threshold, a union-find step
  if (p == Param::V_CS) return 1e9;      // one addition per few cycles
  if (p == Param::V_CM || p == Param::V_CM_all) return 3e9;  // MLS fields: a FLOP a cycle, about
  if (p == Param::V_GM) return 3e8;  // one GPU thread's MLS chain: a FLOP every few cycles
  if (p == Param::L_GP) return 1e-10;  // a window pixel classified, a dot's block beside the others
  if (p == Param::L_GF) return 3e-12;  // a pixel of a whole-frame pass: every multiprocessor's threads at once
  if (p == Param::L_net) return 2e-6;    // a message between processes of one host
  if (p == Param::B_net) return 2e9;
  if (unit == "s") return 10e-6;
  if (info(p).unit == "x") return 1.0;  // a cost ratio: a FLOP costs what any other does
  if (p == Param::S_GC_staged) return 256.0 * 1024;  // the staging chunks of today's drivers
  if (p == Param::S_GC_flat) return 128.0 * 1024;
  if (p == Param::V_G_fp32 || p == Param::V_G_fp64) return 10e12;
  if (p == Param::B_peer || p == Param::B_allreduce) return 100e9;  // GPUs of one host over NVLink
  if (p == Param::B_GG || p == Param::B_GG_copy || p == Param::B_GS || p == Param::B_L2) return 1e12;
  if (p == Param::L_graph) return 1e-6;  // a kernel a graph starts: about a microsecond
  return 10e9;  // host bandwidths and CPU rates
}

}  // namespace

Bound physical_bounds(Param p, const MachineProfile& start, double start_value) {
  const auto unit = info(p).unit;
  const Parameter* probed = start.find(p);
  if (probed && probed->value > 0 && (unit == "B/s" || unit == "FLOP/s"))
    return {1e-4 * probed->value, kBoundAbove * probed->value,
            fmt::format("{} {} probed: no path is faster than the probes saw", format_quantity(probed->value, unit),
                        unit == "B/s" ? "bandwidth" : "rate")};
  if (probed && probed->value > 0 && unit == "s")
    return {0.02 * probed->value, 100 * probed->value,
            fmt::format("0.02x .. 100x the probed {}", format_quantity(probed->value, unit))};
  if (unit == "x") return {0.1, 100, "a cost ratio of one FLOP to another"};
  if (p == Param::L_pixel || p == Param::L_pixel_all || p == Param::L_label || p == Param::L_label_all ||
      p == Param::L_hist || p == Param::L_hist_all || p == Param::L_scan || p == Param::L_scan_all)
    return {5e-11, 1e-7, "a step of a scalar pixel loop: 0.05 ns .. 100 ns"};
  // The dots' blocks classify side by side on every multiprocessor: a step's share of the wall time
  // is picoseconds (about 60-80 ps on the lent H100), below any one event's 0.1 ns.
  if (p == Param::L_GP) return {1e-12, 1e-7, "a window pixel classified on the device, the dots' blocks side by side: 1 ps .. 100 ns"};
  // Likewise a pixel of a whole-frame pass, its threads on every multiprocessor (2.8-3.9 ps on a lent H200).
  if (p == Param::L_GF) return {1e-13, 1e-9, "a pixel of a device pass over a whole frame, every multiprocessor's threads at once: 0.1 ps .. 1 ns"};
  if (unit == "s") return {1e-10, 1e-2, "an event of the machine: 0.1 ns .. 10 ms"};
  if (unit == "B") return {1, 1024.0 * 1024 * 1024, "a copy size: 1 B .. 1 GiB"};
  return {start_value * 1e-6, start_value * 1e6, "no probe: a million-fold either side of its start"};
}

namespace {

// Does a sample's counts exercise component c (so that its prediction can be non-zero)?
bool exercised(const CostCounts& k, Component c) {
  const auto ph = phase(c);
  return !ph || counts_phase(k, *ph);
}

struct Residual {
  const Sample* sample;
  Component component;
  double measured;
  std::vector<int> params;  // indices into the fit's parameter list
};

// One relative residual: (predicted - measured) / measured for one sample's component.
struct ResidualFunctor {
  const MachineProfile* base;
  const std::vector<Param>* ids;
  const std::vector<double>* starts;
  const CostCounts* counts;
  std::vector<int> params;
  Variant variant;
  Component component;
  double measured;

  bool operator()(double const* const* theta, double* r) const {
    MachineProfile m = *base;
    for (std::size_t i = 0; i < params.size(); ++i) {
      const int p = params[i];
      const double v = (*starts)[p] * std::exp(theta[i][0]);
      if (!std::isfinite(v) || v <= 0) return false;
      m.set((*ids)[p], Parameter{v, Provenance::fitted, {}, {}, {}});
    }
    const Prediction pred = predict(m, *counts, variant);
    r[0] = (predicted(pred, component) - measured) / measured;
    return std::isfinite(r[0]);
  }
};

// The prior's residual: weight x log(value / probed) = weight x (theta + offset).
struct PriorCost {
  double weight, offset;
  template <typename T>
  bool operator()(const T* theta, T* r) const {
    r[0] = T(weight) * (theta[0] + T(offset));
    return true;
  }
};

ceres::LossFunction* make_loss(const FitOptions& o) {
  switch (o.loss) {
    case Loss::none: return nullptr;
    case Loss::huber: return new ceres::HuberLoss(o.loss_scale);
    case Loss::cauchy: return new ceres::CauchyLoss(o.loss_scale);
  }
  return nullptr;
}

std::string fmt_value(double v, Param p) { return fmt::format("{:.4g} {}", v, info(p).unit); }

// The parameters a sample's counts exercise: every refinement the model has is priced, those the
// start profile lacks found by the fit (staging, serial chains, all-thread windows, the GPU's L2
// where its size is known, graph launches, all-thread pixel steps, MLS fields at their own rate on
// the CPU and on the GPU, pixel steps by kind). A frame's fixed cost on many threads (L_pass_all)
// only where the probe found one: where it read none (zero within the noise), a fit has nothing to
// tell it from the steps and would push it to a bound. Along-row GPU taps (K_GW) likewise only
// where the probe measured them: against the GPU's rate, a factor from a start of 1 is the rate.
std::vector<Param> exercised_params(const CostCounts& c, Variant v, const MachineProfile& start) {
  return required_params(c, v,
                         Pricing{.llc_bytes = model_llc_bytes(start.identity), .staging = true, .all_threads = true,
                                 .serial = true, .gpu_l2_bytes = start.identity.gpu_l2_bytes, .graph = true,
                                 .pixel_all = true, .mls = true, .mls_all = true, .gpu_mls = true,
                                 .gpu_pixel = true, .pixel_kinds = true, .pixel_kinds_all = true,
                                 .pixel_pass_all = start.has(Param::L_pass_all), .along_row = start.has(Param::K_GW),
                                 .grid_match = true, .gpu_frame = true, .records = true});
}

// Parameters the samples exercise that the fit keeps at their probed values, because the samples
// cannot tell them from a factor beside them and the probe measures them as the machine has them
// (docs/calibration.md, "Kept at the probe"):
// - L_wait where it prices host-timed laps alone (no sample has host_waits): each lap shares its
//   component with the copies' or kernels' own latencies, as many in every sample;
// - the GPU's rate where the samples' FLOPs are window taps priced by K_GR and K_GW: scaling the
//   rate and both factors together moves only the few FLOPs beside the taps;
// - L_record where every sample with record steps has matching steps too: both scale with a frame's
//   dots, so the fit could move the host's time from one to the other at will (on a lent H200 it put
//   L_record on its lower bound and L_match at 1.9x its probe); the host's part lands in L_match.
// The backend's part is in the latencies and factors the fit finds beside them.
std::vector<Param> kept_at_probe(const std::vector<Sample>& samples, const MachineProfile& start) {
  auto any = [&samples](auto pred) {
    return std::any_of(samples.begin(), samples.end(), [&pred](const Sample& s) { return pred(s.counts); });
  };
  std::vector<Param> out;
  const auto probed = [&start](Param p) {
    const Parameter* x = start.find(p);
    return x && x->provenance == Provenance::probed;
  };
  if (probed(Param::L_wait) && any([](const CostCounts& c) { return c.laps_CG + c.laps_GC + c.laps_G > 0; }) &&
      !any([](const CostCounts& c) { return c.host_waits > 0; }))
    out.push_back(Param::L_wait);
  if (start.has(Param::K_GW) && any([](const CostCounts& c) { return c.N_GW > 0; }))
    for (const auto& [p, precision] :
         {std::pair{Param::V_G_fp32, Precision::fp32}, std::pair{Param::V_G_fp64, Precision::fp64}}) {
      const Precision wanted = precision;  // a structured binding cannot be captured before C++20's clang 16
      if (probed(p) && any([wanted](const CostCounts& c) { return c.N_G > 0 && c.precision == wanted; }))
        out.push_back(p);
    }
  if (probed(Param::L_record) && any([](const CostCounts& c) { return c.record_steps > 0; }) &&
      !any([](const CostCounts& c) { return c.record_steps > 0 && c.match_steps == 0; }))
    out.push_back(Param::L_record);
  return out;
}

}  // namespace

FitResult fit(const std::vector<Sample>& samples, const MachineProfile& start, const FitOptions& o) {
  if (samples.empty()) throw InputError("no samples to fit; measure some with `dtflop sweep`");
  if (!(o.loss_scale > 0)) throw InputError("the robust loss scale must be positive");

  // The parameters the samples' counts exercise, in Param order.
  std::vector<Param> ids;
  const std::vector<Param> kept = kept_at_probe(samples, start);
  for (const auto& s : samples)
    for (Param p : exercised_params(s.counts, o.variant, start))
      if (std::find(ids.begin(), ids.end(), p) == ids.end() && std::find(kept.begin(), kept.end(), p) == kept.end())
        ids.push_back(p);
  std::sort(ids.begin(), ids.end());
  // Start values: the latency variant's fit for extended (see FitOptions::warm_start), else
  // the start profile's values.
  MachineProfile from = start;
  if (o.variant == Variant::extended && o.warm_start) {
    FitOptions lo = o;
    lo.variant = Variant::latency;
    try {
      from = fit(samples, start, lo).profile;
    } catch (const InputError&) {
      // No warm start: the extended fit below reports its own problem, if any.
    }
  }
  std::vector<double> starts(ids.size());
  MachineProfile base = start;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const Parameter* p = from.find(ids[i]);
    starts[i] = p ? p->value : default_start(ids[i]);
    if (!p) base.set(ids[i], Parameter{starts[i], Provenance::user, {}, {}, "fit start guess"});
  }
  auto index_of = [&ids](Param p) {
    return static_cast<int>(std::find(ids.begin(), ids.end(), p) - ids.begin());
  };

  // Residuals: total, plus each measured component the counts exercise.
  std::vector<Residual> residuals;
  for (const auto& s : samples) {
    std::vector<int> params;
    for (Param p : exercised_params(s.counts, o.variant, start))
      if (std::find(kept.begin(), kept.end(), p) == kept.end()) params.push_back(index_of(p));
    for (Component c : all_components()) {
      if (c != Component::total &&
          std::find(o.components.begin(), o.components.end(), c) == o.components.end())
        continue;
      const Stats* st = s.find(c);
      if (!st || !(st->median > 0) || !exercised(s.counts, c)) continue;
      residuals.push_back({&s, c, st->median, params});
    }
  }

  std::vector<double> theta(ids.size(), 0.0);
  ceres::Problem::Options popts;
  ceres::Problem problem(popts);
  for (auto& t : theta) problem.AddParameterBlock(&t, 1);
  for (const auto& r : residuals) {
    auto* fn = new ceres::DynamicNumericDiffCostFunction<ResidualFunctor, ceres::CENTRAL>(
        new ResidualFunctor{&base, &ids, &starts, &r.sample->counts, r.params, o.variant, r.component,
                            r.measured});
    std::vector<double*> blocks;
    for (int p : r.params) {
      fn->AddParameterBlock(1);
      blocks.push_back(&theta[p]);
    }
    fn->SetNumResiduals(1);
    problem.AddResidualBlock(fn, make_loss(o), blocks);
  }

  // Parameters that move no prediction at the start point cannot be fitted (e.g. a one-thread
  // rate when every sample runs on all threads, or a term a max() never picks): keep them.
  std::vector<bool> identifiable(ids.size(), false);
  {
    ceres::Problem::EvaluateOptions eo;
    eo.apply_loss_function = false;
    for (auto& t : theta) eo.parameter_blocks.push_back(&t);  // column i is parameter i
    double cost = 0;
    ceres::CRSMatrix jac;
    problem.Evaluate(eo, &cost, nullptr, nullptr, &jac);
    for (int row = 0; row < jac.num_rows; ++row)
      for (int k = jac.rows[row]; k < jac.rows[row + 1]; ++k)
        if (std::abs(jac.values[k]) > 1e-6) identifiable[jac.cols[k]] = true;
  }
  int free = 0;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (identifiable[i]) {
      ++free;
    } else {
      problem.SetParameterBlockConstant(&theta[i]);
      if (const Parameter* p = start.find(ids[i])) starts[i] = p->value;  // held at the probed value
    }
  }
  const int n_samples = static_cast<int>(samples.size());
  if (free == 0)
    throw InputError("the samples exercise no parameter that can be fitted (no counts move any "
                     "prediction); measure a workload with non-zero counts");
  if (n_samples < free)
    throw InputError(fmt::format(
        "{} sample{} cannot determine {} parameters; measure at least {} configurations (e.g. "
        "`dtflop sweep WORKLOAD --plan random:50`)",
        n_samples, n_samples == 1 ? "" : "s", free, free));

  // A parameter whose term the samples barely feel would run off to zero or infinity (in log
  // space) without changing the cost; bound it to a million-fold either way and, if it ends on a
  // bound, report it as not determined. Inside that, each stays in its physical range
  // (physical_bounds); one that ends on an end of it is reported so.
  std::vector<Bound> bounds(ids.size());
  std::vector<double> lo_theta(ids.size(), -kLogBound), hi_theta(ids.size(), kLogBound);
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (!identifiable[i]) continue;
    const Parameter* sp = start.find(ids[i]);
    bounds[i] = physical_bounds(ids[i], start, sp ? sp->value : starts[i]);
    // A warm start outside the range begins on its nearer end.
    const double clamped = std::clamp(starts[i], bounds[i].lo, bounds[i].hi);
    if (clamped != starts[i]) {
      starts[i] = clamped;
      base.set(ids[i], Parameter{starts[i], Provenance::user, {}, {}, "fit start, clamped to its physical range"});
    }
    lo_theta[i] = std::max(-kLogBound, std::log(bounds[i].lo / starts[i]));
    hi_theta[i] = std::min(kLogBound, std::log(bounds[i].hi / starts[i]));
    problem.SetParameterLowerBound(&theta[i], 0, lo_theta[i]);
    problem.SetParameterUpperBound(&theta[i], 0, hi_theta[i]);
  }

  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = o.max_iterations;
  so.function_tolerance = 1e-10;
  so.parameter_tolerance = 1e-10;
  so.gradient_tolerance = 1e-12;
  so.logging_type = ceres::SILENT;
  so.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);

  // The samples' rms relative residual (no loss applied) at theta.
  auto rms_of = [&] {
    double ss = 0;
    for (const auto& r : residuals) {
      MachineProfile m = base;
      for (int p : r.params) m.set(ids[p], Parameter{starts[p] * std::exp(theta[p]), Provenance::fitted, {}, {}, {}});
      const double rel = (predicted(predict(m, r.sample->counts, o.variant), r.component) - r.measured) / r.measured;
      ss += rel * rel;
    }
    return residuals.empty() ? 0.0 : std::sqrt(ss / static_cast<double>(residuals.size()));
  };
  // A fit that creeps along directions its samples barely feel can use up its iterations without
  // converging (the main job's 18 DCT cpu-par samples on a lent H200's host, 16 threads, frames under
  // 2 ms: 3 of 5 folds of the latency variant, whose choice then fell to the seed's 49% error). Such
  // a fit is solved again with the probes as a prior (kFallbackPrior), which holds those directions
  // near the probes, and says so.
  double prior_sigma = o.prior_log_sigma;
  const bool prior_fallback = !(prior_sigma > 0) && summary.termination_type == ceres::NO_CONVERGENCE &&
                              summary.IsSolutionUsable();
  if (prior_fallback) {
    prior_sigma = kFallbackPrior;
    so.max_num_iterations = std::max(o.max_iterations, kFallbackIterations);  // a budget of its own
  }
  int priors = 0;  // parameters the prior holds (those the start profile has as probed)
  if (prior_sigma > 0 && summary.IsSolutionUsable()) {
    // MAP with the samples' residuals as normal with the scatter the fit without the prior left:
    // a prior residual (theta - log(probed / start)) / prior_log_sigma, scaled to that scatter.
    const double weight = rms_of() / prior_sigma;
    for (std::size_t i = 0; i < ids.size() && weight > 0; ++i) {
      const Parameter* sp = start.find(ids[i]);
      if (!identifiable[i] || !sp || sp->provenance != Provenance::probed || !(sp->value > 0)) continue;
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<PriorCost, 1, 1>(
                                   new PriorCost{weight, std::log(starts[i] / sp->value)}),
                               nullptr, &theta[i]);
      ++priors;
    }
    if (priors > 0) ceres::Solve(so, &problem, &summary);
  }

  FitResult out;
  out.variant = o.variant;
  out.samples = n_samples;
  out.residuals = static_cast<int>(residuals.size());
  out.free_parameters = free;
  out.prior_log_sigma = priors > 0 ? prior_sigma : 0;
  out.termination = prior_fallback ? fmt::format("{} (without a prior it did not converge in {} iterations; solved "
                                                 "again with the probes as a prior, sigma {})",
                                                 summary.message, o.max_iterations, kFallbackPrior)
                                   : summary.message;
  out.iterations = static_cast<int>(summary.iterations.size());
  if (summary.termination_type == ceres::NO_CONVERGENCE)
    throw InputError(fmt::format(
        "the {} fit did not converge in {} iterations ({}); the samples may be too noisy or "
        "too few for this variant: measure more configurations or pick another --variant",
        to_string(o.variant), o.max_iterations, summary.message));
  if (summary.termination_type != ceres::CONVERGENCE || !summary.IsSolutionUsable())
    throw InputError(fmt::format("the {} fit failed: {}", to_string(o.variant), summary.message));

  std::vector<bool> at_bound(ids.size(), false), at_physical(ids.size(), false);
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (!identifiable[i]) continue;
    if (std::abs(theta[i]) > kLogBound - 1e-3) {
      at_bound[i] = true;
      problem.SetParameterBlockConstant(&theta[i]);  // out of the covariance
    } else if (theta[i] < lo_theta[i] + 1e-3 || theta[i] > hi_theta[i] - 1e-3) {
      at_physical[i] = true;
      problem.SetParameterBlockConstant(&theta[i]);  // on a bound: its interval says nothing
    }
  }

  // Unrobustified residuals at the solution: their variance scales the covariance, since
  // relative residuals have no known standard deviation of their own.
  out.rms_relative = rms_of();
  const double ss = out.rms_relative * out.rms_relative * static_cast<double>(residuals.size());
  const int dof = out.residuals - free;
  const double s2 = dof > 0 ? ss / dof : 0;

  std::vector<double> log_var(ids.size(), 0.0);
  {
    ceres::Covariance::Options co;
    co.algorithm_type = ceres::DENSE_SVD;
    co.num_threads = 1;
    ceres::Covariance cov(co);
    std::vector<std::pair<const double*, const double*>> blocks;
    for (std::size_t i = 0; i < ids.size(); ++i)
      if (identifiable[i] && !at_bound[i] && !at_physical[i]) blocks.emplace_back(&theta[i], &theta[i]);
    if (dof <= 0) {
      out.covariance_note = "no degrees of freedom left for an uncertainty estimate (as many residuals as parameters)";
    } else if ([&] {
                 // Ceres logs a rank-deficient covariance as an error through glog; the report
                 // below says it in words, so keep glog quiet meanwhile.
                 const int level = FLAGS_minloglevel;
                 FLAGS_minloglevel = google::GLOG_FATAL;
                 const bool ok = cov.Compute(blocks, &problem);
                 FLAGS_minloglevel = level;
                 return ok;
               }()) {
      out.covariance_ok = true;
      for (std::size_t i = 0; i < ids.size(); ++i) {
        if (!identifiable[i] || at_bound[i] || at_physical[i]) continue;
        double c = 0;
        cov.GetCovarianceBlock(&theta[i], &theta[i], &c);
        log_var[i] = std::max(0.0, c * s2);
      }
    } else {
      out.covariance_note =
          "the covariance could not be computed: the Jacobian is rank deficient, so some fitted "
          "parameters are not separately determined by these samples (e.g. a latency and a "
          "bandwidth when every copy has the same size); widen the sweep";
    }
  }

  out.profile = start;
  const std::string stamp = utc_now();
  for (std::size_t i = 0; i < ids.size(); ++i) {
    FittedParameter f;
    f.id = ids[i];
    if (const Parameter* p = start.find(ids[i])) f.probed = p->value;
    f.fitted = identifiable[i] && !at_bound[i];
    f.lo_bound = bounds[i].lo;
    f.hi_bound = bounds[i].hi;
    f.bound_reason = bounds[i].reason;
    f.at_physical_bound = at_physical[i];
    if (at_physical[i]) ++out.at_physical_bounds;
    f.value = starts[i] * std::exp(theta[i]);
    if (!f.fitted) {
      const std::string why = at_bound[i] ? fmt::format("not determined by these samples (the fit drove it {} a "
                                                        "million-fold away: its term is negligible in every sample)",
                                                        theta[i] > 0 ? "up" : "down")
                                          : "not identifiable from these samples (it moves no prediction)";
      f.value = f.probed ? *f.probed : starts[i];
      f.note = why + (f.probed ? "; kept the probed value" : "; absent from the profile, left out");
    } else {
      // A parameter the samples barely constrain can have a variance so large that its interval
      // overflows (exp of it is infinite): it has no interval, rather than an infinite one that
      // no profile can hold (a fitted profile with it could not be read back).
      const double sigma = std::sqrt(log_var[i]);
      if (out.covariance_ok && std::isfinite(f.value * std::exp(kZ95 * sigma))) {
        f.log_sigma = sigma;
        f.has_interval = true;
        f.lo95 = f.value * std::exp(-kZ95 * f.log_sigma);
        f.hi95 = f.value * std::exp(kZ95 * f.log_sigma);
      }
      if (f.probed) {
        const double ratio = f.value / *f.probed;
        if (ratio > o.flag_ratio || ratio < 1.0 / o.flag_ratio) {
          f.flagged = true;
          f.note = fmt::format("fitted is {:.2f}x the probed value: the workload does not run at the "
                               "rate the probe measured (the fitted value is the workload's)",
                               ratio);
        }
      } else {
        f.note = "no probed value to compare with";
      }
      if (f.at_physical_bound)
        f.note = fmt::format("reached the {} end of its physical range ({}): the counts do not describe what bounds "
                             "this backend here, so the value is not the machine's{}",
                             f.value >= f.hi_bound * (1 - 1e-3) ? "upper" : "lower", f.bound_reason,
                             f.note.empty() ? "" : "; " + f.note);
      Parameter par;
      par.value = f.value;
      par.provenance = Provenance::fitted;
      if (f.has_interval) par.uncertainty = (f.hi95 - f.lo95) / 2;
      par.note = fmt::format("fitted to {} samples, model variant {}, {}{}", n_samples,
                             to_string(o.variant), stamp,
                             f.probed ? "; probed " + fmt_value(*f.probed, ids[i]) : std::string());
      out.profile.set(ids[i], par);
    }
    out.params.push_back(std::move(f));
  }
  for (Param p : kept) {
    FittedParameter f;
    f.id = p;
    f.probed = f.value = start.get(p).value;
    f.kept_at_probe = true;
    f.note = p == Param::L_wait     ? "kept at the probe: a host-timed lap's round trip, which these samples cannot tell "
                                      "from the copies' and kernels' latencies beside it"
             : p == Param::L_record ? "kept at the probe: the records' pass, which these samples cannot tell from the "
                                      "matching's steps beside it (both scale with the dots; L_match takes the rest)"
                                    : "kept at the probe: these samples' FLOPs are window taps, whose factors (K_GR, K_GW) "
                                      "the fit finds against it";
    out.params.push_back(std::move(f));
  }
  std::sort(out.params.begin(), out.params.end(),
            [](const FittedParameter& a, const FittedParameter& b) { return a.id < b.id; });
  return out;
}

namespace {

// Deterministic on every platform (std::shuffle's distribution is not).
std::vector<int> shuffled_indices(int n, std::uint64_t seed) {
  std::vector<int> idx(n);
  std::iota(idx.begin(), idx.end(), 0);
  std::mt19937_64 rng(seed);
  for (int i = n - 1; i > 0; --i) std::swap(idx[i], idx[rng() % static_cast<std::uint64_t>(i + 1)]);
  return idx;
}

}  // namespace

namespace {

// Each variant fitted to every fold's complement and scored on the fold (fold_of[i] in 0..k-1).
std::vector<CvResult> cross_validate_folds(const std::vector<Sample>& samples, const MachineProfile& start,
                                           const FitOptions& base, const std::vector<Variant>& variants,
                                           const std::vector<int>& fold_of, int k) {
  const int n = static_cast<int>(samples.size());
  std::vector<CvResult> out;
  for (Variant v : variants) {
    CvResult cv;
    cv.variant = v;
    cv.folds = k;
    std::vector<double> all_err;
    double sum_log2 = 0;
    for (int f = 0; f < k; ++f) {
      std::vector<Sample> train, test;
      for (int i = 0; i < n; ++i) (fold_of[i] == f ? test : train).push_back(samples[i]);
      FitOptions o = base;
      o.variant = v;
      try {
        const FitResult r = fit(train, start, o);
        double sum = 0;
        for (const auto& s : test) {
          const double meas = s.find(Component::total)->median;
          const double pred = predict(r.profile, s.counts, v).total;
          const double err = std::abs(pred - meas) / meas;
          sum_log2 += pred > 0 ? std::pow(std::log(pred / meas), 2) : 0;
          sum += err;
          all_err.push_back(err);
          cv.max_rel = std::max(cv.max_rel, err);
        }
        cv.fold_means.push_back(test.empty() ? 0 : sum / static_cast<double>(test.size()));
      } catch (const InputError& e) {
        if (cv.failed_folds++ == 0) cv.failure = e.what();
      }
    }
    cv.held_out = static_cast<int>(all_err.size());
    if (!all_err.empty()) {
      cv.mean_rel = std::accumulate(all_err.begin(), all_err.end(), 0.0) / static_cast<double>(all_err.size());
      cv.rms_log = std::sqrt(sum_log2 / static_cast<double>(all_err.size()));
    }
    if (cv.fold_means.size() >= 2) {
      const double m = std::accumulate(cv.fold_means.begin(), cv.fold_means.end(), 0.0) /
                       static_cast<double>(cv.fold_means.size());
      double var = 0;
      for (double x : cv.fold_means) var += (x - m) * (x - m);
      var /= static_cast<double>(cv.fold_means.size() - 1);
      cv.se = std::sqrt(var / static_cast<double>(cv.fold_means.size()));
    }
    out.push_back(std::move(cv));
  }
  return out;
}

}  // namespace

std::vector<CvResult> cross_validate(const std::vector<Sample>& samples, const MachineProfile& start,
                                     const FitOptions& base, const std::vector<Variant>& variants,
                                     int k, std::uint64_t seed) {
  const int n = static_cast<int>(samples.size());
  if (k < 2) throw InputError(fmt::format("cross-validation needs at least 2 folds, got {}", k));
  if (n < k)
    throw InputError(fmt::format("{}-fold cross-validation needs at least {} samples, the store holds {}", k, k, n));
  const auto order = shuffled_indices(n, seed);
  std::vector<int> fold_of(n);
  for (int i = 0; i < n; ++i) fold_of[order[i]] = i % k;
  return cross_validate_folds(samples, start, base, variants, fold_of, k);
}

std::vector<std::string> plans_of(const std::vector<Sample>& samples) {
  std::vector<std::string> plans;
  for (const auto& s : samples)
    if (std::find(plans.begin(), plans.end(), s.plan) == plans.end()) plans.push_back(s.plan);
  return plans;
}

CvResult cross_validate_by_plan(const std::vector<Sample>& samples, const MachineProfile& start,
                                const FitOptions& options) {
  const std::vector<std::string> plans = plans_of(samples);
  if (plans.size() < 2)
    throw InputError(fmt::format("leaving one plan out needs samples of at least 2 plans, these are all of '{}'",
                                 plans.empty() ? std::string() : plans.front()));
  std::vector<int> fold_of;
  for (const auto& s : samples)
    fold_of.push_back(static_cast<int>(std::find(plans.begin(), plans.end(), s.plan) - plans.begin()));
  return cross_validate_folds(samples, start, options, {options.variant}, fold_of, static_cast<int>(plans.size()))
      .front();
}

VariantChoice choose_variant(const std::vector<CvResult>& cv) {
  const CvResult* best = nullptr;
  for (const auto& c : cv)
    if (c.failed_folds == 0 && c.held_out > 0 && (!best || c.mean_rel < best->mean_rel)) best = &c;
  if (!best) {
    std::string why;
    for (const auto& c : cv) why += fmt::format("{}{}: {}", why.empty() ? "" : "; ", to_string(c.variant), c.failure);
    throw InputError("no model variant could be cross-validated on these samples: " + why);
  }
  // all_variants() lists the variants from the simplest to the richest.
  const CvResult* chosen = best;
  for (Variant v : all_variants()) {
    auto it = std::find_if(cv.begin(), cv.end(), [v](const CvResult& c) { return c.variant == v; });
    if (it == cv.end() || it->failed_folds > 0 || it->held_out == 0) continue;
    if (it->mean_rel <= best->mean_rel + best->se) {
      chosen = &*it;
      break;
    }
  }
  std::string table;
  for (const auto& c : cv) {
    table += fmt::format("{}{} {}", table.empty() ? "" : ", ", to_string(c.variant),
                         c.failed_folds ? fmt::format("failed in {} fold(s)", c.failed_folds)
                                        : fmt::format("{:.2f}% (se {:.2f}%, max {:.1f}%)", 100 * c.mean_rel,
                                                      100 * c.se, 100 * c.max_rel));
  }
  VariantChoice out;
  out.chosen = chosen->variant;
  const int k = cv.front().folds;
  if (chosen == best)
    out.reason = fmt::format(
        "{}-fold cross-validated mean relative error of the total: {}. Chose {}: lowest error{}.", k, table,
        to_string(chosen->variant),
        chosen->variant == all_variants().front() ? "" : ", and no simpler variant is within one standard error of it");
  else
    out.reason = fmt::format(
        "{}-fold cross-validated mean relative error of the total: {}. Chose {}, the simplest "
        "variant within one standard error of the best ({}, {:.2f}% + {:.2f}%).",
        k, table, to_string(chosen->variant), to_string(best->variant), 100 * best->mean_rel, 100 * best->se);
  return out;
}

ErrorFigure error_figure(const CvResult& cv, int samples) {
  ErrorFigure e;
  e.samples = cv.held_out;
  e.mean_rel = cv.mean_rel;
  e.max_rel = cv.max_rel;
  e.rms_log = cv.rms_log;
  e.how = fmt::format("{}-fold cross-validation of {} samples, variant {}", cv.folds, samples, to_string(cv.variant));
  return e;
}

ErrorFigure plan_error_figure(const CvResult& cv, int samples) {
  ErrorFigure e = error_figure(cv, samples);
  e.how = fmt::format("each of {} plans predicted by a fit to the others ({} samples, variant {})", cv.folds, samples,
                      to_string(cv.variant));
  return e;
}

Calibration to_calibration(const FitResult& r, const std::string& workload, const std::string& backend,
                           const std::vector<std::string>& match, const ErrorFigure& error) {
  Calibration c;
  c.workload = workload;
  c.backend = backend;
  c.match = match;
  c.variant = r.variant;
  c.fitted_on = r.profile.identity;
  c.fit_error = error;
  for (const auto& f : r.params) {
    if (!f.fitted && !f.probed) continue;  // neither fitted nor probed: nothing to carry
    CalibrationFactor cf;
    cf.id = f.id;
    cf.fitted = f.fitted;
    cf.value = f.value;
    cf.log_sigma = f.has_interval ? f.log_sigma : 0;
    if (f.probed && *f.probed > 0) {
      cf.relative = true;
      cf.source_probed = *f.probed;
      cf.factor = f.value / *f.probed;
    }
    c.factors.push_back(cf);
  }
  c.metadata["fitted_at"] = utc_now();
  c.metadata["fit_samples"] = std::to_string(r.samples);
  c.metadata["fit_rms_relative"] = fmt::format("{:.4g}", r.rms_relative);
  return c;
}

}  // namespace dtflop::calib
