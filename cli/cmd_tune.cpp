// `dtflop tune --scenario S.yaml`: which configuration of a workload meets the scenario's deadline
// with the accuracy it needs, on this machine (ranked by the model, the most promising measured
// through the sample store) or, with --no-measure, on a machine not at hand (ranked by prediction
// alone, each with its interval). docs/tune.md.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "calibrate/machine.hpp"
#include "calibrate/measure.hpp"
#include "calibrate/store.hpp"
#include "cli/command.hpp"
#include "cli/table.hpp"
#include "cli/workload_cli.hpp"
#include "model/calibration.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/units.hpp"
#include "model/uncertainty.hpp"
#include "tune/tuner.hpp"

namespace dtflop::cli {
namespace {

using nlohmann::json;

inline constexpr const char* kTunedSchema = "dtflop.tuned";

struct TuneOptions {
  std::string scenario;
  std::string machine;
  std::vector<std::string> calibrations;
  std::string strategy = "model";
  std::int64_t budget = -1;  // -1: the strategy's default
  bool no_measure = false;
  std::string store;
  std::string output;
  bool json = false;
  bool quiet = false;
  std::uint64_t seed = 1;
  int patience = 6;
  calib::MeasureSettings measure;
  bool no_cupti = false;
  std::string replay;       // budgets, e.g. "5,10,20,50": measure everything, then replay the strategies
  int replay_seeds = 10;
  std::string space_csv;    // the measured space, for peers (benchmarks/tune)
};

// A calibration, applied once to the machine's profile, and what it matches.
struct LoadedCalibration {
  std::string file;
  Calibration calibration;
  Applied applied;
  BasisError basis;
};

std::vector<std::size_t> parse_budgets(const std::string& text) {
  std::vector<std::size_t> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    char* end = nullptr;
    const long long v = std::strtoll(item.c_str(), &end, 10);
    if (item.empty() || *end || v < 1 || v > 100000)
      throw InputError(fmt::format("--replay: '{}' is not a budget in 1..100000 (e.g. --replay 5,10,20,50)", item));
    out.push_back(static_cast<std::size_t>(v));
  }
  if (out.empty()) throw InputError("--replay lists no budget (e.g. --replay 5,10,20,50)");
  return out;
}

std::string csv_cell(const json& v) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_array() && v.size() == 2) return fmt::format("{}x{}", v[0].dump(), v[1].dump());
  return v.dump();
}

// ---- Inputs -------------------------------------------------------------------------------------

// The scenario, the workload, the machine's profile and the calibrations applied to it, checked
// before anything is enumerated or measured.
struct Inputs {
  tune::Scenario s;
  const workload::Workload* w = nullptr;
  std::string machine_file;
  MachineProfile machine;
  MachineIdentity here;
  std::vector<LoadedCalibration> calibrations;
  std::vector<std::string> files;  // every input file (no output may replace one)
};

Inputs load_inputs(const TuneOptions& o) {
  Inputs in;
  in.s = tune::load_scenario(o.scenario);
  in.w = &workload::find(in.s.workload);
  in.machine_file = o.machine.empty() ? in.s.machine : o.machine;
  if (in.machine_file.empty())
    throw InputError(fmt::format("scenario '{}' names no machine: give --machine profile.json (`dtflop probe` or "
                                 "`dtflop calibrate` writes one)",
                                 o.scenario));
  in.files = {o.scenario, in.machine_file};
  in.machine = load_profile(in.machine_file);
  in.here = calib::this_machine();
  std::string why_other;
  if (!o.no_measure && !same_machine(in.machine.identity, in.here, &why_other))
    throw InputError(fmt::format("--machine '{}' describes {}, not this machine ({}): measuring here needs this "
                                 "machine's profile; add --no-measure to rank for that machine by prediction alone",
                                 in.machine_file, describe(in.machine.identity), why_other));
  std::vector<std::string> calibration_files = in.s.calibrations;
  calibration_files.insert(calibration_files.end(), o.calibrations.begin(), o.calibrations.end());
  for (const auto& f : calibration_files) {
    LoadedCalibration lc;
    lc.file = f;
    lc.calibration = load_calibration(f);
    if (lc.calibration.workload != in.w->name())
      throw InputError(fmt::format("calibration '{}' is of {}, and the scenario tunes {}: use a calibration of {}", f,
                                   lc.calibration.workload, in.w->name(), in.w->name()));
    lc.applied = apply_calibration(lc.calibration, in.machine);
    lc.basis = basis_of(lc.calibration, lc.applied.basis, in.w->backend(lc.calibration.backend).transfer_error());
    in.calibrations.push_back(std::move(lc));
    in.files.push_back(f);
  }
  return in;
}

