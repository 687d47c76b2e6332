// A sample: one measured configuration of a workload on one machine, as the sample store
// holds it (one JSON object per line of a .jsonl file).
//
// A sample measures `repetitions` runs of `steps` steps each. `counts` are the exact cost counts
// of one such run (what the backend declares for run(steps)), and every measured component is
// the time of one run, so predict(profile, counts) compares with it directly.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "model/stats.hpp"
#include "model/cost_counts.hpp"
#include "model/predict.hpp"
#include "model/profile.hpp"
#include "model/terms.hpp"

namespace dtflop::calib {

inline constexpr const char* kSampleSchema = "dtflop.sample";
inline constexpr int kSampleSchemaVersion = 1;

// The measured components the model predicts: the total (wall time of the run, Prediction::
// total) and the phases of a step a measurement times apart, each the sum of the model's terms
// of that phase (model/terms.hpp, docs/model.md section 5):
//   CG    - host->device copies                   <-> Phase::CG (dt_CG + lat_CG)
//   GC    - device->host copies                   <-> Phase::GC (dt_GC + lat_GC)
//   G     - kernels                               <-> Phase::G (dt_GG + dt_G, extended: the
//                                                     larger, + launches, waves, atomics, tiles)
//   C     - CPU work, host clock                  <-> Phase::C (Prediction::dt_C)
// So the components and the host waits (Phase::wait, in the total only) add up to the total.
// How each is measured (a host clock around the phase, or CUPTI's device-side durations) is in
// the sample's timing note.
enum class Component { total, CG, GC, G, C };

std::string_view to_string(Component c);
std::optional<Component> component_from_string(std::string_view s);
const std::vector<Component>& all_components();
// The model's phase a component measures; none for the total.
std::optional<Phase> phase(Component c);
// The model's prediction of component `c` (seconds), per the table above.
double predicted(const Prediction& p, Component c);

// How a sample's components were timed.
enum class TimingSource {
  cupti,  // CUPTI activity records for copies and kernels, host clocks for CPU work and total
  host,   // host clocks only (CPU backends, or CUPTI unavailable: the reason is in timing_note)
};
std::string_view to_string(TimingSource s);

struct Sample {
  std::string key;              // identifies the configuration measured (resume key)
  MachineIdentity machine;      // where it was measured
  std::string workload;         // "rbe"
  std::string backend;          // "cuda-seed", "cpu-seq", ...
  std::string plan;             // the sweep plan it belongs to ("seed-test1", "random:50", ...)
  int round = 1;                // which round of `dtflop sweep --rounds` measured it (1: the first;
                                // round r >= 2 has the key "<key>/round=r", see calibrate/rounds.hpp)
  nlohmann::json parameters = nlohmann::json::object();  // the configuration
  CostCounts counts;            // exact counts of one repetition (a run of `steps` steps)
  std::int64_t steps = 1;       // steps per repetition
  int warmup = 0;               // runs discarded before the timed ones
  TimingSource source = TimingSource::host;
  std::string timing_note;      // e.g. why CUPTI was not used
  std::map<Component, Stats> components;  // seconds per repetition
  nlohmann::json detail = nlohmann::json::object();  // informational measurements
  std::string measured_at;      // ISO 8601 UTC

  const Stats* find(Component c) const {
    auto it = components.find(c);
    return it == components.end() ? nullptr : &it->second;
  }
  int repetitions() const;  // repetitions of the total (0 when absent)
};

nlohmann::json to_json(const Sample& s);
// Validates every field; throws InputError naming the field and what was expected.
Sample sample_from_json(const nlohmann::json& j);

nlohmann::json to_json(const MachineIdentity& id);
MachineIdentity identity_from_json(const nlohmann::json& j);

// Current UTC time, ISO 8601 ("2026-11-21T10:00:00Z").
std::string utc_now();

}  // namespace dtflop::calib
