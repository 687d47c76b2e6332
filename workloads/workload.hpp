// The workload contract: what every reference workload (rbe, dct, and any added later) gives
// the verbs that predict, measure, sweep, calibrate and validate it, so that each verb is one
// generic path for every workload.
//
// A Workload owns a typed, named parameter space (ParamSpec: domain, default, which backends it
// applies to, help) and its backends. A configuration (Config) is a JSON object holding every
// parameter of the workload that applies to the backend, validated by Workload::validate(). Its
// JSON form is what the sample store keeps, and its store key is Workload::key().
//
// A Backend declares its exact cost counts for a configuration without a device (counts()), and
// prepares a configuration to be measured (prepare()): the returned Run executes one repetition
// at a time. Every backend is measured through the same protocol (calibrate/measure.hpp: warm-up,
// traced and untraced repetitions, CUPTI check of the declared counts, host clocks for CPU
// parts), so no workload writes its own timing loop.
//
// Adding a workload is adding its files and one line in workloads/registry.cpp; adding a backend
// is adding its class and one line in its workload's backend list. What a caller does:
//   const workload::Workload& w = workload::find("rbe");           // InputError when unknown
//   const workload::Backend& b = w.backend("cuda-resident");        // InputError when unknown
//   workload::Config c = w.validate({{"grid", "1000x1000"}}, b);    // defaults filled, checked
//   CostCounts per_step = b.counts(c, &profile.identity);           // no device needed
//   auto run = b.prepare(c, 10);  run->repeat();                    // needs what b needs
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "cuda/error.hpp"
#include "model/cost_counts.hpp"
#include "model/errors.hpp"
#include "model/predict.hpp"
#include "model/profile.hpp"
#include "model/uncertainty.hpp"

namespace dtflop::workload {

using Config = nlohmann::json;

// ---- Parameter space ----------------------------------------------------------------------

enum class Kind {
  integer,  // a whole number in [min, max]
  real,     // a finite number in [min, max]
  size2,    // "WxH": two whole numbers, each in [min, max]; JSON [W, H]
  choice,   // one of `choices`
  flag,     // true or false
  text,     // free text a backend parses itself (e.g. a block layout); validated by the workload
};
std::string_view to_string(Kind k);

struct ParamSpec {
  std::string name;    // JSON key and store-key field; the command line spells it --name
  Kind kind = Kind::integer;
  std::string help;    // one line for --help
  nlohmann::json fallback;  // the default, in JSON form (null: no default, the user must give it)
  double min = 0, max = 0;  // integer, real, size2
  std::vector<std::string> choices;  // choice
  std::vector<std::string> backends; // the backends it applies to; empty: every backend
  std::string unit;    // printed after values ("px", "dots"); empty: none
  // false: the store key leaves this parameter out while it holds its default. For a parameter
  // added after stores were measured whose default is what those stores' configurations did:
  // their samples (whose parameters lack it; validate() fills the default) keep their keys.
  bool keyed_at_default = true;
  // A choice whose values the counts tell apart (e.g. a weight function's FLOPs, a threshold
  // method's bytes per pixel): predictions of all its values share one bias, so the tuner does
  // not split its groups by it (docs/tune.md). Choice and flag parameters that are not priced
  // split them.
  bool priced = false;
  bool applies_to(std::string_view backend) const;
};

// A GPU backend asked for where no CUDA device can be used (or dtflop was built without CUDA).
using DeviceUnavailable = cuda::Unavailable;

// ---- Measuring ----------------------------------------------------------------------------

// Host-clock seconds of one repetition and of its phases, as the model's components: CG host ->
// device copies, GC device -> host copies, G device work (kernels), C CPU work. A phase the
// backend does not bracket is 0 (the protocol then takes it from CUPTI where there is one).
struct PhaseTimes {
  double wall = 0;
  double CG = 0, GC = 0, G = 0, C = 0;
  // Device work the backend times without bracketing it from the host (CUDA events around the
  // kernels of a graph): the G component where neither G nor CUPTI gives one.
  double G_events = 0;
};

// One configuration prepared on one backend: inputs made, buffers allocated, ready to repeat.
class Run {
 public:
  virtual ~Run() = default;
  // The exact counts of one repetition (steps x a step's counts plus what a repetition does once),
  // declared before the first repetition.
  virtual CostCounts counts() const = 0;
  // Executes one repetition and returns its host-clock times. Throws std::runtime_error when the
  // computation fails (e.g. a belief that lost all its mass).
  virtual PhaseTimes repeat() = 0;
  // After a repetition: where what it did differs from counts() (one line; empty: it agrees).
  // Workloads whose cost depends on the data (DCT: dots found) check their declared counts here.
  virtual std::string check() { return {}; }
  // Informational measurements of the last repetition for the sample's detail (e.g. dots found).
  virtual nlohmann::json detail() const { return nlohmann::json::object(); }
};

// ---- Backends -----------------------------------------------------------------------------

struct BackendInfo {
  std::string name;         // "cpu-seq", "cuda-resident", ...
  std::string description;  // one line
  bool needs_gpu = false;
};

class Backend {
 public:
  explicit Backend(BackendInfo info) : info_(std::move(info)) {}
  virtual ~Backend() = default;
  const BackendInfo& info() const { return info_; }
  const std::string& name() const { return info_.name; }
  bool needs_gpu() const { return info_.needs_gpu; }

