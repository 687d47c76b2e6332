// A resumable sweep: measure every configuration of a plan that the sample store does not hold
// yet, appending each sample to the store as soon as it is measured.
#pragma once

#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calibrate/sample.hpp"

namespace dtflop::calib {

struct PlanItem {
  std::string key;             // the configuration's identity in the store
  std::string label;           // short text for progress lines ("1000x1000 k16x16")
  nlohmann::json parameters;   // what the measuring function needs
};

struct Plan {
  std::string name;            // "seed-test1", "random:50", a file name
  std::string description;     // what it covers and why, one paragraph
  std::vector<PlanItem> items;
};

struct SweepReport {
  int planned = 0;         // samples: configurations x rounds
  int configurations = 0;  // distinct configurations of the plan
  int rounds = 1;
  int already = 0;    // found in the store, not measured again
  int measured = 0;
  std::vector<std::string> warnings;
};

using MeasureFn = std::function<Sample(const PlanItem&)>;

// Measures the plan's items missing from `store` with `measure`, appending each sample as it
// completes. With `rounds` R > 1 the plan is walked R times, round after round (every
// configuration once per round, so a slow spell of the machine hits one round of many
// configurations rather than every repetition of one); round r's sample of an item gets the key
// round_key(item.key, r) and the field round = r (calibrate/rounds.hpp), and only the
// (configuration, round) pairs missing from the store are measured. `measure` is given the item
// with its round's key. Progress lines (round, done/total, ETA over every remaining round) go to
// `progress` unless it is null. Throws InputError when `rounds` < 1, when the store holds samples
// of another machine than `here`, or is not a store.
SweepReport run_sweep(const Plan& plan, const std::filesystem::path& store, const MachineIdentity& here,
                      const MeasureFn& measure, std::FILE* progress, int rounds = 1);

// "1h02m", "3m05s", "12s".
std::string format_eta(double seconds);

}  // namespace dtflop::calib
