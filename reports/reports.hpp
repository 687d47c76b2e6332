// The reports `dtflop report` makes, each built from archived files alone (machine profiles,
// fitted profiles, sample stores), so a report can be made again later from what was kept:
//   machine    - one profile: identity, host<->device bandwidth against size per direction and
//                memory kind with the fitted latency + bytes/bandwidth curve, rates and
//                bandwidths against the peaks known for the machine, every parameter;
//   predicted  - samples and the profile fitted for them: per component predicted and
//                measured (same colour), the mean/max error table, the fitted parameters with
//                their intervals, the chosen variant and its margin, the worst configurations;
//   compare    - two profiles (two machines, or two runs of one), parameter by parameter with
//                the ratio; or two runs' sample stores, configuration by configuration;
//   tuning     - a `dtflop tune -o` result: the choice, time against accuracy with the Pareto
//                front and the deadline, predicted against measured, and how each strategy (and
//                a peer's replay) approached the optimum.
// Each returns a Document (reports/document.hpp); write_report() writes it.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calibrate/sample.hpp"
#include "model/predict.hpp"
#include "model/profile.hpp"
#include "reports/document.hpp"

namespace dtflop::reports {

// What every report states besides its data.
struct Context {
  std::string command;              // the command line that made it
  std::vector<std::string> inputs;  // the files it was made from
};

// The dtflop version the build was made from (`git describe --always --dirty`, or the project
// version when built outside a git checkout).
const char* version();

Document machine_report(const MachineProfile& profile, const Context& ctx);

struct PredictedInput {
  std::vector<std::string> stores;
  std::string profile_path;
  std::optional<Variant> variant;      // none: the one the fit chose, else extended
  std::string rounds_combine;          // empty: the fit's, else the default
  std::vector<std::string> backends;   // only these (empty: all)
  std::vector<std::string> match;      // only samples whose key contains each of these
  int worst = 10;                      // configurations named in the worst table
};
// Reads the stores and the profile. Throws InputError (one line) when a store holds no sample,
// when the samples come from more than one machine or from another machine than the profile's,
// or when a prediction needs a parameter the profile lacks.
Document predicted_report(const PredictedInput& in, const Context& ctx);

Document compare_report(const MachineProfile& a, const std::string& name_a, const MachineProfile& b,
                        const std::string& name_b, const Context& ctx);

// Two runs of the same configurations (two machines, or one machine before and after a change):
// the stores of A and of B, their rounds combined by the fastest (the default rule), matched
// by configuration key. Per configuration the measured total per step on each side and the
// ratio B / A; the geometric mean, the smallest and the largest ratio. Throws InputError when
// a side holds no sample or the two share no configuration.
Document compare_runs_report(const std::vector<std::string>& stores_a, const std::string& name_a,
                             const std::vector<std::string>& stores_b, const std::string& name_b, const Context& ctx);

// A `dtflop tune -o` result (`name`: its file, for messages) and the replays of peers run on the
// same measured space (benchmarks/tune/peer_botorch.py's JSON: rows of strategy, budget and
// median_fraction_of_optimum). Throws InputError (one line) for a result of another schema or
// without the fields the report draws.
Document tuning_report(const nlohmann::json& result, const std::string& name, const std::vector<nlohmann::json>& peers,
                       const Context& ctx);

// The transfer sweeps `dtflop probe` keeps in a profile's metadata (probes/machine.cpp writes
// them): "probe.transfers.<series>", e.g. "probe.transfers.h2d_pinned", holds
// "bytes:seconds bytes:seconds ...", seconds the median of the repetitions of one copy.
// Malformed text decodes to nothing (the report then says the points are missing).
std::vector<std::pair<double, double>> decode_transfer_points(const std::string& text);

}  // namespace dtflop::reports