// Why `b` cannot run where the tuning happens: here when measuring, else on the profile's machine.
std::string why_unavailable(const Inputs& in, bool no_measure, const workload::Backend& b) {
  if (!no_measure) return b.unavailable();
  if (b.needs_gpu() && in.machine.identity.gpu_name.empty())
    return fmt::format("backend {} needs a GPU and the machine profile '{}' has none", b.name(), in.machine_file);
  return {};
}

// A configuration's prediction: the profile with the calibration of its backend (and host memory
// kind) applied where one was given, its interval, and the deadline verdict at the scenario's
// confidence.
tune::Predicted predict_one(const Inputs& in, const workload::Backend& b, const workload::Config& c) {
  const std::string key = in.w->key(b, c);
  const LoadedCalibration* cal = nullptr;
  for (const auto& lc : in.calibrations) {
    if (lc.calibration.backend != b.name()) continue;
    bool match = true;
    for (const auto& m : lc.calibration.match) match = match && key.find(m) != std::string::npos;
    if (match) cal = &lc;
  }
  const MachineProfile& profile = cal ? cal->applied.profile : in.machine;
  const CostCounts counts = b.counts(c, &in.machine.identity);
  const Variant wanted = cal ? cal->calibration.variant : chosen_variant(profile).value_or(b.model_variant());
  const Predicted p = predict_with_fallback(profile, counts, wanted);
  const BasisError basis = cal ? cal->basis : basis_of(profile, counts, p.variant, b.probe_only_error());
  const Interval iv = interval_of(p.prediction, profile, counts, basis);
  tune::Predicted out;
  out.seconds = p.prediction.total;
  out.lo = iv.lo;
  out.hi = iv.hi;
  out.sigma = iv.sigma;
  out.basis = std::string(to_string(basis.basis));
  out.note = p.fallback;
  if (in.s.deadline) {
    const DeadlineVerdict v = judge_deadline(p.prediction.total, iv, *in.s.deadline, in.s.confidence);
    out.p_met = v.probability_met;
    out.verdict = std::string(to_string(v.verdict));
  }
  return out;
}

// ---- Measuring through the store ------------------------------------------------------------

// Seconds per step of a configuration: from the store when it holds the configuration (measured
// on this machine: a store of another is refused when opened), else measured by the protocol of
// its backend and appended to the store before it is used. A replay of another machine's store
// (--replay with --no-measure) reads the samples of the profile's machine and measures nothing.
class StoreMeasurer {
 public:
  StoreMeasurer(const Inputs& in, const TuneOptions& o, std::string store) : in_(in), o_(o), store_(std::move(store)) {
    if (o.no_measure && !std::filesystem::is_regular_file(store_))
      throw InputError(fmt::format("store '{}' is not a file: --replay with --no-measure replays a store measured on "
                                   "the machine of --machine (decompress a .xz store first)",
                                   store_));
    const calib::StoreContents contents = calib::read_store(store_);
    for (const auto& warning : contents.warnings) fmt::print(stderr, "dtflop: warning: {}\n", warning);
    const MachineIdentity& owner = o.no_measure ? in.machine.identity : in.here;
    for (const auto& sm : contents.samples) {
      std::string why;
      if (!same_machine(sm.machine, owner, &why))
        throw InputError(fmt::format("store '{}' holds samples of {} ({}); {}: use another --store", store_,
                                     describe(sm.machine), why,
                                     o.no_measure ? fmt::format("the replay is of the machine of '{}'", in.machine_file)
                                                  : std::string("a tuning measures this machine")));
      const Stats* total = sm.find(calib::Component::total);
      if (sm.round == 1 && total && sm.steps > 0) stored_[sm.key] = total->median / static_cast<double>(sm.steps);
    }
  }
  tune::Measurement operator()(const tune::Candidate& c) {
    if (auto it = stored_.find(c.key); it != stored_.end()) return {it->second, true};
    if (o_.no_measure) throw std::logic_error("tune: a replay of a store asked to measure " + c.label);
    const workload::Workload& w = *in_.w;
    const std::string plan = "tune:" + in_.s.name;
    auto pit = protocols_.find(c.backend->name());
    if (pit == protocols_.end()) {
      pit = protocols_.emplace(c.backend->name(), calib::open_protocol(w, *c.backend, o_.measure, o_.no_cupti)).first;
      // The first configuration a process measures on a backend runs slower (clocks, first
      // allocations, module loading): once, unrecorded.
      calib::measure(w, *c.backend, c.config, pit->second, in_.here, c.key, plan);
    }
    if (!writer_) writer_ = std::make_unique<calib::StoreWriter>(store_, warnings_);
    const calib::Sample sm = calib::measure(w, *c.backend, c.config, pit->second, in_.here, c.key, plan);
    writer_->append(sm);
    ++measured_now_;
    const double seconds = sm.find(calib::Component::total)->median / static_cast<double>(sm.steps);
    stored_[c.key] = seconds;
    return {seconds, false};
  }
  bool holds(const std::string& key) const { return stored_.count(key) > 0; }
  int measured_now() const { return measured_now_; }
  const std::string& store() const { return store_; }
  const std::vector<std::string>& warnings() const { return warnings_; }