  // The model variant that describes this backend's code where no fit has chosen one (a probe-only
  // profile): its phases as separate loops on the host (memory) or copies, kernels and host work
  // one after another on a GPU (latency). Every fit so far chose these (docs/model.md 2.5,
  // docs/PERFORMANCE.md): memory for each CPU backend, latency for each GPU one. A backend whose
  // code overlaps its traffic with its arithmetic overrides it.
  virtual Variant model_variant() const { return needs_gpu() ? Variant::latency : Variant::memory; }
  // The measured error of this backend's probe-only predictions (sigma: the rms of log(measured /
  // predicted) over held-out sets on the machines it was measured on, source: which), where it has
  // been measured with today's probes and counts; none (the default) leaves the interval to
  // kProbeOnlySigma, the widest such error of any backend.
  virtual std::optional<BasisError> probe_only_error() const { return std::nullopt; }
  // The measured error of this backend's calibrations carried to another machine's probe profile
  // (sigma: the largest rms of log(measured / predicted) over held-out sets of a machine the
  // calibration was not fitted on, source: which), where it has been measured; it is added in
  // quadrature to a carried calibration's own error. None (the default) leaves it to kTransferSigma.
  virtual std::optional<BasisError> transfer_error() const { return std::nullopt; }
  // Why this backend cannot run on this machine, one line ending with what to do; empty when it
  // can (the default: a CPU backend always can; GPU backends say whether a CUDA device is usable).
  virtual std::string unavailable() const;
  // Exact counts of one step (RBE) or frame (DCT) of `config`, without a device. `target`: the
  // machine the counts are for when they depend on it (multiprocessors of its GPU), else null
  // (this machine's GPU where there is one, else the backend's documented default).
  virtual CostCounts counts(const Config& config, const MachineIdentity* target) const = 0;
  // Prepares `config` to be measured in repetitions of `steps` steps (frames). Throws InputError
  // for a configuration the backend cannot run and DeviceUnavailable without a device.
  virtual std::unique_ptr<Run> prepare(const Config& config, std::int64_t steps) const = 0;

