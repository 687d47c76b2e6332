// Sub-command registry of the `dtflop` executable. Each cli/cmd_*.cpp file registers its
// sub-commands with a static Registrar; adding a command means adding a file.
#pragma once

#include <functional>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "model/cost_counts.hpp"
#include "model/profile.hpp"

namespace dtflop::cli {

using Setup = std::function<void(CLI::App& root)>;

// Commands are set up in ascending `order` (this fixes their order in --help).
struct Registrar {
  Registrar(int order, Setup setup);
};

// Runs every registered setup on `root`.
void setup_all(CLI::App& root);

// Finds the sub-command `name` of `parent`, creating it with `description` if absent.
// Lets several files add children to one group (e.g. `run rbe`, `run dct`).
CLI::App& group(CLI::App& parent, const std::string& name, const std::string& description);

// A workload `dtflop predict` knows. `setup` adds the workload's options to its sub-command
// and returns the function that computes its counts once the options are parsed.
struct CountsResult {
  CostCounts counts;
  nlohmann::json parameters;  // what the counts were computed for, for the report
  std::string description;    // one line, e.g. "seed GPU RBE pipeline, grid 1000x1000, kernel 33x33"
};
// `machine`: the profile given with --machine, else null (counts that depend on the machine,
// such as cuda-resident's waves, take it from its identity).
using CountsFn = std::function<CountsResult(const MachineProfile* machine)>;
struct PredictTarget {
  std::string name;
  std::string description;
  std::function<CountsFn(CLI::App&)> setup;
};
struct PredictRegistrar {
  explicit PredictRegistrar(PredictTarget target);
};
const std::vector<PredictTarget>& predict_targets();

}  // namespace dtflop::cli
