// `dtflop predict WORKLOAD --backend NAME [parameters]`: a configuration's cost counts and, given a
// machine profile, the DTFLOP model's per-component time breakdown and the real-time check
// (eq. 3.1). The same path for every workload of the registry.
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include <fmt/format.h>

#include "cli/command.hpp"
#include "cli/model_tables.hpp"
#include "cli/workload_cli.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/units.hpp"

namespace dtflop::cli {
namespace {

struct PredictCommon {
  PredictArgs predict;
  ResultArgs result;
};

void run(const PredictCommon& o, const WorkloadArgs& a) {
  const workload::Workload& w = *a.workload;
  const Chosen c = choose(a);
  check_output(o.result.output, {o.predict.machine});
  const std::optional<double> deadline = deadline_of(o.predict);
  std::optional<MachineProfile> profile;
  if (!o.predict.machine.empty()) profile = load_profile(o.predict.machine);
  const CostCounts counts = c.backend->counts(c.config, profile ? &profile->identity : nullptr);
  const std::string description = w.describe(*c.backend, c.config);

  nlohmann::json out = {{"workload", std::string(w.name())},
                        {"backend", c.backend->name()},
                        {"description", description},
                        {"parameters", c.config},
                        {"counts", to_json(counts)}};
  std::optional<Predicted> pred;
  if (profile) {
    pred = predict_with_fallback(*profile, counts, wanted_variant(o.predict, *profile));
    if (!pred->fallback.empty()) fmt::print(stderr, "dtflop: note: {}\n", pred->fallback);
    out["machine"] = machine_json(o.predict.machine, *profile);
    out["variant"] = std::string(to_string(pred->variant));
    if (!pred->fallback.empty()) out["variant_fallback"] = pred->fallback;
    out["prediction"] = to_json(pred->prediction);
    if (deadline) {
      out["deadline"] = *deadline;
      out["meets_deadline"] = meets_deadline(pred->prediction, *deadline);
      out["slack"] = *deadline - pred->prediction.total;
    }
  }
  if (deadline && !meets_deadline(pred->prediction, *deadline)) set_exit_status(kExitMissed);
  if (!o.result.output.empty()) write_file_atomically(o.result.output, out.dump(2) + "\n");
  if (o.result.json) {
    fmt::print("{}\n", out.dump(2));
    return;
  }
  fmt::print("{}\n\nCost counts per {}:\n", description, w.step_name());
  print_counts(counts);
  if (!pred) {
    fmt::print("\n(no --machine given: counts only. Add --machine machine.json for the time breakdown, e.g. "
               "--machine docs/examples/h200.json)\n");
    return;
  }
  fmt::print("\nPredicted time per {} on {}{} (model variant: {}):\n", w.step_name(), machine_name(*profile),
             profile->identity.measured_at.empty() ? "" : ", profiled " + profile->identity.measured_at,
             to_string(pred->variant));
  print_prediction(pred->prediction);
  if (deadline) {
    const bool ok = meets_deadline(pred->prediction, *deadline);
    fmt::print("\nDeadline dt_p = {}: {} (dt = {}, {} {})\n", format_duration(*deadline), ok ? "MET" : "MISSED",
               format_duration(pred->prediction.total), format_duration(std::abs(*deadline - pred->prediction.total)),
               ok ? "to spare" : "over");
  }
}

}  // namespace

void add_predict_command(CLI::App& root) {
  auto* app = root.add_subcommand(
      "predict",
      "Print a workload configuration's cost counts and, with --machine, the DTFLOP model's predicted time per step, "
      "component by component, and whether it meets a deadline (exit status 3 when it does not).");
  auto o = std::make_shared<PredictCommon>();
  add_predict_options(*app, o->predict);
  add_result_options(*app, o->result);
  add_workload_subcommands(*app, [o](const WorkloadArgs& a) { run(*o, a); });
}

}  // namespace dtflop::cli
