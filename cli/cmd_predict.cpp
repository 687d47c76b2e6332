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
  check_output(o.result.output, {o.predict.machine, o.predict.calibration});
  const std::optional<double> deadline = deadline_of(o.predict);
  std::optional<PredictionProfile> pp;
  if (!o.predict.machine.empty() || !o.predict.calibration.empty())
    pp = prediction_profile(o.predict, w, *c.backend, c.config);
  const CostCounts counts = c.backend->counts(c.config, pp ? &pp->profile.identity : nullptr);
  const std::string description = w.describe(*c.backend, c.config);

  nlohmann::json out = {{"workload", std::string(w.name())},
                        {"backend", c.backend->name()},
                        {"description", description},
                        {"parameters", c.config},
                        {"counts", to_json(counts)}};
  std::optional<Predicted> pred;
  std::optional<Judged> judged;
  if (pp) {
    for (const auto& n : pp->notes) fmt::print(stderr, "dtflop: note: {}\n", n);
    pred = predict_with_fallback(pp->profile, counts, wanted_variant(o.predict, pp->profile, c.backend));
    if (!pred->fallback.empty()) fmt::print(stderr, "dtflop: note: {}\n", pred->fallback);
    judged = judge(*pred, *pp, counts, deadline);
    out["machine"] = machine_json(o.predict.machine, pp->profile);
    if (!o.predict.calibration.empty()) out["calibration"] = o.predict.calibration;
    out["variant"] = std::string(to_string(pred->variant));
    if (!pred->fallback.empty()) out["variant_fallback"] = pred->fallback;
    out["prediction"] = to_json(pred->prediction);
    out["uncertainty"] = uncertainty_json(*judged, deadline);
    if (deadline) {
      out["deadline"] = *deadline;
      out["meets_deadline"] = judged->deadline->verdict == Verdict::met;
      out["slack"] = *deadline - pred->prediction.total;
    }
  }
  if (judged && judged->deadline) set_exit_status(exit_status_of(*judged->deadline));
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
  const MachineProfile& profile = pp->profile;
  fmt::print("\nPredicted time per {} on {}{} (model variant: {}):\n", w.step_name(), machine_name(profile),
             profile.identity.measured_at.empty() ? "" : ", profiled " + profile.identity.measured_at,
             to_string(pred->variant));
  print_prediction(pred->prediction);
  fmt::print("{}", judged_text(*pred, *judged, deadline));
}

}  // namespace

void add_predict_command(CLI::App& root) {
  auto* app = root.add_subcommand(
      "predict",
      "Print a workload configuration's cost counts and, with --machine, the DTFLOP model's predicted time per step, "
      "component by component, with a 90% interval and how the parameters were obtained (probe-only, calibrated, "
      "transferred with --calibration), and whether it meets a deadline (exit status 3 missed, 4 uncertain).");
  auto o = std::make_shared<PredictCommon>();
  add_predict_options(*app, o->predict);
  add_result_options(*app, o->result);
  add_workload_subcommands(*app, [o](const WorkloadArgs& a) { run(*o, a); });
}

}  // namespace dtflop::cli
