#include "calibrate/profiler.hpp"

#include <algorithm>
#include <utility>

namespace dtflop::calib {

namespace {
double ns(std::uint64_t d) { return static_cast<double>(d) * 1e-9; }

nlohmann::json copy_json(const CopyTotals& c) {
  return {{"count", c.count}, {"bytes", c.bytes}, {"seconds", c.seconds},
          {"pageable", c.pageable}, {"pinned", c.pinned}};
}
}  // namespace

nlohmann::json DeviceActivity::to_json() const {
  nlohmann::json kernels_json = nlohmann::json::object();
  for (const auto& [name, v] : kernel_by_name) kernels_json[name] = {{"count", v.first}, {"seconds", v.second}};
  return {{"to_device", copy_json(to_device)},
          {"to_host", copy_json(to_host)},
          {"on_device", copy_json(on_device)},
          {"other_copies", copy_json(other_copies)},
          {"kernels", kernels},
          {"kernel_seconds", kernel_seconds},
          {"kernel_by_name", kernels_json},
          {"launch_calls", launch_calls},
          {"launch_api_seconds", launch_api_seconds},
          {"copy_calls", copy_calls},
          {"copy_api_seconds", copy_api_seconds},
          {"window_seconds", window_seconds},
          {"busy_seconds", busy_seconds},
          {"dropped_records", dropped_records}};
}

DeviceActivity aggregate(const std::vector<ActivityRecord>& records, std::uint64_t t0, std::uint64_t t1) {
  DeviceActivity a;
  a.window_seconds = t1 > t0 ? ns(t1 - t0) : 0;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> busy;
  for (const auto& r : records) {
    const std::uint64_t s = std::max(r.start, t0);
    const std::uint64_t e = std::min(r.end, t1);
    if (r.end < r.start || e <= s) continue;  // outside the range (or empty)
    const double d = ns(e - s);
    switch (r.kind) {
      case ActivityRecord::Kind::copy: {
        CopyTotals* c = &a.other_copies;
        if (r.direction == ActivityRecord::Direction::to_device) c = &a.to_device;
        else if (r.direction == ActivityRecord::Direction::to_host) c = &a.to_host;
        else if (r.direction == ActivityRecord::Direction::on_device) c = &a.on_device;
        c->count += 1;
        c->bytes += r.bytes;
        c->seconds += d;
        (r.pageable ? c->pageable : c->pinned) += 1;
        busy.emplace_back(s, e);
        break;
      }
      case ActivityRecord::Kind::kernel: {
        a.kernels += 1;
        a.kernel_seconds += d;
        auto& k = a.kernel_by_name[r.name];
        k.first += 1;
        k.second += d;
        busy.emplace_back(s, e);
        break;
      }
      case ActivityRecord::Kind::api: {
        if (r.name.find("Launch") != std::string::npos) {
          a.launch_calls += 1;
          a.launch_api_seconds += d;
        } else if (r.name.find("Memcpy") != std::string::npos) {
          a.copy_calls += 1;
          a.copy_api_seconds += d;
        }
        break;
      }
    }
  }
  // Union of the device intervals: time the device was doing something.
  std::sort(busy.begin(), busy.end());
  std::uint64_t cur_s = 0, cur_e = 0, total = 0;
  bool open = false;
  for (const auto& [s, e] : busy) {
    if (!open || s > cur_e) {
      if (open) total += cur_e - cur_s;
      cur_s = s;
      cur_e = e;
      open = true;
    } else {
      cur_e = std::max(cur_e, e);
    }
  }
  if (open) total += cur_e - cur_s;
  a.busy_seconds = ns(total);
  return a;
}

#if !DTFLOP_HAVE_CUPTI
ProfilerOpen open_cupti_profiler() {
  return {nullptr,
#if DTFLOP_HAVE_CUDA
          "dtflop was built without CUPTI (the CUDA toolkit's CUPTI library was not found at build "
          "time)"
#else
          "dtflop was built without CUDA, so CUPTI is unavailable"
#endif
  };
}
#endif

}  // namespace dtflop::calib