 private:
  BackendInfo info_;
};

// ---- Plans --------------------------------------------------------------------------------

// Configurations to sweep, with what they cover.
struct PlanConfigs {
  std::string name;
  std::string description;
  std::vector<Config> configs;  // each valid for the backend the plan was made for
};

// How a backend is measured when the user does not say: steps per repetition, repetitions and
// warm-up runs (the protocol times each repetition as one sample of the total).
struct ProtocolDefaults {
  std::int64_t steps = 1;
  int repetitions = 5;
  int warmup = 1;
};

// ---- Workloads ----------------------------------------------------------------------------

class Workload {
 public:
  virtual ~Workload() = default;
  virtual std::string_view name() const = 0;         // "rbe", "dct"
  virtual std::string_view description() const = 0;  // one line
  virtual std::string_view step_name() const = 0;    // what one step is: "step", "frame"
  virtual const std::vector<ParamSpec>& params() const = 0;
  // Every backend, in the order --help lists them.
  virtual const std::vector<std::unique_ptr<Backend>>& backends() const = 0;

  // Throws InputError naming the known backends when `name` is unknown.
  const Backend& backend(std::string_view name) const;
  std::string backend_names(std::string_view separator = ", ") const;
  const ParamSpec* find_param(std::string_view name) const;

  // The configuration `given` on `backend`: every applicable parameter, the given value (its
  // JSON form, or a string as typed on the command line: "1000x1000", "12", "true") or else the
  // default. Throws InputError (one line: the parameter, what was wrong, what to do) for an unknown
  // parameter, one that does not apply to the backend, a value outside its domain, or a
  // combination the workload's constraints reject.
  Config validate(const nlohmann::json& given, const Backend& backend) const;
  // The store key: workload, backend and every parameter of the configuration, in spec order
  // (a parameter that is not keyed_at_default is left out while it holds its default).
  std::string key(const Backend& backend, const Config& config) const;
  // A short text for progress lines and tables ("1000x1000 k33x33").
  virtual std::string label(const Config& config) const = 0;
  // One line describing what `config` computes on `backend`, for reports.
  virtual std::string describe(const Backend& backend, const Config& config) const = 0;
  // A sweep plan by name: the workload's named plans, "random:N" (N configurations drawn from
  // `seed`), or a JSON file {"description": ..., "configs": [{param: value, ...}, ...]}. Throws
  // InputError naming what is wrong with the spec or the file.
  virtual PlanConfigs plan(const std::string& spec, const Backend& backend, std::uint64_t seed) const = 0;
  // Named plans and what each holds, for --help.
  virtual std::vector<std::pair<std::string, std::string>> plan_names() const = 0;
  virtual ProtocolDefaults defaults(const Backend& backend) const = 0;
  // Runs `config` for `steps` steps once more and writes what it estimates after each (the RBE:
  // mean, covariance, MAP cell, entropy; rbe/estimate.hpp) to `file`: JSON when the name ends
  // in .json, else CSV. The default throws InputError: the workload has no such output.
  virtual void write_estimate(const Backend& backend, const Config& config, std::int64_t steps,
                              const std::string& file) const;
  // Whether write_estimate() is available (checked before anything is measured).
  virtual bool has_estimate() const { return false; }

 protected:
  // Workload-specific checks of a configuration whose parameters are each in their domain.
  virtual void check(const Config& /*config*/, const Backend& /*backend*/) const {}
  // Plans from a file, validated against the parameter space (shared by every workload).
  PlanConfigs plan_from_file(const std::string& path, const Backend& backend) const;
  // N of a "random:N" spec, 1..100000; throws InputError naming the spec otherwise.
  static std::int64_t random_plan_size(const std::string& spec);
};

// ---- Registry -----------------------------------------------------------------------------

// Every registered workload, by name.
const std::vector<const Workload*>& all();
// Throws InputError naming the known workloads when `name` is unknown.
const Workload& find(std::string_view name);
std::string names(std::string_view separator = ", ");


// Typed access to a validated configuration.
std::int64_t get_int(const Config& c, std::string_view name);
double get_real(const Config& c, std::string_view name);
std::pair<std::int64_t, std::int64_t> get_size2(const Config& c, std::string_view name);
std::string get_text(const Config& c, std::string_view name);  // choice and text
bool get_flag(const Config& c, std::string_view name);
bool has(const Config& c, std::string_view name);  // applies to the config's backend

}  // namespace dtflop::workload
