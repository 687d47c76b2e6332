// A tuning scenario: what a user deploys (the workload, the space of configurations to choose
// from, the deadline of a step or frame and the accuracy the application needs) and on which
// machine (a probe or fitted profile, and calibrations of the backends), read from YAML.
//
//   name: sar-raft
//   description: one paragraph
//   workload: rbe
//   machine: ../../docs/examples/h200.json      # relative to this file; --machine overrides
//   calibrations: [h100-cuda-seed.json]          # optional; --calibration adds more
//   deadline: 50ms                               # per step (frame); eq. 3.1's dt_p. Optional
//   confidence: 0.95                             # the deadline verdict's confidence
//   space:                                       # values to choose from; a parameter left out
//     backend: [cuda-seed, cuda-resident]        #   keeps its default (or `fixed`)
//     grid: [1000x1000, 2000x2000]
//     kernel: {from: 9, to: 65, step: 4, square: true}   # a range; size2 squares (IxI)
//   fixed: {problem-seed: 1}                     # set in every configuration
//   accuracy: {...}                              # what the workload's accuracy model needs
//
// Every field is validated when the file is read: an unknown field, a value of the wrong type or
// outside its range is an InputError naming the file, the field, the value and what was expected.
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace dtflop::tune {

// One parameter of the space and the values (as typed on a command line: "1000x1000", "12",
// "pinned") it takes.
struct Axis {
  std::string param;
  std::vector<std::string> values;
};

struct Scenario {
  std::filesystem::path file;       // where it was read from (empty: from text)
  std::string name;
  std::string description;
  std::string workload;
  std::string machine;              // a profile path (resolved against the file's folder); may be empty
  std::vector<std::string> calibrations;  // calibration paths, resolved likewise
  std::optional<double> deadline;   // seconds per step (frame)
  double confidence = 0.95;
  std::vector<std::string> backends;  // empty: every backend of the workload
  std::vector<Axis> axes;             // in the file's order
  std::map<std::string, std::string> fixed;
  nlohmann::json accuracy = nlohmann::json::object();  // validated by the workload's accuracy model
};

// Largest number of configurations a space may enumerate (before constraints): a guard against
// a range typed with a step too small.
inline constexpr std::size_t kMaxSpace = 200'000;

// Reads and validates a scenario file (at most 1 MiB). Throws InputError.
Scenario load_scenario(const std::filesystem::path& path);
// The same from YAML text; relative paths are resolved against `base`; `origin` names the text
// in messages.
Scenario parse_scenario(const std::string& yaml, const std::filesystem::path& base, const std::string& origin);

}  // namespace dtflop::tune
