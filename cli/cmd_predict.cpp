// `dtflop predict`: cost counts of a workload and, given a machine profile, the DTFLOP
// model's per-component time breakdown and the real-time check (eq. 3.1).
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include <fmt/format.h>

#include "cli/command.hpp"
#include "cli/model_tables.hpp"
#include "cli/table.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/predict.hpp"
#include "model/units.hpp"

namespace dtflop::cli {
namespace {

struct PredictOptions {
  std::string machine;
  std::string deadline;
  std::string variant = "extended";
  bool json = false;
};

void run(const PredictOptions& o, const PredictTarget& target, const CountsFn& fn) {
  const auto variant = variant_from_string(o.variant);
  if (!variant)
    throw InputError(fmt::format("--variant '{}' is unknown; use {}", o.variant, variant_names()));
  std::optional<double> deadline;
  if (!o.deadline.empty()) deadline = parse_duration(o.deadline, "--deadline");
  if (deadline && o.machine.empty())
    throw InputError("--deadline needs a machine profile to predict against; add --machine "
                     "machine.json (try docs/examples/h200.json)");

  MachineProfile profile;
  if (!o.machine.empty()) profile = load_profile(o.machine);
  const CountsResult r = fn(o.machine.empty() ? nullptr : &profile);
  nlohmann::json out = {{"workload", target.name},
                        {"description", r.description},
                        {"parameters", r.parameters},
                        {"counts", to_json(r.counts)}};
  std::optional<Prediction> pred;
  if (!o.machine.empty()) {
    pred = predict(profile, r.counts, *variant);
    out["machine"] = {{"file", o.machine},
                      {"cpu_model", profile.identity.cpu_model},
                      {"gpu_name", profile.identity.gpu_name}};
    out["prediction"] = to_json(*pred);
    if (deadline) {
      out["deadline"] = *deadline;
      out["meets_deadline"] = meets_deadline(*pred, *deadline);
      out["slack"] = *deadline - pred->total;
    }
  }
  if (o.json) {
    fmt::print("{}\n", out.dump(2));
    return;
  }
  fmt::print("{}\n\nCost counts per step:\n", r.description);
  print_counts(r.counts);
  if (!pred) {
    fmt::print("\n(no --machine given: counts only. Add --machine machine.json for the time "
               "breakdown, e.g. --machine docs/examples/h200.json)\n");
    return;
  }
  fmt::print("\nPredicted time per step on {}{} (model variant: {}):\n",
             profile.identity.gpu_name.empty() ? profile.identity.cpu_model : profile.identity.gpu_name,
             profile.identity.measured_at.empty() ? "" : ", profiled " + profile.identity.measured_at,
             to_string(*variant));
  print_prediction(*pred);
  if (deadline) {
    const bool ok = meets_deadline(*pred, *deadline);
    fmt::print("\nDeadline dt_p = {}: {} (dt = {}, {} {})\n", format_duration(*deadline),
               ok ? "MET" : "MISSED", format_duration(pred->total),
               format_duration(std::abs(*deadline - pred->total)), ok ? "to spare" : "over");
  }
}

Registrar reg(20, [](CLI::App& root) {
  auto* app = root.add_subcommand(
      "predict",
      "Print a workload's cost counts and, with --machine, the DTFLOP model's predicted time "
      "per step, component by component, and whether it meets a deadline.");
  auto opts = std::make_shared<PredictOptions>();
  app->add_option("--machine,-m", opts->machine, "Machine profile (JSON) written by `dtflop probe`")
      ->check(CLI::ExistingFile);
  app->add_option("--deadline", opts->deadline, "Real-time deadline dt_p, e.g. 1ms or 250us");
  app->add_option("--variant", opts->variant, "Model variant: " + variant_names(", ") + " (docs/model.md)")
      ->capture_default_str();
  app->add_flag("--json", opts->json, "Print JSON instead of tables");
  // An unknown workload name is rejected by the parser as an unexpected argument, named in
  // its one-line message; no name at all is caught here.
  app->callback([app] {
    if (!app->get_subcommands().empty()) return;
    std::string known;
    for (const auto& t : predict_targets()) known += (known.empty() ? "" : ", ") + t.name;
    throw InputError(fmt::format("name the workload to predict: {}", known));
  });
  for (const auto& target : predict_targets()) {
    auto* sub = app->add_subcommand(target.name, target.description);
    sub->fallthrough();
    auto fn = std::make_shared<CountsFn>(target.setup(*sub));
    const PredictTarget* t = &target;
    sub->callback([opts, fn, t] { run(*opts, *t, *fn); });
  }
});

}  // namespace
}  // namespace dtflop::cli
