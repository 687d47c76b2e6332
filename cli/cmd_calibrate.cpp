// `dtflop calibrate`: fit the DTFLOP model's parameters to measured samples (Ceres), with 95%
// intervals, a comparison with the probed values, and the model variant chosen by k-fold
// cross-validation; writes the fitted machine profile.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "calibrate/fit.hpp"
#include "calibrate/machine.hpp"
#include "calibrate/rounds.hpp"
#include "calibrate/store.hpp"
#include "cli/command.hpp"
#include "cli/table.hpp"
#include "cli/workload_cli.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/units.hpp"

namespace dtflop::cli {
namespace {

namespace fs = std::filesystem;
using namespace dtflop::calib;

struct CalibrateOptions {
  std::vector<std::string> stores;
  std::string machine;
  std::string output;
  std::string calibration;  // --write-calibration
  std::string variant = "all";
  int folds = 5;
  std::string loss = "huber";
  double loss_scale = 0.05;
  double flag_ratio = 1.5;
  double prior = 0;
  std::vector<std::string> backends;
  std::vector<std::string> match;  // sample keys must contain each
  bool total_only = false;
  std::uint64_t seed = 1;
  bool accept_bounds = false;
  std::string rounds_combine{to_string(kDefaultRoundCombine)};
  bool json = false;
};

std::vector<Sample> loaded_samples(const std::vector<std::string>& stores, const SampleFilter& filter) {
  LoadedSamples l = load_samples(stores, filter);
  for (const auto& w : l.warnings) fmt::print(stderr, "dtflop: warning: {}\n", w);
  return std::move(l.samples);
}

void check_machine(const std::vector<Sample>& samples, const MachineProfile& profile, const std::string& file) {
  int foreign = 0;
  const Sample* first = nullptr;
  std::string why;
  for (const auto& s : samples) {
    std::string w;
    if (!same_machine(s.machine, profile.identity, &w)) {
      if (foreign++ == 0) {
        first = &s;
        why = w;
      }
    }
  }
  if (foreign > 0)
    throw InputError(fmt::format(
        "{} of {} samples were measured on another machine than profile '{}' describes (first: '{}' on {}; "
        "{}). Fit samples against the profile of the machine that measured them",
        foreign, samples.size(), file, first->key, describe(first->machine), why));
}

std::string value_text(double v, Param p) { return format_quantity(v, info(p).unit); }

void run(const CalibrateOptions& o) {
  if (o.stores.empty()) throw InputError("name at least one --store");
  if (o.output.empty()) throw InputError("name the fitted profile to write with -o fitted.json");
  {
    // Neither the probed profile nor a store is ever replaced by the fit or the calibration.
    std::vector<std::string> inputs = o.stores;
    inputs.push_back(o.machine);
    check_output(o.output, inputs);
    if (!o.calibration.empty()) {
      inputs.push_back(o.output);
      check_output(o.calibration, inputs);
      check_output(o.output, {o.calibration});
    }
  }
  if (o.folds < 2) throw InputError(fmt::format("--folds must be at least 2, got {}", o.folds));
  if (!(o.loss_scale > 0)) throw InputError("--loss-scale must be positive, e.g. 0.05 (5%)");
  if (!(o.flag_ratio > 1)) throw InputError("--flag-ratio must be above 1, e.g. 1.5");
  std::vector<Variant> variants;
  if (o.variant == "all") variants = all_variants();
  else if (auto v = variant_from_string(o.variant)) variants = {*v};
  else throw InputError(fmt::format("--variant '{}' is unknown; use {} or all", o.variant, variant_names(", ")));

  FitOptions fo;
  if (o.loss == "huber") fo.loss = Loss::huber;
  else if (o.loss == "cauchy") fo.loss = Loss::cauchy;
  else if (o.loss == "none") fo.loss = Loss::none;
  else throw InputError(fmt::format("--loss '{}' is unknown; use huber, cauchy or none", o.loss));
  fo.loss_scale = o.loss_scale;
  fo.flag_ratio = o.flag_ratio;
  fo.prior_log_sigma = o.prior;
  if (o.total_only) fo.components.clear();

  const MachineProfile probed = load_profile(o.machine);
  // The rounds of one configuration (`dtflop sweep --rounds`) become one sample: the median of their medians.
  const MergedRounds merged =
      merge_rounds(loaded_samples(o.stores, {o.backends, o.match}), parse_round_combine(o.rounds_combine));
  for (const auto& w : merged.warnings) fmt::print(stderr, "dtflop: warning: {}\n", w);
  const std::vector<Sample>& samples = merged.samples;
  check_machine(samples, probed, o.machine);

  // Variant: cross-validated when there is a choice (and reported when there is not).
  std::vector<CvResult> cv;
  VariantChoice choice;
  const bool can_cv = static_cast<int>(samples.size()) >= 2 * o.folds;
  if (variants.size() > 1) {
    if (!can_cv)
      throw InputError(fmt::format("choosing a model variant by {}-fold cross-validation needs at least {} "
                                   "samples, the stores hold {}; measure more or name one --variant",
                                   o.folds, 2 * o.folds, samples.size()));
    cv = cross_validate(samples, probed, fo, variants, o.folds, o.seed);
    choice = choose_variant(cv);
  } else {
    choice.chosen = variants.front();
    choice.reason = fmt::format("variant {} named by --variant", to_string(choice.chosen));
    if (can_cv) {
      cv = cross_validate(samples, probed, fo, variants, o.folds, o.seed);
      if (cv.front().failed_folds == 0)
        choice.reason += fmt::format("; its {}-fold cross-validated mean relative error of the total is {:.2f}% "
                                     "(max {:.1f}%)",
                                     o.folds, 100 * cv.front().mean_rel, 100 * cv.front().max_rel);
    }
  }
  fo.variant = choice.chosen;
  // A calibration describes one backend of one workload: check that before the fit's minutes.
  if (!o.calibration.empty()) {
    std::map<std::string, int> kinds;
    for (const auto& s : samples) kinds[s.workload + "/" + s.backend] += 1;
    if (kinds.size() != 1)
      throw InputError(fmt::format("--write-calibration describes one backend of one workload, and the samples hold "
                                   "{} ({}); select one with --backend NAME",
                                   kinds.size(), [&] {
                                     std::string t;
                                     for (const auto& [k, n] : kinds) t += (t.empty() ? "" : ", ") + k;
                                     return t;
                                   }()));
  }
  FitResult r = [&] {
    try {
      return fit(samples, probed, fo);
    } catch (const InputError& e) {
      if (cv.size() < 2) throw;  // one variant, named by --variant: nothing else to fit
      // The chosen variant fitted every fold but not all the samples at once (noisy samples can
      // leave the extended fit's max() terms cycling): fit the next best variant that
      // cross-validated, by its error, and say so, rather than lose the calibration.
      std::vector<const CvResult*> rest;
      for (const auto& c : cv)
        if (c.variant != choice.chosen && c.failed_folds == 0 && c.held_out > 0) rest.push_back(&c);
      std::sort(rest.begin(), rest.end(), [](const CvResult* a, const CvResult* b) { return a->mean_rel < b->mean_rel; });
      for (const CvResult* c : rest) {
        fo.variant = c->variant;
        try {
          FitResult next = fit(samples, probed, fo);
          choice.reason += fmt::format("; but fitted on all the samples it failed ({}), so the next best variant "
                                       "by cross-validated error, {}, was fitted",
                                       e.what(), to_string(c->variant));
          fmt::print(stderr, "dtflop: warning: the {} fit failed on all the samples ({}); fitted {} instead\n",
                     to_string(choice.chosen), e.what(), to_string(c->variant));
          choice.chosen = c->variant;
          return next;
        } catch (const InputError&) {
        }
      }
      throw;
    }
  }();
  // The chosen variant's cross-validated error: what a prediction of this calibration carries.
  ErrorFigure error;
  for (const auto& c : cv)
    if (c.variant == r.variant && c.failed_folds == 0 && c.held_out > 0) error = error_figure(c, static_cast<int>(samples.size()));
  if (error.samples == 0) {
    error.samples = static_cast<int>(samples.size());
    error.rms_log = std::log1p(r.rms_relative);
    error.mean_rel = r.rms_relative;
    error.max_rel = r.rms_relative;
    error.how = "the fit's rms residual on its own samples (too few samples to cross-validate: an optimistic figure)";
  }
  // Random folds share every plan: they measure a fit among configurations like its own. Each plan
  // predicted by a fit to the others measures how far it carries to configurations of another kind,
  // as a held-out set's are; a calibration's intervals carry the larger of the two errors.
  std::optional<CvResult> by_plan;
  if (plans_of(samples).size() >= 2) {
    FitOptions po = fo;
    po.variant = r.variant;
    by_plan = cross_validate_by_plan(samples, probed, po);
    if (by_plan->failed_folds == 0 && by_plan->held_out > 0 && by_plan->rms_log > error.rms_log)
      error = plan_error_figure(*by_plan, static_cast<int>(samples.size()));
  }

  // The machine's drift between the rounds, which no fold of one sweep sees (calibrate/rounds.hpp).
  if (merged.round_configs > 0) {
    error.round_log_sd = merged.round_log_sd;
    error.round_configs = merged.round_configs;
  }

  // Report: tables, or with --json the same as one object.
  std::FILE* tables = o.json ? nullptr : stdout;
  auto print = [tables](const std::string& text) {
    if (tables) std::fputs(text.c_str(), tables);
  };
  std::map<std::string, int> per_backend;
  for (const auto& s : samples) per_backend[s.backend] += 1;
  std::string backends;
  for (const auto& [b, n] : per_backend) backends += fmt::format("{}{} {}", backends.empty() ? "" : ", ", n, b);
  print(fmt::format("Samples: {}{}.\n", merged.summary(), merged.how()));
  print(fmt::format("Fitted {} samples ({}) from {} to the {} variant: {} residuals, {} free parameters, "
                    "rms relative residual {:.2f}%, {} iterations.\n",
                    samples.size(), backends, describe(probed.identity), to_string(r.variant), r.residuals,
                    r.free_parameters, 100 * r.rms_relative, r.iterations));
  print(fmt::format("Solver: {}\n", r.termination));
  nlohmann::json result = {{"samples", samples.size()},
                           {"stored_samples", merged.input},
                           {"rounds", {{"min", merged.min_rounds}, {"max", merged.max_rounds}}},
                           {"rounds_combine", std::string(to_string(merged.combine))},
                           {"backends", per_backend},
                           {"variant", std::string(to_string(r.variant))},
                           {"variant_reason", choice.reason},
                           {"residuals", r.residuals},
                           {"free_parameters", r.free_parameters},
                           {"rms_relative", r.rms_relative},
                           {"iterations", r.iterations},
                           {"solver", r.termination},
                           {"output", o.output}};
  nlohmann::json cv_json = nlohmann::json::array();
  for (const auto& c : cv)
    cv_json.push_back({{"variant", std::string(to_string(c.variant))},
                       {"mean_rel", c.mean_rel},
                       {"se", c.se},
                       {"max_rel", c.max_rel},
                       {"failed_folds", c.failed_folds}});
  result["cross_validation"] = cv_json;
  if (!cv.empty()) {
    print(fmt::format("\nModel variants by {}-fold cross-validation (relative error of the total on held-out folds):\n",
                      o.folds));
    Table t({"variant", "mean", "std. error", "max", "note"}, "lrrrl");
    for (const auto& c : cv)
      t.row({std::string(to_string(c.variant)), c.failed_folds ? "-" : fmt::format("{:.2f}%", 100 * c.mean_rel),
             c.failed_folds ? "-" : fmt::format("{:.2f}%", 100 * c.se),
             c.failed_folds ? "-" : fmt::format("{:.1f}%", 100 * c.max_rel),
             c.failed_folds ? fmt::format("fit failed in {} fold(s): {}", c.failed_folds, c.failure)
                            : (c.variant == choice.chosen ? "chosen" : "")});
    print(t.str());
  }
  if (by_plan) {
    nlohmann::json bp = {{"plans", by_plan->folds}, {"mean_rel", by_plan->mean_rel}, {"max_rel", by_plan->max_rel},
                         {"rms_log", by_plan->rms_log}, {"failed_folds", by_plan->failed_folds}};
    result["cross_validation_by_plan"] = bp;
    print(by_plan->failed_folds
              ? fmt::format("\nEach of the {} plans predicted by a fit to the others: the fit failed without {} of them "
                            "({}).\n",
                            by_plan->folds, by_plan->failed_folds, by_plan->failure)
              : fmt::format("\nEach of the {} plans predicted by a fit to the others ({} variant): mean {:.2f}%, max "
                            "{:.1f}%, rms log {:.3f}.\n",
                            by_plan->folds, to_string(r.variant), 100 * by_plan->mean_rel, 100 * by_plan->max_rel,
                            by_plan->rms_log));
  }
  result["error_for_intervals"] = {{"rms_log", error.rms_log},
                                   {"how", error.how},
                                   {"round_log_sd", error.round_log_sd},
                                   {"round_configs", error.round_configs},
                                   {"sigma", error.sigma()}};
  if (error.round_configs > 0)
    print(fmt::format("Predictions of this fit carry a log error of {:.3f} in their intervals: an rms log error of "
                      "{:.3f} ({}) and the machine's drift between a configuration's rounds, {:.3f} (the standard "
                      "deviation of log time over {} configurations), in quadrature.\n",
                      error.sigma(), error.rms_log, error.how, error.round_log_sd, error.round_configs));
  else
    print(fmt::format("Predictions of this fit carry an rms log error of {:.3f} in their intervals ({}; one round "
                      "each, so no drift of the machine between rounds is measured: sweep with --rounds 2 or more).\n",
                      error.rms_log, error.how));
  print(fmt::format("{}\n\nParameters:\n", choice.reason));
  nlohmann::json params_json = nlohmann::json::array();
  Table t({"parameter", "probed", "fitted", "95% interval", "fitted/probed", "note"}, "lrrrrl");
  int flagged = 0;
  for (const auto& f : r.params) {
    if (f.flagged) ++flagged;
    t.row({std::string(info(f.id).name), f.probed ? value_text(*f.probed, f.id) : "-",
           f.fitted ? value_text(f.value, f.id) : "(kept)",
           f.has_interval ? fmt::format("{} .. {}", value_text(f.lo95, f.id), value_text(f.hi95, f.id)) : "-",
           f.fitted && f.probed ? fmt::format("{:.2f}", f.value / *f.probed) : "-",
           (f.at_physical_bound ? "BOUND: " : f.flagged ? "FLAG: " : "") + f.note});
    nlohmann::json pj = {{"name", std::string(info(f.id).name)}, {"unit", std::string(info(f.id).unit)},
                         {"fitted", f.fitted}, {"value", f.value}, {"flagged", f.flagged}, {"note", f.note},
                         {"bounds", {f.lo_bound, f.hi_bound}}, {"at_physical_bound", f.at_physical_bound}};
    if (f.probed) pj["probed"] = *f.probed;
    if (f.has_interval) pj["interval95"] = {f.lo95, f.hi95};
    params_json.push_back(pj);
  }
  result["parameters"] = params_json;
  print(t.str());
  if (!r.covariance_ok) print(fmt::format("No intervals: {}\n", r.covariance_note));
  if (flagged)
    print(fmt::format("{} parameter{} disagree with the probed value by more than {:.2f}x (flagged above).\n", flagged,
                      flagged == 1 ? "" : "s", o.flag_ratio));

  if (r.at_physical_bounds > 0) {
    std::string which;
    for (const auto& f : r.params)
      if (f.at_physical_bound) which += (which.empty() ? "" : ", ") + std::string(info(f.id).name);
    result["at_physical_bounds"] = which;
    if (!o.accept_bounds) {
      if (o.json) fmt::print("{}\n", result.dump(2));
      throw std::runtime_error(fmt::format(
          "{} fitted parameter{} reached {} physical bound ({}: see the table): the samples' counts do not describe "
          "what bounds this backend on this machine, and such a value cannot carry to another; nothing written. Pass "
          "--accept-bounds to write the fit anyway",
          r.at_physical_bounds, r.at_physical_bounds == 1 ? "" : "s", r.at_physical_bounds == 1 ? "its" : "their",
          which));
    }
    print(fmt::format("{} parameter(s) at a physical bound ({}), accepted with --accept-bounds.\n",
                      r.at_physical_bounds, which));
  }

  MachineProfile out = r.profile;
  std::string stores;
  // As given (relative paths stay relative, so a fitted profile names no folder of this machine).
  for (const auto& s : o.stores) stores += (stores.empty() ? "" : ";") + fs::path(s).lexically_normal().string();
  out.metadata[kChosenVariantKey] = std::string(to_string(r.variant));
  out.metadata["model_variant_reason"] = choice.reason;
  out.metadata["fit_samples"] = std::to_string(samples.size());
  if (merged.max_rounds > 1) {
    out.metadata["fit_rounds"] = merged.summary() + merged.how();
    out.metadata["fit_rounds_combine"] = std::string(to_string(merged.combine));  // validate's default
  }
  out.metadata["fit_stores"] = stores;
  out.metadata["fit_rms_relative"] = fmt::format("{:.4g}", r.rms_relative);
  out.metadata["fit_cv_rms_log"] = fmt::format("{:.4g}", error.rms_log);
  out.metadata["fit_error"] = error.how;
  if (error.round_configs > 0) out.metadata["fit_round_log_sd"] = fmt::format("{:.4g}", error.round_log_sd);
  out.metadata["fit_loss"] = fmt::format("{} (scale {})", to_string(fo.loss), fo.loss_scale);
  if (r.prior_log_sigma > 0) out.metadata["fit_prior_log_sigma"] = fmt::format("{:.4g}", r.prior_log_sigma);
  out.metadata["fit_from"] = fs::path(o.machine).lexically_normal().string();
  out.metadata["fitted_at"] = utc_now();
  std::string kept, at_probe;
  for (const auto& f : r.params)
    if (!f.fitted) {
      std::string& list = f.kept_at_probe ? at_probe : kept;
      list += (list.empty() ? "" : ", ") + std::string(info(f.id).name);
    }
  if (!kept.empty()) out.metadata["fit_not_identifiable"] = kept;
  if (!at_probe.empty()) out.metadata["fit_kept_at_probe"] = at_probe;
  save_profile(out, o.output);
  print(fmt::format("\nWrote {} (model variant {}).\n", o.output, to_string(r.variant)));
  if (!o.calibration.empty()) {
    std::vector<std::string> match = o.match;
    Calibration cal = to_calibration(r, samples.front().workload, samples.front().backend, match, error);
    cal.metadata["fit_stores"] = stores;
    cal.metadata["fit_rounds_combine"] = std::string(to_string(merged.combine));
    save_calibration(cal, o.calibration);
    result["calibration"] = o.calibration;
    print(fmt::format("Wrote {}: {} {} on {} ({} parameters; carry it to another machine with `dtflop predict "
                      "--machine target.json --calibration {}`).\n",
                      o.calibration, cal.workload, cal.backend, hardware_class(cal.fitted_on, uses_gpu(cal)),
                      cal.factors.size(), o.calibration));
  }
  if (o.json) fmt::print("{}\n", result.dump(2));
}

}  // namespace

void add_calibrate_command(CLI::App& root) {
  auto* app = root.add_subcommand(
      "calibrate",
      "Fit the model's bandwidths, rates, latencies and launch overhead to measured samples (Ceres, "
      "relative residuals, robust loss), with 95% intervals, a comparison with the probed profile, and "
      "the model variant chosen by k-fold cross-validation. Writes the fitted profile.");
  auto o = std::make_shared<CalibrateOptions>();
  app->add_option("--store,-s", o->stores, "Sample store(s) written by `dtflop sweep` (repeatable)")->required();
  app->add_option("--machine,-m", o->machine, "Probed machine profile: start values and the comparison")
      ->required()
      ->check(CLI::ExistingFile);
  app->add_option("--output,-o", o->output, "Fitted profile to write (written only when the fit succeeds)")
      ->required();
  app->add_option("--write-calibration", o->calibration,
                  "Also write the backend's calibration: its fitted parameters as factors of the probed ones, to "
                  "carry to another machine's probe profile (one workload and backend; docs/portability.md)");
  app->add_option("--variant", o->variant, variant_names(", ") + ", or all (choose by cross-validation)")
      ->capture_default_str();
  app->add_flag("--json", o->json, "Print the fit's result as JSON instead of tables");
  app->add_option("--folds", o->folds, "Folds of the cross-validation")->capture_default_str()->check(number_in(2, 1000, true));
  app->add_option("--match", o->match, "Only samples whose key contains this text, e.g. host-memory=pinned (repeatable: all must match)");
  app->add_option("--backend", o->backends, "Fit only samples of these backends (repeatable)");
  app->add_option("--loss", o->loss, "Robust loss: huber, cauchy or none")->capture_default_str();
  app->add_option("--loss-scale", o->loss_scale, "Relative residual where the robust loss bends")
      ->check(number_in(1e-6, 100))
      ->capture_default_str();
  app->add_option("--flag-ratio", o->flag_ratio, "Flag a fitted value this many times off the probed one")
      ->check(number_in(1, 1e6))
      ->capture_default_str();
  app->add_option("--prior", o->prior,
                  "Keep each probed parameter near its probe: log(fitted / probed) taken as normal with this "
                  "standard deviation, weighed against the samples' scatter (0: no prior; docs/calibration.md, Prior)")
      ->check(number_in(0, 100))
      ->capture_default_str();
  app->add_flag("--total-only", o->total_only, "Fit totals only, not the measured components");
  app->add_flag("--accept-bounds", o->accept_bounds,
                "Write the fit even when a parameter ended on its physical bound (otherwise exit status 1, nothing "
                "written; docs/calibration.md, Bounds)");
  app->add_option("--seed", o->seed, "Seed of the fold assignment")->capture_default_str()->check(number_in(0, std::numeric_limits<std::uint64_t>::max(), true));
  app->add_option("--rounds-combine", o->rounds_combine,
                  "How the rounds of a configuration (sweep --rounds) give its time: fastest (the fastest round's "
                  "median: interference only adds time), p25 (the rounds' lower quartile) or median (docs/calibration.md)")
      ->capture_default_str();
  app->callback([o] { run(*o); });
}

}  // namespace dtflop::cli