 private:
  const Inputs& in_;
  const TuneOptions& o_;
  std::string store_;
  std::map<std::string, double> stored_;  // key -> seconds per step
  std::map<std::string, calib::Protocol> protocols_;
  std::unique_ptr<calib::StoreWriter> writer_;
  std::vector<std::string> warnings_;
  int measured_now_ = 0;
};

// ---- The outcome --------------------------------------------------------------------------

struct Outcome {
  bool by_measure = true;
  const tune::Space* space = nullptr;
  tune::Search search;
  int measured_now = 0;
  std::string store;
  std::string strategy;
  std::vector<tune::ReplayRow> replayed;
  std::optional<std::size_t> chosen;
  std::vector<std::size_t> ranked;        // fastest first (measured ones, or every one by prediction)
  std::vector<std::size_t> front;         // Pareto front, fastest first
  std::optional<std::size_t> most_accurate;  // the front's most accurate within the deadline
  bool meets = false;
  double time_of(std::size_t i) const {
    const auto& x = space->valid[i];
    return by_measure ? *x.measured : x.predicted.seconds;
  }
};

void decide(Outcome& r, const tune::Scenario& s) {
  const auto& c = r.space->valid;
  r.chosen = r.by_measure ? tune::fastest_measured(c) : tune::fastest_predicted(c, s.deadline.has_value());
  for (std::size_t i = 0; i < c.size(); ++i)
    if (!r.by_measure || c[i].measured) r.ranked.push_back(i);
  std::sort(r.ranked.begin(), r.ranked.end(), [&](std::size_t a, std::size_t b) { return r.time_of(a) < r.time_of(b); });
  r.front = tune::pareto_front(c, r.by_measure);
  r.meets = r.chosen && s.deadline &&
            (r.by_measure ? *c[*r.chosen].measured <= *s.deadline : c[*r.chosen].predicted.verdict == "met");
  if (s.deadline)
    for (std::size_t i : r.front)
      if (r.time_of(i) <= *s.deadline) r.most_accurate = i;  // the front is fastest first
}

json candidate_json(const Outcome& r, const tune::Scenario& s, std::size_t i) {
  const auto& x = r.space->valid[i];
  json j = {{"backend", x.backend->name()},
            {"config", x.config},
            {"key", x.key},
            {"label", x.label},
            {"predicted", {{"seconds", x.predicted.seconds},
                           {"interval90", {x.predicted.lo, x.predicted.hi}},
                           {"basis", x.predicted.basis}}},
            {"accuracy", {{"error", x.accuracy.error}, {"figures", x.accuracy.figures}}}};
  if (x.predicted.p_met) {
    j["predicted"]["verdict"] = x.predicted.verdict;
    j["predicted"]["probability_met"] = *x.predicted.p_met;
  }
  if (!x.predicted.note.empty()) j["predicted"]["note"] = x.predicted.note;
  if (x.measured) j["measured_seconds"] = *x.measured;
  if (s.deadline) j["margin_seconds"] = *s.deadline - r.time_of(i);
  return j;
}

