#include "cli/workload_cli.hpp"

#include <charconv>
#include <cmath>
#include <cstdint>
#include <filesystem>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/units.hpp"

namespace dtflop::cli {

std::shared_ptr<WorkloadArgs> add_workload_options(CLI::App& app, const workload::Workload& w,
                                                   const std::string& default_backend) {
  auto a = std::make_shared<WorkloadArgs>();
  a->workload = &w;
  a->app = &app;
  a->backend = default_backend;
  std::string backends;
  for (const auto& b : w.backends())
    backends += fmt::format("\n  {}{}: {}", b->name(), b->needs_gpu() ? " (GPU)" : "", b->info().description);
  auto* opt = app.add_option("--backend,-b", a->backend,
                             "Backend" + std::string(default_backend.empty() ? " (required unless --tuned names it)" : "") +
                                 ":" + backends);
  if (!default_backend.empty()) opt->capture_default_str();
  app.add_option("--tuned", a->tuned,
                 "The configuration `dtflop tune -o tuned.json` chose (its backend and parameters; options given "
                 "beside it override them)")
      ->check(CLI::ExistingFile);
  for (const auto& p : w.params()) {
    std::string help = p.help;
    if (!p.fallback.is_null())
      help += fmt::format(" [default: {}]", p.fallback.is_string() ? p.fallback.get<std::string>() : p.fallback.dump());
    if (!p.backends.empty()) {
      std::string only;
      for (const auto& b : p.backends) only += (only.empty() ? "" : ", ") + b;
      help += " (" + only + " only)";
    }
    app.add_option_function<std::string>(
        "--" + p.name, [a, name = p.name](const std::string& v) { a->values[name] = v; }, help);
  }
  return a;
}

void add_workload_subcommands(CLI::App& verb, const std::function<void(const WorkloadArgs&)>& action,
                              const std::function<std::string(const workload::Workload&)>& describe) {
  // An unknown workload is rejected by the parser as an unexpected argument, named in its message;
  // no workload at all is caught here.
  CLI::App* app = &verb;
  verb.callback([app] {
    if (app->get_subcommands().empty())
      throw InputError(fmt::format("name the workload to {}: {} (e.g. `dtflop {} rbe --help`)", app->get_name(),
                                   workload::names(), app->get_name()));
  });
  for (const workload::Workload* w : workload::all()) {
    auto* sub = verb.add_subcommand(std::string(w->name()), describe ? describe(*w) : std::string(w->description()));
    sub->fallthrough();
    auto a = add_workload_options(*sub, *w);
    sub->callback([action, a] { action(*a); });
  }
}

CLI::Validator number_in(long double lo, long double hi, bool whole) {
  auto range = [lo, hi, whole] {
    if (whole)
      return fmt::format("a whole number in [{}, {}]", static_cast<std::int64_t>(lo),
                         static_cast<std::uint64_t>(hi));
    return fmt::format("a finite number in [{}, {}]", static_cast<double>(lo), static_cast<double>(hi));
  };
  return CLI::Validator(
      [lo, hi, whole, range](std::string& text) -> std::string {
        long double v = 0;
        bool ok = false;
        const char* b = text.data();
        const char* e = b + text.size();
        if (whole) {
          if (!text.empty() && text[0] == '-') {
            std::int64_t i = 0;
            const auto r = std::from_chars(b, e, i);
            ok = r.ec == std::errc() && r.ptr == e;
            v = static_cast<long double>(i);
          } else {
            std::uint64_t u = 0;
            const auto r = std::from_chars(b, e, u);
            ok = r.ec == std::errc() && r.ptr == e;
            v = static_cast<long double>(u);
          }
        } else {
          double d = 0;
          const auto r = std::from_chars(b, e, d);
          ok = r.ec == std::errc() && r.ptr == e && std::isfinite(d);
          v = d;
        }
        if (!ok || v < lo || v > hi) return fmt::format("'{}' is not {}", text.substr(0, 40), range());
        return {};
      },
      range());
}

void add_measure_options(CLI::App& app, calib::MeasureSettings& settings, bool& no_cupti) {
  app.add_option("--steps", settings.steps, "Steps (frames) per repetition (default: the workload's for the backend)")
      ->check(number_in(1, std::int64_t{1} << 30, true));
  app.add_option("--reps", settings.repetitions, "Timed repetitions (default: the workload's for the backend)")
      ->check(number_in(2, 100000, true));
  app.add_option("--warmup", settings.warmup, "Untimed repetitions first (default: the workload's for the backend)")
      ->check(number_in(0, 100000, true));
  app.add_flag("--no-cupti", no_cupti, "Time device work with host clocks only");
}

Chosen choose(const WorkloadArgs& a) {
  const workload::Workload& w = *a.workload;
  nlohmann::json given = nlohmann::json::object();
  std::string backend = a.backend;
  if (!a.tuned.empty()) {
    const std::string what = fmt::format("--tuned '{}'", a.tuned);
    const nlohmann::json t = parse_json_limited(read_file_limited(a.tuned, what, kMaxJsonFileBytes), what);
    if (!t.is_object() || t.value("schema", "") != "dtflop.tuned" || !t.contains("workload") ||
        !t.contains("backend") || !t.contains("config") || !t["config"].is_object() || !t["backend"].is_string())
      throw InputError(fmt::format("{} is not a result of `dtflop tune -o` (schema dtflop.tuned with workload, backend "
                                   "and config); give the file tune wrote",
                                   what));
    if (t["workload"] != w.name())
      throw InputError(fmt::format("{} is a configuration of {}, not {}: run it with `dtflop run {} --tuned {}`", what,
                                   t["workload"].dump(), w.name(), t["workload"].get<std::string>(), a.tuned));
    if (!backend.empty() && backend != t["backend"].get<std::string>())
      throw InputError(fmt::format("{} chose backend {}, and --backend says {}: drop --backend, or drop --tuned", what,
                                   t["backend"].get<std::string>(), backend));
    backend = t["backend"].get<std::string>();
    given = t["config"];
  }
  if (backend.empty())
    throw InputError(fmt::format("name the backend with --backend ({}), or give --tuned tuned.json", w.backend_names()));
  const workload::Backend& b = w.backend(backend);
  for (const auto& [name, text] : a.values) given[name] = text;
  return {&b, w.validate(given, b)};
}

void add_result_options(CLI::App& app, ResultArgs& args) {
  app.add_flag("--json", args.json, "Print JSON instead of tables");
  app.add_option("--output,-o", args.output,
                 "Also write the JSON result to this file (replaced only if it is a regular file)");
}

void add_predict_options(CLI::App& app, PredictArgs& args) {
  app.add_option("--machine,-m", args.machine, "Machine profile (JSON) written by `dtflop probe` or `dtflop calibrate`")
      ->check(CLI::ExistingFile);
  app.add_option("--calibration", args.calibration,
                 "Backend calibration (`dtflop calibrate --write-calibration`) to apply to --machine, a probe profile: "
                 "how to predict a machine the workload never ran on (docs/portability.md)")
      ->check(CLI::ExistingFile);
  app.add_option("--variant", args.variant,
                 "Model variant: " + variant_names(", ") +
                     " (default: the one the profile's calibration chose, else extended; docs/model.md)");
  app.add_option("--deadline", args.deadline,
                 "Real-time deadline dt_p per step, e.g. 1ms or 250us, judged against the prediction's 90% interval "
                 "(exit status 3 when missed, 4 when the interval straddles it)");
}

PredictionProfile prediction_profile(const PredictArgs& args, const workload::Workload& w,
                                     const workload::Backend& b, const workload::Config& config) {
  if (args.machine.empty()) {
    if (!args.calibration.empty())
      throw InputError("--calibration is applied to a machine's probe profile; add --machine target.json (a `dtflop "
                       "probe` profile of the machine to predict)");
    throw InputError("no --machine profile to predict with");
  }
  PredictionProfile out;
  out.probe_only = b.probe_only_error();
  const MachineProfile machine = load_profile(args.machine);
  if (args.calibration.empty()) {
    out.profile = machine;
    return out;
  }
  const Calibration c = load_calibration(args.calibration);
  if (c.workload != w.name() || c.backend != b.name())
    throw InputError(fmt::format("calibration '{}' is of {} on {}, and this predicts {} on {}; use a calibration of "
                                 "this workload and backend (`dtflop calibrate --backend {} --write-calibration ...`)",
                                 args.calibration, c.workload, c.backend, w.name(), b.name(), b.name()));
  const std::string key = w.key(b, config);
  for (const auto& m : c.match)
    if (key.find(m) == std::string::npos)
      throw InputError(fmt::format("calibration '{}' was fitted to samples with '{}' only, and this configuration "
                                   "({}) is not one: use a calibration fitted to such configurations",
                                   args.calibration, m, key));
  Applied a = apply_calibration(c, machine);
  out.profile = std::move(a.profile);
  out.notes = std::move(a.notes);
  out.calibration = basis_of(c, a.basis, b.transfer_error());
  return out;
}

Judged judge(const Predicted& p, const PredictionProfile& pp, const CostCounts& counts, std::optional<double> deadline) {
  Judged j;
  j.basis = pp.calibration ? *pp.calibration : basis_of(pp.profile, counts, p.variant, pp.probe_only);
  j.interval = interval_of(p.prediction, pp.profile, counts, j.basis);
  if (deadline) j.deadline = judge_deadline(p.prediction.total, j.interval, *deadline);
  return j;
}

nlohmann::json uncertainty_json(const Judged& j, std::optional<double> deadline) {
  nlohmann::json out = {{"basis", std::string(to_string(j.basis.basis))},
                        {"basis_error", {{"sigma_log", j.basis.sigma}, {"source", j.basis.source}}},
                        {"interval", {{"level", j.interval.level},
                                      {"lo", j.interval.lo},
                                      {"hi", j.interval.hi},
                                      {"sigma_log", j.interval.sigma},
                                      {"sigma_log_parameters", j.interval.sigma_params},
                                      {"sigma_log_basis", j.interval.sigma_basis}}}};
  if (!j.basis.from.empty()) out["calibrated_on"] = j.basis.from;
  if (deadline && j.deadline)
    out["deadline_verdict"] = {{"deadline", *deadline},
                               {"verdict", std::string(to_string(j.deadline->verdict))},
                               {"probability_met", j.deadline->probability_met}};
  return out;
}

std::string judged_text(const Predicted& p, const Judged& j, std::optional<double> deadline) {
  std::string basis;
  switch (j.basis.basis) {
    case Basis::probe_only: basis = "probe-only: no run of this workload calibrated the parameters"; break;
    case Basis::calibrated: basis = "calibrated on this machine"; break;
    case Basis::transferred: basis = fmt::format("calibration transferred from {}", j.basis.from); break;
  }
  std::string out = fmt::format(
      "{:.0f}% interval: {} .. {} ({}; spread of log time {:.3f} = parameters {:.3f} and {:.3f} from {})\n",
      100 * j.interval.level, format_duration(j.interval.lo), format_duration(j.interval.hi), basis, j.interval.sigma,
      j.interval.sigma_params, j.interval.sigma_basis, j.basis.source);
  if (deadline && j.deadline) {
    const double t = p.prediction.total;
    switch (j.deadline->verdict) {
      case Verdict::met:
        out += fmt::format("Deadline dt_p = {}: MET (dt = {}, {} to spare; met with probability {:.3f})\n",
                           format_duration(*deadline), format_duration(t), format_duration(*deadline - t),
                           j.deadline->probability_met);
        break;
      case Verdict::missed:
        out += fmt::format("Deadline dt_p = {}: MISSED (dt = {}, {} over; met with probability {:.3f})\n",
                           format_duration(*deadline), format_duration(t), format_duration(std::abs(*deadline - t)),
                           j.deadline->probability_met);
        break;
      case Verdict::uncertain:
        out += fmt::format("Deadline dt_p = {}: UNCERTAIN (dt = {}, but the {:.0f}% interval straddles the deadline: "
                           "met with probability {:.2f}); {}\n",
                           format_duration(*deadline), format_duration(t), 100 * j.interval.level,
                           j.deadline->probability_met,
                           j.basis.basis == Basis::calibrated
                               ? "calibrated on this machine already, the interval is its own scatter between runs: "
                                 "measure the configuration (`run --deadline`) or leave that much margin"
                               : "calibrate this backend on a machine of this class (docs/portability.md) to narrow it");
        break;
    }
  }
  return out;
}

int exit_status_of(const DeadlineVerdict& v) {
  switch (v.verdict) {
    case Verdict::met: return 0;
    case Verdict::missed: return kExitMissed;
    case Verdict::uncertain: return kExitUncertain;
  }
  return 0;
}

Variant wanted_variant(const PredictArgs& args, const MachineProfile& profile, const workload::Backend* backend) {
  if (!args.variant.empty()) {
    const auto v = variant_from_string(args.variant);
    if (!v) throw InputError(fmt::format("--variant '{}' is unknown; use {}", args.variant, variant_names()));
    return *v;
  }
  if (const auto chosen = chosen_variant(profile)) return *chosen;
  return backend ? backend->model_variant() : Variant::extended;
}

Predicted predict_with_fallback(const MachineProfile& profile, const CostCounts& counts, Variant wanted) {
  std::vector<Param> missing;
  Predicted r;
  r.variant = richest_supported_variant(profile, counts, wanted, &missing);
  if (r.variant != wanted) r.fallback = fallback_note(wanted, r.variant, missing);
  r.prediction = predict(profile, counts, r.variant);
  return r;
}

std::optional<double> deadline_of(const PredictArgs& args) {
  if (args.deadline.empty()) return std::nullopt;
  const double d = parse_duration(args.deadline, "--deadline");
  if (args.machine.empty())
    throw InputError("--deadline needs a machine profile to predict against; add --machine machine.json (try "
                     "docs/examples/h200.json)");
  return d;
}

void check_output(const std::string& output, const std::vector<std::string>& inputs) {
  if (output.empty()) return;
  namespace fs = std::filesystem;
  std::error_code ec;
  const auto st = fs::symlink_status(output, ec);
  if (ec || !fs::exists(st)) return;
  if (!fs::is_regular_file(st))
    throw InputError(fmt::format("--output '{}' exists and is not a regular file (a link, a device or a folder); "
                                 "name a new file",
                                 output));
  for (const auto& in : inputs)
    if (!in.empty() && fs::exists(in, ec) && fs::equivalent(output, in, ec))
      throw InputError(fmt::format("--output '{}' is the input '{}'; name another file so the input stays", output, in));
}

nlohmann::json machine_json(const std::string& file, const MachineProfile& p) {
  return {{"file", file},
          {"cpu_model", p.identity.cpu_model},
          {"gpu_name", p.identity.gpu_name},
          {"measured_at", p.identity.measured_at}};
}

std::string machine_name(const MachineProfile& p) {
  return p.identity.gpu_name.empty() ? p.identity.cpu_model : p.identity.gpu_name;
}

namespace {
int& status() {
  static int s = 0;
  return s;
}
}  // namespace
void set_exit_status(int s) { status() = s; }
int exit_status() { return status(); }

}  // namespace dtflop::cli
