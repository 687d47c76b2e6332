// One traced repetition as a timeline: every copy and kernel the device ran and every runtime API
// call the host made, in the Trace Event Format that chrome://tracing and ui.perfetto.dev open
// (`dtflop run ... --timeline FILE`), with a summary of where the repetition's wall time went
// that the aggregates of DeviceActivity cannot say: how long the device sat idle between its
// operations, and what the host was doing then.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calibrate/profiler.hpp"

namespace dtflop::calib {

// A kernel's name as a reader wants it: the function's own name, without namespaces, template
// arguments or parameters ("k_union" for "void dtflop::dct::gpu::(anonymous namespace)::k_union(int*,
// int, int)" or its mangled form). Names it cannot demangle are returned as they are.
std::string short_kernel_name(const std::string& name);

// Where the time of the range [t0, t1] (ns, CUPTI's clock) went.
struct TimelineSummary {
  double window_seconds = 0;       // t1 - t0
  double device_busy_seconds = 0;  // union of the copies' and kernels' intervals
  int device_operations = 0;       // copies and kernels
  // Idle stretches of the device between two of its operations (not before the first or after
  // the last): how many, their sum and their median.
  int gaps = 0;
  double gap_seconds = 0;
  double gap_median_seconds = 0;
  double lead_seconds = 0;   // t0 to the device's first operation
  double trail_seconds = 0;  // the device's last operation to t1
  // Runtime API calls: count and host-side seconds by function name.
  std::vector<std::pair<std::string, std::pair<int, double>>> api_by_name;

  nlohmann::json to_json() const;
};

// Pure functions of the records (tested without a device). Records outside [t0, t1] are left out
// and those straddling it clipped, as aggregate() does.
TimelineSummary summarize_timeline(const std::vector<ActivityRecord>& records, std::uint64_t t0, std::uint64_t t1);
// The Trace Event Format document: "traceEvents" (complete events, microseconds from t0; the
// device's copies and kernels in one process, the host's runtime calls in another) and
// "dtflop_summary" (summarize_timeline, with `label` saying what ran).
nlohmann::json timeline_json(const std::vector<ActivityRecord>& records, std::uint64_t t0, std::uint64_t t1,
                             const std::string& label);

}  // namespace dtflop::calib