json result_json(const Outcome& r, const Inputs& in, const tune::AccuracyModel& accuracy, int replay_seeds) {
  const tune::Scenario& s = in.s;
  const tune::Space& space = *r.space;
  const auto& c = space.valid;
  json out = {{"schema", kTunedSchema},
              {"version", 1},
              {"scenario", s.name},
              {"workload", std::string(in.w->name())},
              {"machine", describe(in.machine.identity)},
              {"strategy", r.strategy},
              {"verdicts", r.by_measure ? "measured" : "predicted"},
              {"accuracy_figure", {{"name", accuracy.error_name()}, {"unit", accuracy.error_unit()}}},
              {"accuracy_needs", accuracy.needs()},
              {"space", {{"enumerated", space.enumerated}, {"valid", c.size()}, {"removed", space.removed},
                         {"removed_example", space.example}}},
              {"measured", r.search.order.size() - static_cast<std::size_t>(r.search.failed)},
              {"failed", r.search.failed},
              {"measured_now", r.measured_now},
              {"stop_reason", r.by_measure ? r.search.stop_reason : "not measured"}};
  if (s.deadline) out["deadline_seconds"] = *s.deadline;
  if (!r.store.empty()) out["store"] = r.store;
  json failures = json::array();
  for (const auto& x : c)
    if (!x.failure.empty()) failures.push_back({{"label", x.label}, {"key", x.key}, {"failure", x.failure}});
  out["failures"] = failures;
  if (r.chosen) {
    out["chosen"] = candidate_json(r, s, *r.chosen);
    // What `dtflop run --tuned` takes: the backend and the configuration.
    out["backend"] = c[*r.chosen].backend->name();
    out["config"] = c[*r.chosen].config;
  }
  out["meets_deadline"] = s.deadline ? json(r.meets) : json(nullptr);
  json runners = json::array();
  for (std::size_t k = 1; k < r.ranked.size() && k <= 5; ++k) runners.push_back(candidate_json(r, s, r.ranked[k]));
  out["runners_up"] = runners;
  json pf = json::array();
  for (std::size_t i : r.front) pf.push_back(candidate_json(r, s, i));
  out["pareto_front"] = pf;
  if (r.most_accurate) out["most_accurate_meeting_deadline"] = candidate_json(r, s, *r.most_accurate);
  // Every configuration the verdicts rest on (measured ones; by prediction, every valid one), for
  // `dtflop report tuning`.
  json all = json::array();
  for (std::size_t i : r.ranked) {
    const auto& x = c[i];
    json j = {{"label", x.label},
              {"backend", x.backend->name()},
              {"predicted_seconds", x.predicted.seconds},
              {"interval90", {x.predicted.lo, x.predicted.hi}},
              {"accuracy_error", x.accuracy.error}};
    if (x.measured) j["measured_seconds"] = *x.measured;
    all.push_back(std::move(j));
  }
  out["configurations"] = all;
  if (!r.replayed.empty()) {
    json rows = json::array();
    for (const auto& x : r.replayed)
      rows.push_back({{"strategy", x.strategy}, {"budget", x.budget}, {"median_fraction_of_optimum", x.median},
                      {"fractions", x.fractions}, {"median_measured", x.measured_median}});
    out["replay"] = {{"seeds", replay_seeds}, {"rows", rows}};
  }
  return out;
}

// Every valid configuration with its parameters, prediction, accuracy and measured time.
std::string space_csv(const workload::Workload& w, const tune::Space& space) {
  std::string csv = "key,backend";
  for (const auto& p : w.params()) csv += "," + p.name;
  csv += ",predicted_s,interval_lo_s,interval_hi_s,accuracy_error,measured_s\n";
  for (const auto& x : space.valid) {
    csv += fmt::format("\"{}\",{}", x.key, x.backend->name());
    for (const auto& p : w.params()) csv += "," + (x.config.contains(p.name) ? csv_cell(x.config[p.name]) : std::string());
    csv += fmt::format(",{:.6e},{:.6e},{:.6e},{:.6g},{}\n", x.predicted.seconds, x.predicted.lo, x.predicted.hi,
                       x.accuracy.error, x.measured ? fmt::format("{:.6e}", *x.measured) : "");
  }
  return csv;
}

