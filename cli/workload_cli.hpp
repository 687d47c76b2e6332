// What every verb that takes a workload (`predict`, `run`, `sweep`) shares: the workload's
// parameters as command-line options (one spelling everywhere: --grid, --kernel, --host-memory,
// ...), the backend, and a prediction from a machine profile that never fails for want of a
// parameter no probe measures (it falls back to the richest variant the profile supports and
// says so on stderr).
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "calibrate/measure.hpp"
#include "model/calibration.hpp"
#include "model/predict.hpp"
#include "model/uncertainty.hpp"
#include "model/profile.hpp"
#include "workloads/workload.hpp"

namespace dtflop::cli {

struct WorkloadArgs {
  const workload::Workload* workload = nullptr;
  CLI::App* app = nullptr;
  std::string backend;
  std::map<std::string, std::string> values;  // parameter -> text as typed (given ones only count)
  std::string tuned;  // --tuned: a `dtflop tune -o` result naming the backend and configuration
};
// Adds --backend and one option per parameter of `w` to `app`.
std::shared_ptr<WorkloadArgs> add_workload_options(CLI::App& app, const workload::Workload& w,
                                                   const std::string& default_backend = {});

// Adds one sub-command per registered workload to `verb` (its parameters as options, the verb's own
// options before or after it), each calling `action` with its parsed arguments; and refuses the
// verb without a workload, naming the workloads. Every verb that takes a workload is set up so.
// `describe` gives a workload's sub-command its help text (default: the workload's description).
void add_workload_subcommands(CLI::App& verb, const std::function<void(const WorkloadArgs&)>& action,
                              const std::function<std::string(const workload::Workload&)>& describe = {});

// The one check of a number typed on the command line: a CLI11 validator that accepts the text only
// as a finite number in [lo, hi] (a whole one when `whole`), so nan, inf, 1e309, 1.5 for a count and
// 18446744073709551616 for a 64-bit seed are refused with the option's name and its range (exit 2).
CLI::Validator number_in(long double lo, long double hi, bool whole = false);

// --steps, --reps, --warmup and --no-cupti: how `run` and `sweep` measure (calibrate/measure.hpp).
void add_measure_options(CLI::App& app, calib::MeasureSettings& settings, bool& no_cupti);

struct Chosen {
  const workload::Backend* backend = nullptr;
  workload::Config config;
};
// The backend and the validated configuration the command line names (defaults for the rest), or
// --tuned's (a `dtflop tune -o` file of this workload; options given beside it override its values).
// Throws InputError for an unknown or missing backend, an option that does not apply to it, a bad
// value, and a tuned file of another workload or backend.
Chosen choose(const WorkloadArgs& args);

// --json and -o: how `predict` and `run` give their result (tables or JSON; JSON also to a file).
struct ResultArgs {
  bool json = false;
  std::string output;
};
void add_result_options(CLI::App& app, ResultArgs& args);

// --machine, --calibration, --variant and --deadline, as `predict` and `run` take them.
struct PredictArgs {
  std::string machine;
  std::string calibration;  // a backend calibration to apply to --machine (model/calibration.hpp)
  std::string variant;   // empty: the variant the profile's calibration chose, else extended
  std::string deadline;
};
void add_predict_options(CLI::App& app, PredictArgs& args);

struct Predicted {
  Variant variant = Variant::extended;
  std::string fallback;   // why `variant` is not the one asked for (empty: it is)
  Prediction prediction;
};

// The profile a prediction uses: --machine's, with --calibration applied when given, and the basis
// of its parameters (probe-only, calibrated here, transferred) with that basis' measured error.
struct PredictionProfile {
  MachineProfile profile;
  std::optional<BasisError> calibration;  // the basis a --calibration gives (else judge() finds it)
  std::optional<BasisError> probe_only;   // the backend's measured probe-only error, if it declares one
  std::vector<std::string> notes;  // for stderr: what a calibration carried as it is
};
// Throws InputError for a calibration of another workload, backend or host memory kind than the
// configuration, a fitted --machine under a calibration, or --calibration without --machine.
PredictionProfile prediction_profile(const PredictArgs& args, const workload::Workload& w,
                                     const workload::Backend& b, const workload::Config& config);

// A prediction with its interval and, given a deadline, the verdict against it.
struct Judged {
  BasisError basis;
  Interval interval;
  std::optional<DeadlineVerdict> deadline;
};
Judged judge(const Predicted& p, const PredictionProfile& pp, const CostCounts& counts,
             std::optional<double> deadline);
// JSON of the basis, interval and verdict (the same figures the tables print).
nlohmann::json uncertainty_json(const Judged& j, std::optional<double> deadline);
// Lines for people: "90% interval 1.2 ms .. 1.9 ms (probe-only: ...)" and the deadline verdict.
std::string judged_text(const Predicted& p, const Judged& j, std::optional<double> deadline);
// The exit status a deadline verdict gives: 0 met, kExitMissed, kExitUncertain.
int exit_status_of(const DeadlineVerdict& v);
// The variant `args` asks for on `profile`: --variant, else the profile's chosen one, else the one
// `backend` declares for its code (a probe-only profile; workload::Backend::model_variant), else
// extended.
Variant wanted_variant(const PredictArgs& args, const MachineProfile& profile,
                       const workload::Backend* backend = nullptr);
// Predicts `counts` on `profile` with the wanted variant, or with the richest simpler one whose
// parameters the profile holds (saying why in `fallback`). Throws MissingParameter only when not
// even the seed variant can be computed (e.g. a GPU backend on a profile without a GPU).
Predicted predict_with_fallback(const MachineProfile& profile, const CostCounts& counts, Variant wanted);
// The deadline of --deadline (seconds), if given. Throws InputError for a bad duration, and for a
// deadline without --machine (there is nothing to judge it against).
std::optional<double> deadline_of(const PredictArgs& args);

// Checks, before any work, that `output` can take a result: not a link, device file or folder, and
// not the same file as an input. Throws InputError saying which.
void check_output(const std::string& output, const std::vector<std::string>& inputs);

// JSON of a machine profile's identity for reports.
nlohmann::json machine_json(const std::string& file, const MachineProfile& profile);
// "NVIDIA H200" or the CPU model.
std::string machine_name(const MachineProfile& profile);

// Exit statuses (docs/cli.md): 0 done, 1 failed while running, 2 bad input, 3 a deadline or
// target missed, 4 a deadline neither met nor missed within the prediction's interval. A command
// sets 3 or 4 through this; main() returns it.
inline constexpr int kExitFailure = 1;
inline constexpr int kExitBadInput = 2;
inline constexpr int kExitMissed = 3;
inline constexpr int kExitUncertain = 4;  // a deadline the prediction's interval straddles
void set_exit_status(int status);
int exit_status();

}  // namespace dtflop::cli
