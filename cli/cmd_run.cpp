// `dtflop run WORKLOAD --backend NAME [parameters]`: measures one configuration by the shared
// protocol (calibrate/measure.hpp: warm-up, CUPTI-traced and untraced repetitions, host clocks)
// and prints the measured time per step and its components beside the cost counts and, with
// --machine, the model's prediction of each component. The same path for every workload.
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include <fmt/format.h>

#include "calibrate/machine.hpp"
#include "calibrate/measure.hpp"
#include "cli/command.hpp"
#include "cli/model_tables.hpp"
#include "cli/table.hpp"
#include "cli/workload_cli.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/units.hpp"

namespace dtflop::cli {
namespace {

using namespace dtflop::calib;

struct RunCommon {
  PredictArgs predict;
  MeasureSettings measure;
  bool no_cupti = false;
  ResultArgs result;
  std::string estimate;  // --estimate FILE
  std::string timeline;  // --timeline FILE
};

void run(const RunCommon& o, const WorkloadArgs& a) {
  const workload::Workload& w = *a.workload;
  const Chosen c = choose(a);
  check_output(o.result.output, {o.predict.machine, o.predict.calibration});
  if (!o.estimate.empty()) {
    if (!w.has_estimate())
      throw InputError(fmt::format("{}: --estimate is not available for this workload; leave it out", w.name()));
    check_output(o.estimate, {o.predict.machine, o.predict.calibration, o.result.output});
  }
  if (!o.timeline.empty()) {
    if (!c.backend->needs_gpu())
      throw InputError(fmt::format("--timeline traces a GPU backend's copies, kernels and runtime calls; {} runs on "
                                   "the CPU: leave --timeline out",
                                   c.backend->name()));
    if (o.no_cupti)
      throw InputError("--timeline is made of CUPTI's traced repetitions, which --no-cupti turns off: leave one of "
                       "them out");
    check_output(o.timeline, {o.predict.machine, o.predict.calibration, o.result.output, o.estimate});
  }
  const std::optional<double> deadline = deadline_of(o.predict);
  // Everything that can be wrong with the profile (and a calibration) is found before anything is measured.
  std::optional<PredictionProfile> pp;
  std::optional<Variant> wanted;
  if (!o.predict.machine.empty() || !o.predict.calibration.empty()) {
    pp = prediction_profile(o.predict, w, *c.backend, c.config);
    for (const auto& n : pp->notes) fmt::print(stderr, "dtflop: note: {}\n", n);
    wanted = wanted_variant(o.predict, pp->profile, c.backend);
    (void)predict_with_fallback(pp->profile, c.backend->counts(c.config, &pp->profile.identity), *wanted);
  }
  const MachineProfile* profile = pp ? &pp->profile : nullptr;
  Protocol protocol = open_protocol(w, *c.backend, o.measure, o.no_cupti);
  if (!o.timeline.empty() && !protocol.profiler)
    throw InputError(fmt::format("--timeline needs CUPTI's tracing, which is not available here ({}); leave "
                                 "--timeline out",
                                 protocol.no_profiler));
  const MachineIdentity here = this_machine();
  const MeasureSettings& st = protocol.settings;
  fmt::print(stderr, "dtflop run {}: {} on {}: {} warm-up, {}{} repetitions of {} {}{}\n", w.name(),
             w.describe(*c.backend, c.config), describe(here), st.warmup, st.repetitions,
             protocol.profiler ? fmt::format(" CUPTI-traced and {} untraced", st.repetitions) : std::string(),
             st.steps, w.step_name(), st.steps == 1 ? "" : "s");
  nlohmann::json timeline;
  const Sample s = measure(w, *c.backend, c.config, protocol, here, w.key(*c.backend, c.config), "run",
                           o.timeline.empty() ? nullptr : &timeline);
  const double steps = static_cast<double>(s.steps);

  std::optional<Predicted> pred;
  std::optional<Judged> judged;
  if (profile) {
    pred = predict_with_fallback(*profile, s.counts, *wanted);
    judged = judge(*pred, *pp, s.counts, std::nullopt);
  }
  if (pred && !pred->fallback.empty()) fmt::print(stderr, "dtflop: note: {}\n", pred->fallback);
  for (const char* k : {"counts_mismatch", "work_mismatch"})
    if (s.detail.contains(k))
      fmt::print(stderr, "dtflop: warning: the declared counts disagree with what ran ({}): {}\n", k,
                 s.detail[k].get<std::string>());

  const Stats& total = *s.find(Component::total);
  nlohmann::json measured = nlohmann::json::object();
  for (const auto& [comp, stats] : s.components)
    measured[std::string(to_string(comp))] = {{"median", stats.median / steps},
                                              {"p25", stats.p25 / steps},
                                              {"p75", stats.p75 / steps}};
  // What ran here, a step of it (not the profile's machine: its threads and multiprocessors may differ).
  const CostCounts per_step = c.backend->counts(c.config, &here);
  nlohmann::json out = {{"workload", std::string(w.name())},
                        {"backend", c.backend->name()},
                        {"description", w.describe(*c.backend, c.config)},
                        {"parameters", c.config},
                        {"machine_measured", to_json(here)},
                        {"steps", s.steps},
                        {"repetitions", s.repetitions()},
                        {"warmup", s.warmup},
                        {"timing", {{"source", std::string(to_string(s.source))}, {"note", s.timing_note}}},
                        {"measured_per_step", measured},
                        {"counts_per_step", to_json(per_step)},
                        {"counts_per_repetition", to_json(s.counts)},
                        {"detail", s.detail}};
  if (pred) {
    out["machine"] = machine_json(o.predict.machine, *profile);
    out["variant"] = std::string(to_string(pred->variant));
    if (!pred->fallback.empty()) out["variant_fallback"] = pred->fallback;
    out["prediction_per_repetition"] = to_json(pred->prediction);
    out["predicted_over_measured"] = pred->prediction.total / total.median;
    out["uncertainty"] = uncertainty_json(*judged, std::nullopt);  // interval per repetition, as the prediction
    out["measured_within_interval"] = total.median >= judged->interval.lo && total.median <= judged->interval.hi;
    if (deadline) {
      out["deadline"] = *deadline;
      out["meets_deadline"] = total.median / steps <= *deadline;
      out["predicted_meets_deadline"] = pred->prediction.total / steps <= *deadline;
    }
  }
  // The deadline is judged on what was measured.
  if (deadline && total.median / steps > *deadline) set_exit_status(kExitMissed);
  if (!o.result.output.empty()) write_file_atomically(o.result.output, out.dump(2) + "\n");
  if (!o.timeline.empty()) {
    write_file_atomically(o.timeline, timeline.dump() + "\n");
    const auto& sum = timeline["dtflop_summary"];
    fmt::print(stderr,
               "dtflop run {}: timeline of the last traced repetition written to {} (open it in ui.perfetto.dev or "
               "chrome://tracing): device busy {} of {}, idle {} in {} gaps between its operations\n",
               w.name(), o.timeline, format_duration(sum["device_busy_seconds"].get<double>()),
               format_duration(sum["window_seconds"].get<double>()),
               format_duration(sum["device_gap_seconds"].get<double>()), sum["device_gaps"].get<int>());
  }
  if (!o.estimate.empty()) {
    w.write_estimate(*c.backend, c.config, st.steps, o.estimate);
    fmt::print(stderr, "dtflop run {}: estimate per step of one more run of {} {}{} written to {}\n", w.name(), st.steps,
               w.step_name(), st.steps == 1 ? "" : "s", o.estimate);
  }
  if (o.result.json) {
    fmt::print("{}\n", out.dump(2));
    return;
  }
  fmt::print("{}\n", w.describe(*c.backend, c.config));
  fmt::print("\nMeasured per {} (median of {} repetitions of {} {}{}; {}):\n", w.step_name(), s.repetitions(), s.steps,
             w.step_name(), s.steps == 1 ? "" : "s", to_string(s.source));
  std::vector<std::string> head = {"component", "measured", "p25..p75"};
  if (pred) head.insert(head.end(), {"predicted", "pred/meas"});
  Table t(head);
  for (Component comp : all_components()) {
    const Stats* m = s.find(comp);
    if (!m) continue;
    std::vector<std::string> row = {std::string(to_string(comp)), format_duration(m->median / steps),
                                    fmt::format("{}..{}", format_duration(m->p25 / steps), format_duration(m->p75 / steps))};
    if (pred) {
      const double p = predicted(pred->prediction, comp);
      row.push_back(format_duration(p / steps));
      row.push_back(m->median > 0 ? fmt::format("{:.2f}", p / m->median) : "-");
    }
    t.row(row);
  }
  fmt::print("{}", t.str());
  if (!s.timing_note.empty()) fmt::print("({})\n", s.timing_note);
  fmt::print("\nCost counts per {}:\n", w.step_name());
  print_counts(per_step);
  if (!pred) {
    fmt::print("\n(add --machine machine.json for the model's prediction of each component)\n");
  } else {
    fmt::print("\nPredicted by the DTFLOP model ({} variant) on {}, per repetition of {} {}{}:\n",
               to_string(pred->variant), machine_name(*profile), s.steps, w.step_name(), s.steps == 1 ? "" : "s");
    print_prediction(pred->prediction);
    fmt::print("predicted / measured: {:.2f}\n", pred->prediction.total / total.median);
    fmt::print("{}", judged_text(*pred, *judged, std::nullopt));
  }
  if (deadline) {
    const bool ok = total.median / steps <= *deadline;
    fmt::print("\nDeadline dt_p = {}: {} (measured {} per {})\n", format_duration(*deadline), ok ? "MET" : "MISSED",
               format_duration(total.median / steps), w.step_name());
  }
}

}  // namespace

void add_run_command(CLI::App& root) {
  auto* app = root.add_subcommand(
      "run", "Measure one configuration of a workload on one backend (warm-up, timed repetitions, CUPTI on a GPU) "
             "and print the measured time per step and its components, the cost counts and, with --machine, the "
             "model's prediction beside each.");
  auto o = std::make_shared<RunCommon>();
  add_predict_options(*app, o->predict);
  add_measure_options(*app, o->measure, o->no_cupti);
  add_result_options(*app, o->result);
  app->add_option("--estimate", o->estimate,
                  "rbe: also run --steps steps once more, one at a time, and write the estimate after each (mean, "
                  "covariance, MAP cell, entropy; step 0 is the prior) to FILE: JSON if it ends in .json, else CSV")
      ->type_name("FILE");
  app->add_option("--timeline", o->timeline,
                  "GPU backends: write the last CUPTI-traced repetition's copies, kernels and runtime API calls to "
                  "FILE in the Trace Event Format (ui.perfetto.dev, chrome://tracing), with a summary of the "
                  "device's busy and idle time (docs/cli.md)")
      ->type_name("FILE");
  add_workload_subcommands(*app, [o](const WorkloadArgs& a) { run(*o, a); });
}

}  // namespace dtflop::cli