void print_result(const Outcome& r, const Inputs& in, const tune::AccuracyModel& accuracy, const TuneOptions& o) {
  const tune::Scenario& s = in.s;
  const tune::Space& space = *r.space;
  const auto& c = space.valid;
  auto acc = [&](std::size_t i) {
    return accuracy.error_name() == "none" ? std::string("-")
                                           : fmt::format("{:.3g} {}", c[i].accuracy.error, accuracy.error_unit());
  };
  fmt::print("scenario {}: {} on {}\n", s.name, in.w->name(), describe(in.machine.identity));
  fmt::print("space: {} enumerated, {} valid", space.enumerated, c.size());
  for (const auto& [k, n] : space.removed) fmt::print("; {} removed by {}", n, k);
  fmt::print("\n");
  for (const auto& [k, e] : space.example) fmt::print("  {}: e.g. {}\n", k, e);
  if (r.by_measure) {
    const std::size_t ok = r.search.order.size() - static_cast<std::size_t>(r.search.failed);
    fmt::print("measured {} of {} valid ({} now, {} from the store '{}'), strategy {}: {}\n", ok, c.size(),
               r.measured_now, ok - static_cast<std::size_t>(r.measured_now), r.store, r.strategy, r.search.stop_reason);
    for (const auto& x : c)
      if (!x.failure.empty()) fmt::print("  failed: {}: {}\n", x.label, x.failure);
  } else {
    fmt::print("not measured: every verdict below is a prediction ({} basis){}\n",
               r.chosen ? c[*r.chosen].predicted.basis : "-",
               in.calibrations.empty() ? "" : fmt::format(", with {} calibration(s)", in.calibrations.size()));
  }
  if (r.chosen) {
    const auto& x = c[*r.chosen];
    fmt::print("\nchosen: {}\n  {}\n", x.label, in.w->describe(*x.backend, x.config));
    fmt::print("  predicted {} (90% interval {} .. {}, {})\n", format_duration(x.predicted.seconds),
               format_duration(x.predicted.lo), format_duration(x.predicted.hi), x.predicted.basis);
    if (x.measured) fmt::print("  measured  {}\n", format_duration(*x.measured));
    if (s.deadline)
      fmt::print("  deadline  {}: {} (margin {}{})\n", format_duration(*s.deadline), r.meets ? "met" : "NOT met",
                 format_duration(std::abs(*s.deadline - r.time_of(*r.chosen))),
                 *s.deadline >= r.time_of(*r.chosen) ? "" : " over");
    fmt::print("  accuracy  {} = {}; {}\n", accuracy.error_name(), acc(*r.chosen), x.accuracy.figures.dump());
    if (s.deadline && !r.meets)
      fmt::print("nothing {} meets the deadline of {}: the configuration above comes closest\n",
                 r.by_measure ? "measured" : "predicted with confidence", format_duration(*s.deadline));
  }
  Table t({"runner-up", r.by_measure ? "measured" : "predicted", "90% interval", accuracy.error_name()});
  for (std::size_t k = 1; k < r.ranked.size() && k <= 5; ++k) {
    const auto& x = c[r.ranked[k]];
    t.row({x.label, format_duration(r.time_of(r.ranked[k])),
           fmt::format("{} .. {}", format_duration(x.predicted.lo), format_duration(x.predicted.hi)), acc(r.ranked[k])});
  }
  if (r.ranked.size() > 1) fmt::print("\n{}", t.str());
  Table p({"Pareto front: configuration", r.by_measure ? "measured" : "predicted", accuracy.error_name(),
           s.deadline ? "deadline" : ""});
  for (std::size_t i : r.front)
    p.row({c[i].label, format_duration(r.time_of(i)), acc(i),
           s.deadline ? (r.time_of(i) <= *s.deadline ? "met" : "missed") : ""});
  fmt::print("\n{}", p.str());
  if (r.most_accurate && accuracy.error_name() != "none")
    fmt::print("most accurate within the deadline: {} ({}, {} {})\n", c[*r.most_accurate].label,
               format_duration(r.time_of(*r.most_accurate)), accuracy.error_name(), acc(*r.most_accurate));
  if (!r.replayed.empty()) {
    Table x({"strategy", "budget", "median fraction of optimum", "min", "median measured"});
    for (const auto& row : r.replayed)
      x.row({row.strategy, fmt::format("{}", row.budget), fmt::format("{:.3f}", row.median),
             fmt::format("{:.3f}", *std::min_element(row.fractions.begin(), row.fractions.end())),
             fmt::format("{:.0f}", row.measured_median)});
    fmt::print("\nreplayed on the {} measured configurations, {} seeds each:\n{}", c.size(), o.replay_seeds, x.str());
  }
  if (!o.output.empty())
    fmt::print("\nwritten: {} (`dtflop run {} --tuned {}` runs the choice)\n", o.output, in.w->name(), o.output);
}

