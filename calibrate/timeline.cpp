#include "calibrate/timeline.hpp"

#include <cxxabi.h>

#include <algorithm>
#include <cstdlib>
#include <map>
#include <memory>
#include <string_view>
#include <utility>

#include <fmt/format.h>

namespace dtflop::calib {

namespace {

double ns(std::uint64_t d) { return static_cast<double>(d) * 1e-9; }

// A record's interval clipped to [t0, t1]; false when nothing of it is inside.
bool clipped(const ActivityRecord& r, std::uint64_t t0, std::uint64_t t1, std::uint64_t& s, std::uint64_t& e) {
  s = std::max(r.start, t0);
  e = std::min(r.end, t1);
  return r.end >= r.start && e > s;
}

bool on_device(const ActivityRecord& r) { return r.kind != ActivityRecord::Kind::api; }

std::string_view direction_name(ActivityRecord::Direction d) {
  switch (d) {
    case ActivityRecord::Direction::to_device: return "host->device";
    case ActivityRecord::Direction::to_host: return "device->host";
    case ActivityRecord::Direction::on_device: return "device->device";
    case ActivityRecord::Direction::other: return "other";
  }
  return "other";
}

}  // namespace

std::string short_kernel_name(const std::string& name) {
  std::string text = name;
  int status = -1;
  std::unique_ptr<char, void (*)(void*)> d(abi::__cxa_demangle(name.c_str(), nullptr, nullptr, &status), std::free);
  if (status == 0 && d) text = d.get();
  // Cut the parameter list: the first '(' outside angle brackets that is not "(anonymous namespace)".
  constexpr std::string_view anonymous = "(anonymous namespace)";
  int depth = 0;
  std::size_t end = text.size();
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char ch = text[i];
    if (ch == '<') ++depth;
    else if (ch == '>') --depth;
    else if (ch == '(' && depth == 0 && text.compare(i, anonymous.size(), anonymous) != 0) {
      end = i;
      break;
    }
  }
  text.resize(end);
  // Template arguments of the function itself.
  if (!text.empty() && text.back() == '>') {
    int level = 0;
    for (std::size_t i = text.size(); i-- > 0;) {
      if (text[i] == '>') ++level;
      else if (text[i] == '<' && --level == 0) {
        text.resize(i);
        break;
      }
    }
  }
  // Namespaces and a return type before the name.
  const std::size_t colon = text.rfind("::");
  if (colon != std::string::npos) text = text.substr(colon + 2);
  const std::size_t space = text.rfind(' ');
  if (space != std::string::npos) text = text.substr(space + 1);
  return text.empty() ? name : text;
}

nlohmann::json TimelineSummary::to_json() const {
  nlohmann::json api = nlohmann::json::object();
  for (const auto& [n, v] : api_by_name) api[n] = {{"calls", v.first}, {"seconds", v.second}};
  return {{"window_seconds", window_seconds},
          {"device_busy_seconds", device_busy_seconds},
          {"device_operations", device_operations},
          {"device_gaps", gaps},
          {"device_gap_seconds", gap_seconds},
          {"device_gap_median_seconds", gap_median_seconds},
          {"device_lead_seconds", lead_seconds},
          {"device_trail_seconds", trail_seconds},
          {"runtime_api", api}};
}

TimelineSummary summarize_timeline(const std::vector<ActivityRecord>& records, std::uint64_t t0, std::uint64_t t1) {
  TimelineSummary out;
  out.window_seconds = t1 > t0 ? ns(t1 - t0) : 0;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> dev;
  std::map<std::string, std::pair<int, double>> api;
  for (const ActivityRecord& r : records) {
    std::uint64_t s = 0, e = 0;
    if (!clipped(r, t0, t1, s, e)) continue;
    if (on_device(r)) {
      dev.emplace_back(s, e);
    } else {
      auto& a = api[r.name.empty() ? std::string("?") : r.name];
      a.first += 1;
      a.second += ns(e - s);
    }
  }
  out.api_by_name.assign(api.begin(), api.end());
  out.device_operations = static_cast<int>(dev.size());
  if (dev.empty()) return out;
  // The device's busy stretches (overlapping operations merged), then the idle ones between them.
  std::sort(dev.begin(), dev.end());
  std::vector<std::pair<std::uint64_t, std::uint64_t>> busy = {dev.front()};
  for (std::size_t i = 1; i < dev.size(); ++i) {
    if (dev[i].first > busy.back().second) busy.push_back(dev[i]);
    else busy.back().second = std::max(busy.back().second, dev[i].second);
  }
  std::vector<double> gaps;
  for (std::size_t i = 0; i < busy.size(); ++i) {
    out.device_busy_seconds += ns(busy[i].second - busy[i].first);
    if (i > 0) gaps.push_back(ns(busy[i].first - busy[i - 1].second));
  }
  out.lead_seconds = ns(busy.front().first - t0);
  out.trail_seconds = ns(t1 - busy.back().second);
  out.gaps = static_cast<int>(gaps.size());
  for (double g : gaps) out.gap_seconds += g;
  if (!gaps.empty()) {
    std::sort(gaps.begin(), gaps.end());
    const std::size_t m = gaps.size() / 2;
    out.gap_median_seconds = gaps.size() % 2 ? gaps[m] : 0.5 * (gaps[m - 1] + gaps[m]);
  }
  return out;
}

nlohmann::json timeline_json(const std::vector<ActivityRecord>& records, std::uint64_t t0, std::uint64_t t1,
                             const std::string& label) {
  constexpr int kDevice = 1, kHost = 2;
  nlohmann::json events = nlohmann::json::array();
  auto meta = [&events](int pid, const char* what, const std::string& name) {
    events.push_back({{"ph", "M"}, {"pid", pid}, {"tid", 0}, {"name", what}, {"args", {{"name", name}}}});
  };
  meta(kDevice, "process_name", "device");
  meta(kHost, "process_name", "host");
  meta(kDevice, "thread_name", "copies and kernels");
  meta(kHost, "thread_name", "runtime API");
  auto us = [t0](std::uint64_t t) { return static_cast<double>(t - t0) * 1e-3; };
  for (const ActivityRecord& r : records) {
    std::uint64_t s = 0, e = 0;
    if (!clipped(r, t0, t1, s, e)) continue;
    nlohmann::json ev = {{"ph", "X"}, {"ts", us(s)}, {"dur", us(e) - us(s)}, {"tid", 0}};
    switch (r.kind) {
      case ActivityRecord::Kind::kernel:
        ev["name"] = short_kernel_name(r.name);
        ev["cat"] = "kernel";
        ev["pid"] = kDevice;
        ev["args"] = {{"function", r.name}};
        break;
      case ActivityRecord::Kind::copy:
        ev["name"] = fmt::format("copy {}", direction_name(r.direction));
        ev["cat"] = "copy";
        ev["pid"] = kDevice;
        ev["args"] = {{"bytes", r.bytes}, {"host_memory", r.pageable ? "pageable" : "pinned"}};
        break;
      case ActivityRecord::Kind::api:
        ev["name"] = r.name.empty() ? std::string("?") : r.name;
        ev["cat"] = "runtime";
        ev["pid"] = kHost;
        break;
    }
    events.push_back(std::move(ev));
  }
  nlohmann::json summary = summarize_timeline(records, t0, t1).to_json();
  summary["what"] = label;
  return {{"traceEvents", std::move(events)}, {"displayTimeUnit", "ns"}, {"dtflop_summary", std::move(summary)}};
}

}  // namespace dtflop::calib
