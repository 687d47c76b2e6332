// Actual component times of device work from the CUPTI Activity API.
//
// The profiler records every memcpy (bytes, direction, pinned or pageable host memory, start
// and end on the device), every kernel (name, start, end) and the runtime API calls that
// launch kernels and copies, and attributes them to a run by a marked range: begin() stamps the
// start (on CUPTI's clock, the clock its records use), end() waits for the device, stamps the
// end and keeps the records inside the range. Work is traced only between begin() and end(),
// so runs outside a range pay no tracing overhead.
//
// CUPTI can be unavailable: dtflop built without CUDA, no usable device, another tool (Nsight,
// a second profiler) already subscribed, or insufficient permissions. open_cupti_profiler()
// then returns no profiler and says why, so the caller can fall back to host timing and record
// the reason in the sample.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace dtflop::calib {

// One activity record, reduced to what dtflop uses. Times in ns on CUPTI's clock.
struct ActivityRecord {
  enum class Kind { copy, kernel, api };
  enum class Direction { to_device, to_host, on_device, other };
  Kind kind = Kind::copy;
  std::uint64_t start = 0;
  std::uint64_t end = 0;
  // copies
  Direction direction = Direction::other;
  std::uint64_t bytes = 0;
  bool pageable = false;  // the host side of the copy is pageable memory
  // kernels: the (mangled) kernel name; api: the runtime function's name
  std::string name;
};

struct CopyTotals {
  int count = 0;
  std::uint64_t bytes = 0;
  double seconds = 0;  // sum of device-side durations
  int pageable = 0;    // copies whose host memory was pageable
  int pinned = 0;      // copies whose host memory was pinned
};

// What happened on the device during one marked range.
struct DeviceActivity {
  CopyTotals to_device, to_host, on_device, other_copies;
  int kernels = 0;
  double kernel_seconds = 0;             // sum of kernel durations
  std::map<std::string, std::pair<int, double>> kernel_by_name;  // name -> (count, seconds)
  int launch_calls = 0;                  // runtime API calls that launch work (kernels, graphs)
  double launch_api_seconds = 0;         // their host-side durations
  int copy_calls = 0;                    // runtime API copy calls
  double copy_api_seconds = 0;           // their host-side durations (include waiting)
  double window_seconds = 0;             // end - begin
  double busy_seconds = 0;               // union of copy and kernel intervals
  std::uint64_t dropped_records = 0;     // records CUPTI could not deliver (buffers full)
  // The range (ns, CUPTI's clock) and its records as CUPTI delivered them, for a timeline
  // (calibrate/timeline.hpp): the profiler fills them, aggregate() does not.
  std::uint64_t begin_ns = 0, end_ns = 0;
  std::vector<ActivityRecord> records;

  nlohmann::json to_json() const;
};

// Sums the records that lie inside [t0, t1] (ns). Records straddling a boundary are clipped
// to the range. Pure function: tested without a device.
DeviceActivity aggregate(const std::vector<ActivityRecord>& records, std::uint64_t t0, std::uint64_t t1);

class ActivityProfiler {
 public:
  virtual ~ActivityProfiler() = default;
  // Starts tracing and marks the start of a range. Waits for earlier device work first.
  virtual void begin() = 0;
  // Waits for the device, marks the end of the range, stops tracing and returns the range's
  // activity.
  virtual DeviceActivity end() = 0;
};

struct ProfilerOpen {
  std::unique_ptr<ActivityProfiler> profiler;  // null when unavailable
  std::string why_not;                          // one line when unavailable
};

// The process-wide CUPTI profiler (CUPTI allows one subscriber per process: a second call
// while the first profiler lives returns none, with the reason).
ProfilerOpen open_cupti_profiler();

}  // namespace dtflop::calib