void run(const TuneOptions& o) {
  if (o.budget == 0)
    throw InputError("--budget 0 measures nothing: give a budget of at least 1, or --no-measure to rank by "
                     "prediction alone");
  // --replay with --no-measure: the strategies replayed on a store another machine measured (the
  // machine of --machine), measuring nothing here.
  const bool replay_only = o.no_measure && !o.replay.empty();
  if (replay_only && o.store.empty())
    throw InputError("--replay with --no-measure replays a store measured on the machine of --machine: give it with "
                     "--store");
  const tune::StrategyInfo& strategy_info = tune::find_strategy(o.strategy);
  const std::vector<std::size_t> replay_budgets = o.replay.empty() ? std::vector<std::size_t>{} : parse_budgets(o.replay);
  const Inputs in = load_inputs(o);
  const tune::Scenario& s = in.s;
  const workload::Workload& w = *in.w;
  if (!o.output.empty()) check_output(o.output, in.files);
  if (!o.space_csv.empty()) check_output(o.space_csv, in.files);
  // Backends the scenario names must be able to run where the tuning happens.
  for (const auto& name : s.backends) {
    const std::string why = why_unavailable(in, o.no_measure, w.backend(name));
    if (!why.empty())
      throw InputError(fmt::format("scenario '{}' names backend {}, which cannot run {}: {}; remove it from "
                                   "space.backend, or {}",
                                   o.scenario, name, o.no_measure ? "on the machine of the profile" : "here", why,
                                   o.no_measure ? "give the profile of a machine that runs it (--machine)"
                                                : "tune where it runs, or rank for such a machine with --no-measure"));
  }
  std::optional<StoreMeasurer> measurer;
  if (!o.no_measure || replay_only) measurer.emplace(in, o, o.store.empty() ? s.name + ".samples.jsonl" : o.store);
  std::FILE* progress = o.quiet ? nullptr : stderr;

  const std::unique_ptr<tune::AccuracyModel> accuracy = tune::make_accuracy_model(w.name(), s.accuracy);
  tune::Space space = tune::constrain(
      s, w, *accuracy, [&](const workload::Backend& b) { return why_unavailable(in, o.no_measure, b); },
      [&](const workload::Backend& b, const workload::Config& c) { return predict_one(in, b, c); }, progress);
  if (progress) {
    fmt::print(stderr, "tune: scenario {} ({}), {} on {}{}\n", s.name, o.scenario, w.name(),
               describe(in.machine.identity),
               replay_only       ? " (replayed from the store: nothing measured here)"
               : o.no_measure    ? " (not measured: ranked by prediction alone)"
                                 : "");
    fmt::print(stderr, "tune: {} valid configurations of {} enumerated", space.valid.size(), space.enumerated);
    for (const auto& [c, n] : space.removed) fmt::print(stderr, "; {} removed by {}", n, c);
    fmt::print(stderr, "\n");
  }

  Outcome r;
  r.space = &space;
  r.by_measure = !o.no_measure || replay_only;
  r.strategy = !r.by_measure ? "none (--no-measure)" : replay_budgets.empty() ? o.strategy : "exhaustive";
  if (replay_only) {
    // A store measured before the space grew (a constraint relaxed since) lacks configurations
    // that are valid now: the replay is of the space the store holds, and says what it left out.
    std::vector<tune::Candidate> kept;
    for (auto& c : space.valid) {
      if (measurer->holds(c.key)) {
        kept.push_back(std::move(c));
        continue;
      }
      space.remove("store", fmt::format("{}: not in the store", c.label));
    }
    space.valid = std::move(kept);
    if (space.valid.empty())
      throw InputError(fmt::format("store '{}' holds none of the {} valid configurations: replay the store of this "
                                   "scenario, or run `dtflop tune --replay` on that machine to measure them",
                                   o.store, space.removed["store"]));
    if (space.removed.count("store"))
      fmt::print(stderr,
                 "dtflop: warning: the store '{}' lacks {} of the configurations valid now; the replay is of the {} it "
                 "holds\n",
                 o.store, space.removed["store"], space.valid.size());
  }
  if (measurer) {
    tune::StrategyOptions so;
    so.seed = o.seed;
    so.patience = o.patience;
    const tune::MeasureFn measure = [&](const tune::Candidate& c) { return (*measurer)(c); };
    if (!replay_budgets.empty()) {
      // Everything measured (exhaustive), then every strategy replayed on the stored times.
      auto all = tune::make_exhaustive_strategy(so);
      r.search = tune::search(space, *all, 0, measure, progress);
      r.search.stop_reason = "every valid configuration measured, for the replay";
      r.replayed = tune::replay(space, {"model", "random"}, replay_budgets, o.replay_seeds);
    } else {
      auto strategy = strategy_info.make(so);
      const std::size_t budget = o.budget > 0 ? static_cast<std::size_t>(o.budget) : o.strategy == "exhaustive" ? 0 : 20;
      r.search = tune::search(space, *strategy, budget, measure, progress);
    }
    for (const auto& warning : measurer->warnings()) fmt::print(stderr, "dtflop: warning: {}\n", warning);
    r.measured_now = measurer->measured_now();
    r.store = measurer->store();
  }
  decide(r, s);

  const json out = result_json(r, in, *accuracy, o.replay_seeds);
  if (!o.space_csv.empty()) write_file_atomically(o.space_csv, space_csv(w, space));
  if (!o.output.empty()) write_file_atomically(o.output, out.dump(2) + "\n");
  if (o.json)
    fmt::print("{}\n", out.dump(2));
  else
    print_result(r, in, *accuracy, o);
  if (s.deadline && !r.meets) set_exit_status(kExitMissed);
}

}  // namespace

