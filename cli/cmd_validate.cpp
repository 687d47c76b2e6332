// `dtflop validate`: predicted against measured on held-out samples, per component and total,
// mean and maximum error like the seed's Tables 5.2-5.3, with the worst samples named.
#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "calibrate/machine.hpp"
#include "calibrate/rounds.hpp"
#include "calibrate/store.hpp"
#include "calibrate/validate.hpp"
#include "cli/command.hpp"
#include "workloads/workload.hpp"
#include "cli/workload_cli.hpp"
#include "cli/table.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/units.hpp"
#include "model/calibration.hpp"
#include "model/uncertainty.hpp"

namespace dtflop::cli {
namespace {

namespace fs = std::filesystem;
using namespace dtflop::calib;

struct ValidateOptions {
  std::vector<std::string> stores;
  std::string machine;
  std::string calibration;       // applied to --machine (a probe profile)
  std::string record;            // --record-error: the calibration with its measured transfer error
  std::string variant;
  std::vector<std::string> backends;
  std::vector<std::string> match;  // sample keys must contain each
  bool by_plan = false;
  double target_mean = 3;
  double target_max = 8;
  int worst = 5;
  bool strict = false;
  bool json = false;
  std::string rounds_combine;  // empty: the fitted profile's (metadata.fit_rounds_combine), else median
};

const char* component_label(Component c) {
  switch (c) {
    case Component::total: return "total";
    case Component::CG: return "dt_CG host->device";
    case Component::GC: return "dt_GC device->host";
    case Component::G: return "dt_G  kernels";
    case Component::C: return "dt_C  CPU";
  }
  return "?";
}

nlohmann::json stats_json(const ErrorStats& e) {
  return {{"n", e.n},           {"mean_abs_s", e.mean_abs}, {"max_abs_s", e.max_abs}, {"mean_rel", e.mean_rel},
          {"max_rel", e.max_rel}, {"bias", e.bias},         {"worst", e.worst}};
}

// The configuration in the workload's own words ("1000x1000 k33x33"); the key where the sample's
// parameters are not (or no longer) a configuration of a known workload.
std::string params_text(const Sample& s) {
  try {
    const workload::Workload& w = workload::find(s.workload);
    return w.label(w.validate(s.parameters, w.backend(s.backend)));
  } catch (const std::exception&) {
    return s.key;
  }
}

int run(const ValidateOptions& o) {
  if (o.stores.empty()) throw InputError("name at least one --store of held-out samples");
  if (!(o.target_mean > 0) || !(o.target_max > 0)) throw InputError("--target-mean and --target-max are percentages > 0");
  if (!o.record.empty() && o.calibration.empty())
    throw InputError("--record-error writes a calibration with the error measured here; name it with --calibration");
  MachineProfile profile = load_profile(o.machine);
  std::optional<Calibration> calibration;
  std::optional<BasisError> calibration_basis;
  if (!o.calibration.empty()) {
    check_output(o.record, {o.calibration, o.machine});
    calibration = load_calibration(o.calibration);
    Applied a = apply_calibration(*calibration, profile);
    for (const auto& n : a.notes) fmt::print(stderr, "dtflop: note: {}\n", n);
    profile = std::move(a.profile);
    calibration_basis = basis_of(*calibration, a.basis,
                                 workload::find(calibration->workload).backend(calibration->backend).transfer_error());
  }
  Variant variant = Variant::extended;
  std::string variant_from = "default";
  if (!o.variant.empty()) {
    auto v = variant_from_string(o.variant);
    if (!v) throw InputError(fmt::format("--variant '{}' is unknown; use {}", o.variant, variant_names()));
    variant = *v;
    variant_from = "--variant";
  } else if (const auto chosen = chosen_variant(profile)) {
    variant = *chosen;
    variant_from = "the profile's fit";
  } else {
    variant_from = "the richest the profile supports";  // a probe profile: see below
  }

  std::vector<Sample> loaded;
  std::string fit_stores;
  if (auto it = profile.metadata.find("fit_stores"); it != profile.metadata.end()) fit_stores = it->second;
  std::vector<std::string> backends = o.backends, match = o.match;
  if (calibration) {  // only the samples the calibration describes
    if (backends.empty()) backends = {calibration->backend};
    for (const auto& m : calibration->match) match.push_back(m);
  }
  LoadedSamples l = load_samples(o.stores, {backends, match});
  for (const auto& w : l.warnings) fmt::print(stderr, "dtflop: warning: {}\n", w);
  loaded = std::move(l.samples);
  // A store the profile was fitted to (its metadata names them as given then) gives no held-out errors.
  std::vector<std::string> fitted_to;
  for (std::size_t at = 0; !fit_stores.empty() && at != std::string::npos;) {
    const std::size_t next = fit_stores.find(';', at);
    fitted_to.push_back(fit_stores.substr(at, next == std::string::npos ? std::string::npos : next - at));
    at = next == std::string::npos ? next : next + 1;
  }
  for (const auto& path : o.stores)
    for (const auto& f : fitted_to) {
      std::error_code ec;
      if (fs::exists(f, ec) && fs::equivalent(f, path, ec)) {
        fmt::print(stderr,
                   "dtflop: warning: '{}' was used to fit this profile, so these errors are not held-out errors\n",
                   path);
        break;
      }
    }
  // The rounds of one configuration (`dtflop sweep --rounds`) become one sample: the median of their medians.
  std::string combine_name = o.rounds_combine;
  if (combine_name.empty()) {
    auto it = profile.metadata.find("fit_rounds_combine");
    combine_name = it != profile.metadata.end() ? it->second : std::string(to_string(kDefaultRoundCombine));
  }
  const MergedRounds merged = merge_rounds(std::move(loaded), parse_round_combine(combine_name));
  for (const auto& w : merged.warnings) fmt::print(stderr, "dtflop: warning: {}\n", w);
  const std::vector<Sample>& samples = merged.samples;
  for (const auto& s : samples) {
    std::string why;
    if (!same_machine(s.machine, profile.identity, &why))
      throw InputError(fmt::format("sample '{}' was measured on another machine ({}) than profile '{}' describes "
                                   "({}): {}. Validate against the profile of the machine that measured it",
                                   s.key, describe(s.machine), o.machine, describe(profile.identity), why));
  }

  // A probe profile names no variant: predict with the one the samples' backends declare for their
  // code (workload::Backend::model_variant; extended where they differ), or the richest simpler one
  // the profile supports for all of them, as `predict` falls back (a profile of older probes has no B_GS, L_atomic).
  if (o.variant.empty() && !chosen_variant(profile)) {
    std::optional<Variant> declared;
    bool alike = true;
    for (const auto& s : samples) {
      const Variant v = workload::find(s.workload).backend(s.backend).model_variant();
      alike = alike && (!declared || *declared == v);
      declared = v;
    }
    if (declared && alike) {
      variant = *declared;
      variant_from = "the one the backend declares for its code";
    }
    const Variant wanted = variant;
    std::vector<Param> missing;
    for (const auto& s : samples) {
      std::vector<Param> m;
      const Variant v = richest_supported_variant(profile, s.counts, variant, &m);
      if (v != variant) {
        variant = v;
        missing = m;
      }
    }
    if (!missing.empty()) fmt::print(stderr, "dtflop: note: {}\n", fallback_note(wanted, variant, missing));
  }
  if (calibration)
    for (const auto& s : samples)
      if (s.workload != calibration->workload || s.backend != calibration->backend)
        throw InputError(fmt::format("sample '{}' is not of {} on {}, which calibration '{}' describes; select the "
                                     "samples with --backend and --match",
                                     s.key, calibration->workload, calibration->backend, o.calibration));

  const Validation v = validate(samples, profile, variant);
  // How often the 90% interval each prediction states holds the measured time, and the error of
  // this basis as a figure a calibration can carry.
  int inside = 0, scored = 0;
  ErrorFigure measured_error;
  std::map<std::string, int> bases;
  double sum_log2 = 0;
  for (const auto& s : samples) {
    const Stats* st = s.find(Component::total);
    if (!st || !(st->median > 0)) continue;
    const Prediction p = predict(profile, s.counts, variant);
    const BasisError b = calibration_basis
                             ? *calibration_basis
                             : basis_of(profile, s.counts, variant,
                                        workload::find(s.workload).backend(s.backend).probe_only_error());
    const Interval iv = interval_of(p, profile, s.counts, b);
    ++scored;
    bases[std::string(to_string(b.basis))] += 1;
    if (st->median >= iv.lo && st->median <= iv.hi) ++inside;
    const double rel = std::abs(p.total - st->median) / st->median;
    measured_error.mean_rel += rel;
    measured_error.max_rel = std::max(measured_error.max_rel, rel);
    if (p.total > 0) sum_log2 += std::pow(std::log(p.total / st->median), 2);
  }
  if (scored > 0) {
    measured_error.samples = scored;
    measured_error.mean_rel /= scored;
    measured_error.rms_log = std::sqrt(sum_log2 / scored);
  }
  std::string basis_names;
  for (const auto& [b, n] : bases) basis_names += fmt::format("{}{} {}", basis_names.empty() ? "" : ", ", n, b);
  const double tmean = o.target_mean / 100, tmax = o.target_max / 100;
  std::vector<std::string> groups = {"all"};
  for (const auto& [g, comps] : v.groups) {
    if (g == "all") continue;
    const bool is_plan = g.find(" / ") != std::string::npos;
    if (!is_plan || o.by_plan) groups.push_back(g);
  }
  if (v.groups.size() <= 3) groups = {"all"};  // one backend, one plan: the rest repeats "all"

  if (!o.json)
    fmt::print("Samples: {}{}.\n", merged.summary(), merged.how());
  bool all_met = true;
  nlohmann::json out = {{"machine", o.machine},        {"variant", to_string(variant)},
                        {"samples", samples.size()},   {"targets", {{"mean_rel", tmean}, {"max_rel", tmax}}},
                        {"configurations", samples.size()}, {"stored_samples", merged.input},
                        {"rounds", {{"min", merged.min_rounds}, {"max", merged.max_rounds}, {"combine", to_string(merged.combine)}}},
                        {"groups", nlohmann::json::object()}};
  for (const auto& g : groups) {
    const auto& comps = v.groups.at(g);
    nlohmann::json gj = nlohmann::json::object();
    for (const auto& [c, e] : comps) gj[std::string(to_string(c))] = stats_json(e);
    const auto& tot = comps.at(Component::total);
    const bool met = tot.mean_rel <= tmean && tot.max_rel <= tmax;
    all_met = all_met && met;
    gj["total_target_met"] = met;
    out["groups"][g] = gj;
    if (o.json) continue;
    fmt::print("\n{} ({} samples, model variant {} from {}):\n", g, tot.n, to_string(variant), variant_from);
    Table t({"component", "n", "mean abs error", "mean rel", "max abs error", "max rel", "bias"}, "lrrrrrr");
    for (Component c : all_components()) {
      auto it = comps.find(c);
      if (it == comps.end()) continue;
      const auto& e = it->second;
      t.row({component_label(c), std::to_string(e.n), format_duration(e.mean_abs), fmt::format("{:.2f}%", 100 * e.mean_rel),
             format_duration(e.max_abs), fmt::format("{:.2f}%", 100 * e.max_rel), fmt::format("{:+.2f}%", 100 * e.bias)});
    }
    fmt::print("{}", t.str());
    fmt::print("total: mean {:.2f}% (target <= {:.0f}%) {}, max {:.2f}% (target <= {:.0f}%) {}\n", 100 * tot.mean_rel,
               o.target_mean, tot.mean_rel <= tmean ? "MET" : "MISSED", 100 * tot.max_rel, o.target_max,
               tot.max_rel <= tmax ? "MET" : "MISSED");
  }

  // The worst samples, with the component that misses most: where the model fails, and why.
  std::vector<const SampleError*> rows;
  for (const auto& r : v.rows) rows.push_back(&r);
  std::sort(rows.begin(), rows.end(), [](auto* a, auto* b) {
    return std::abs(a->rel(Component::total)) > std::abs(b->rel(Component::total));
  });
  nlohmann::json worst = nlohmann::json::array();
  const int n_worst = std::min<int>(o.worst, static_cast<int>(rows.size()));
  Table t({"backend", "configuration", "measured/step", "predicted/step", "total error", "largest component error"},
          "llrrrl");
  for (int i = 0; i < n_worst; ++i) {
    const auto& r = *rows[i];
    Component wc = Component::total;
    for (const auto& [c, pm] : r.per_step)
      if (c != Component::total && std::abs(r.rel(c)) > std::abs(r.rel(wc))) wc = c;
    const auto& tot = r.per_step.at(Component::total);
    t.row({r.sample->backend, params_text(*r.sample), format_duration(tot.second), format_duration(tot.first),
           fmt::format("{:+.2f}%", 100 * r.rel(Component::total)),
           wc == Component::total ? "-" : fmt::format("{} {:+.1f}%", to_string(wc), 100 * r.rel(wc))});
    worst.push_back({{"key", r.sample->key}, {"total_rel", r.rel(Component::total)}});
  }
  out["worst"] = worst;
  out["interval90"] = {{"inside", inside}, {"scored", scored}, {"coverage", scored ? double(inside) / scored : 0.0},
                       {"bases", bases}};
  out["error"] = to_json(measured_error);
  if (calibration) out["calibration"] = o.calibration;
  if (o.json) {
    fmt::print("{}\n", out.dump(2));
  } else if (n_worst > 0) {
    fmt::print("\nWorst {} samples by total error:\n{}", n_worst, t.str());
  }
  if (!o.json && scored > 0)
    fmt::print("\nThe predictions' 90% intervals ({}) hold {} of {} measured totals ({:.1f}%; honest intervals hold "
               "about 90%).\n",
               basis_names, inside, scored, 100.0 * inside / scored);
  if (!o.record.empty()) {
    Calibration c = *calibration;
    c.transfer_error = measured_error;
    c.transfer_error->how = fmt::format("held-out samples of {} ({}), variant {}", o.stores.front(),
                                        describe(profile.identity), to_string(variant));
    c.transfer_measured_on = describe(profile.identity);
    save_calibration(c, o.record);
    if (!o.json)
      fmt::print("Wrote {}: the calibration with the error measured here (rms log {:.3f}), which predictions "
                 "carried to other machines now state.\n",
                 o.record, measured_error.rms_log);
  }
  return o.strict && !all_met ? 3 : 0;
}

}  // namespace

void add_validate_command(CLI::App& root) {
  auto* app = root.add_subcommand(
      "validate",
      "Compare a fitted profile's predictions with held-out samples: per component and total, mean and "
      "maximum absolute and relative error (like the seed's Tables 5.2-5.3), against the targets.");
  auto o = std::make_shared<ValidateOptions>();
  app->add_option("--store,-s", o->stores, "Held-out sample store(s) (repeatable)")->required();
  app->add_option("--machine,-m", o->machine,
                  "Fitted machine profile (`dtflop calibrate -o`), or a probe profile (with --calibration, or to "
                  "measure probe-only predictions)")
      ->required()
      ->check(CLI::ExistingFile);
  app->add_option("--calibration", o->calibration,
                  "Backend calibration to apply to --machine (then a probe profile): validates a calibration "
                  "carried to this machine (docs/portability.md)")
      ->check(CLI::ExistingFile);
  app->add_option("--record-error", o->record,
                  "With --calibration: write the calibration, with the error measured here as its transfer error, "
                  "to this new file");
  app->add_option("--variant", o->variant, "Model variant (default: the one the fit chose)");
  app->add_option("--match", o->match, "Only samples whose key contains this text, e.g. host-memory=pinned (repeatable: all must match)");
  app->add_option("--backend", o->backends, "Only samples of these backends (repeatable)");
  app->add_flag("--by-plan", o->by_plan, "Also break the errors down by sweep plan");
  app->add_option("--target-mean", o->target_mean, "Target for the mean relative error of the total [%]")
      ->capture_default_str()
      ->check(number_in(1e-9, 1e6));
  app->add_option("--target-max", o->target_max, "Target for the maximum relative error of the total [%]")
      ->capture_default_str()
      ->check(number_in(1e-9, 1e6));
  app->add_option("--worst", o->worst, "Show this many worst samples")->capture_default_str()->check(number_in(0, 1000000, true));
  app->add_flag("--strict", o->strict, "Exit with status 3 when a target is missed");
  app->add_flag("--json", o->json, "Print JSON instead of tables");
  app->add_option("--rounds-combine", o->rounds_combine,
                  "How the rounds of a configuration give its time: fastest, p25 or median (default: what the fit "
                  "used, from the profile; else fastest)");
  app->callback([o] {
    if (run(*o) != 0) set_exit_status(kExitMissed);  // --strict and a target missed; the tables say which
  });
}

}  // namespace dtflop::cli
