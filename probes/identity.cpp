#include "probes/identity.hpp"

#include <algorithm>
#include <cstdlib>
#include <chrono>
#include <ctime>
#include <fstream>
#include <set>
#include <sstream>
#include <string_view>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "probes/team.hpp"

#if defined(__unix__)
#include <unistd.h>
#endif

namespace dtflop::probes {

namespace {

std::string trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n");
  return std::string(s.substr(b, e - b + 1));
}

std::optional<std::string> read_first_line(const char* path) {
  std::ifstream f(path);
  std::string line;
  if (f && std::getline(f, line)) return trim(line);
  return std::nullopt;
}

// "32768K" -> 33554432
std::optional<std::int64_t> parse_cache_size(const std::string& s) {
  std::int64_t v = 0;
  std::size_t i = 0;
  while (i < s.size() && s[i] >= '0' && s[i] <= '9') v = v * 10 + (s[i++] - '0');
  if (i == 0) return std::nullopt;
  const char unit = i < s.size() ? s[i] : ' ';
  if (unit == 'K') v *= 1024;
  else if (unit == 'M') v *= 1024 * 1024;
  else if (unit == 'G') v *= 1024LL * 1024 * 1024;
  return v > 0 ? std::optional<std::int64_t>(v) : std::nullopt;
}

}  // namespace

CpuInfo cpu_info() {
  CpuInfo c;
  c.threads = usable_cpus();
  std::set<std::pair<std::string, std::string>> cores;  // (physical id, core id)
  std::string physical, mhz;
  std::ifstream f("/proc/cpuinfo");
  for (std::string line; std::getline(f, line);) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::string key = trim(std::string_view(line).substr(0, colon));
    const std::string value = trim(std::string_view(line).substr(colon + 1));
    if (key == "model name" && c.model.empty()) c.model = value;
    else if (key == "physical id") physical = value;
    else if (key == "core id") cores.emplace(physical, value);
    else if (key == "cpu MHz" && mhz.empty()) mhz = value;
  }
  if (c.model.empty()) c.model = "unknown CPU";
  c.cores = cores.empty() ? c.threads : static_cast<int>(cores.size());
  c.cores = std::clamp(c.cores, 1, std::max(c.threads, 1));

  // Clock: the nominal (base) frequency where the kernel exposes it, else cpuinfo_max_freq
  // (the highest boost), else the 'cpu MHz' of /proc/cpuinfo (what a VM's hypervisor
  // reports, usually the nominal clock).
  if (auto base = read_first_line("/sys/devices/system/cpu/cpu0/cpufreq/base_frequency")) {
    c.clock_ghz = std::stod(*base) / 1e6;
    c.clock_source = "/sys/.../cpufreq/base_frequency";
  } else if (auto mx = read_first_line("/sys/devices/system/cpu/cpu0/cpufreq/cpuinfo_max_freq")) {
    c.clock_ghz = std::stod(*mx) / 1e6;
    c.clock_source = "/sys/.../cpufreq/cpuinfo_max_freq (highest boost clock)";
  } else if (!mhz.empty()) {
    try {
      c.clock_ghz = std::stod(mhz) / 1e3;
      c.clock_source = "/proc/cpuinfo 'cpu MHz'";
    } catch (const std::exception&) {
    }
  }
  if (c.clock_ghz && !(*c.clock_ghz > 0)) c.clock_ghz.reset();

  // Largest cache of the highest level listed for cpu0 (the last-level cache), and the largest
  // of the levels below it (the core's own caches, on most CPUs its L2).
  std::vector<std::pair<int, std::int64_t>> caches;  // (level, bytes)
  for (int i = 0; i < 8; ++i) {
    const std::string p = fmt::format("/sys/devices/system/cpu/cpu0/cache/index{}/size", i);
    const std::string l = fmt::format("/sys/devices/system/cpu/cpu0/cache/index{}/level", i);
    if (auto s = read_first_line(p.c_str())) {
      if (auto v = parse_cache_size(*s)) {
        int level = 0;
        if (auto ls = read_first_line(l.c_str())) level = std::atoi(ls->c_str());
        caches.emplace_back(level, *v);
      }
    }
  }
  int top = 0;
  for (const auto& [level, bytes] : caches) top = std::max(top, level);
  for (const auto& [level, bytes] : caches) {
    if (level == top) c.llc_bytes = std::max(c.llc_bytes.value_or(0), bytes);
    else c.private_cache_bytes = std::max(c.private_cache_bytes.value_or(0), bytes);
  }
  return c;
}

std::string nvidia_driver_version(const std::string& first_line) {
  const auto k = first_line.find("Kernel Module");
  if (k == std::string::npos) return {};
  std::istringstream in(first_line.substr(k + 13));
  for (std::string w; in >> w;)
    if (w[0] >= '0' && w[0] <= '9' && w.find('.') != std::string::npos) return w;
  return {};
}

std::string utc_now_iso8601() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm utc{};
#if defined(_WIN32)
  gmtime_s(&utc, &now);
#else
  gmtime_r(&now, &utc);
#endif
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return buf;
}

MachineIdentity host_identity() {
  MachineIdentity id;
#if defined(__unix__)
  char host[256] = {};
  if (gethostname(host, sizeof(host) - 1) == 0) id.hostname = host;
#endif
  const CpuInfo c = cpu_info();
  id.cpu_model = c.model;
  id.cpu_cores = c.cores;
  id.cpu_threads = c.threads;
  id.cpu_llc_bytes = c.llc_bytes.value_or(0);
  id.cpu_clock_ghz = c.clock_ghz;
  id.measured_at = utc_now_iso8601();
  return id;
}

}  // namespace dtflop::probes