void add_tune_command(CLI::App& root) {
  auto* app = root.add_subcommand(
      "tune",
      "Choose the configuration of a workload that meets a scenario's deadline with the accuracy it needs: rank the "
      "scenario's space by the model, measure the most promising through the sample store, and report the choice, "
      "its runners-up and the Pareto front of time against accuracy; or, with --no-measure, rank for a machine not "
      "at hand by prediction alone (docs/tune.md)");
  auto o = std::make_shared<TuneOptions>();
  app->add_option("--scenario", o->scenario, "Scenario file (YAML; tune/scenarios/ holds examples)")->required();
  app->add_option("--machine", o->machine, "Machine profile (overrides the scenario's machine)");
  app->add_option("--calibration", o->calibrations,
                  "Backend calibration to apply to the profile (repeatable; added to the scenario's)");
  app->add_option("--strategy", o->strategy, "Search strategy: " + tune::strategy_names())->capture_default_str();
  app->add_option("--budget", o->budget,
                  "Most configurations to measure (default 20; exhaustive: every valid one). Configurations found "
                  "in the store count but cost nothing")
      ->check(number_in(0, 1'000'000, true));
  app->add_flag("--no-measure", o->no_measure,
                "Rank by prediction alone (a machine not at hand: its probe profile plus carried calibrations); "
                "every verdict is a prediction");
  app->add_option("--store,-s", o->store,
                  "Sample store measurements go through (default: <scenario name>.samples.jsonl); a tuning resumes "
                  "from it and reuses a sweep's samples of the same configurations");
  app->add_option("--output,-o", o->output, "Write the result as JSON (`dtflop run --tuned` takes it)");
  app->add_flag("--json", o->json, "Print the result as JSON on stdout");
  app->add_flag("--quiet,-q", o->quiet, "No progress on stderr");
  app->add_option("--seed", o->seed, "Seed of the random strategy")
      ->capture_default_str()
      ->check(number_in(0, std::numeric_limits<std::uint64_t>::max(), true));
  app->add_option("--patience", o->patience,
                  "model: stop after this many measurements in a row that did not improve the best by 1%")
      ->capture_default_str()
      ->check(number_in(1, 1000, true));
  add_measure_options(*app, o->measure, o->no_cupti);
  app->add_option("--replay", o->replay,
                  "Benchmark the strategies: measure every valid configuration, then replay model and random on "
                  "the stored times at these budgets (e.g. 5,10,20,50) and report the fraction of the optimum each "
                  "reached (median over --replay-seeds); with --no-measure and --store, replay a store measured on "
                  "the machine of --machine, measuring nothing");
  app->add_option("--replay-seeds", o->replay_seeds, "Seeds per strategy and budget for --replay")
      ->capture_default_str()
      ->check(number_in(1, 1000, true));
  app->add_option("--space-csv", o->space_csv,
                  "Write every valid configuration with its prediction and measured time as CSV (for peers)");
  app->callback([o] { run(*o); });
}

}  // namespace dtflop::cli
