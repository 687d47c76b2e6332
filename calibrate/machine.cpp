#include "calibrate/machine.hpp"

#include <sched.h>
#include <unistd.h>

#include <algorithm>

#include <fstream>
#include <set>
#include <thread>
#include <utility>

#include <fmt/format.h>

#if DTFLOP_HAVE_CUDA
#include <cuda_runtime.h>
#endif

namespace dtflop::calib {

namespace {

std::string trim(std::string s) {
  const auto b = s.find_first_not_of(" \t");
  const auto e = s.find_last_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  s = s.substr(b, e - b + 1);
  // Collapse runs of spaces ("Intel(R) Xeon(R)  CPU" -> one space).
  std::string out;
  for (char c : s)
    if (!(c == ' ' && !out.empty() && out.back() == ' ')) out += c;
  return out;
}

struct CpuInfo {
  std::string model;
  int cores = 0;
};

CpuInfo read_cpuinfo() {
  CpuInfo info;
  std::ifstream in("/proc/cpuinfo");
  std::set<std::pair<std::string, std::string>> cores;  // (physical id, core id)
  std::string line, physical = "0";
  while (std::getline(in, line)) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::string key = trim(line.substr(0, colon));
    const std::string value = trim(line.substr(colon + 1));
    if (key == "model name" && info.model.empty()) info.model = value;
    else if (key == "physical id") physical = value;
    else if (key == "core id") cores.emplace(physical, value);
  }
  info.cores = static_cast<int>(cores.size());
  return info;
}

std::string normalized(const std::string& s) { return trim(s); }

// Hardware threads this process may run on (its affinity mask), as `dtflop probe` counts them.
int usable_cpus() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (::sched_getaffinity(0, sizeof set, &set) == 0) {
    const int n = CPU_COUNT(&set);
    if (n > 0) return n;
  }
  return std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

}  // namespace

MachineIdentity this_machine() {
  MachineIdentity id;
  char host[256] = {};
  if (::gethostname(host, sizeof host - 1) == 0) id.hostname = host;
  const CpuInfo cpu = read_cpuinfo();
  id.cpu_model = cpu.model.empty() ? "unknown CPU" : cpu.model;
  id.cpu_threads = usable_cpus();
  id.cpu_cores = cpu.cores > 0 ? cpu.cores : id.cpu_threads;
#if DTFLOP_HAVE_CUDA
  int count = 0;
  if (cudaGetDeviceCount(&count) == cudaSuccess && count > 0) {
    cudaDeviceProp prop{};
    if (cudaGetDeviceProperties(&prop, 0) == cudaSuccess) id.gpu_name = prop.name;
    int driver = 0, runtime = 0;
    if (cudaDriverGetVersion(&driver) == cudaSuccess)
      id.gpu_driver = fmt::format("CUDA driver API {}.{}", driver / 1000, (driver % 1000) / 10);
    if (cudaRuntimeGetVersion(&runtime) == cudaSuccess)
      id.cuda_version = fmt::format("{}.{}", runtime / 1000, (runtime % 1000) / 10);
  } else {
    (void)cudaGetLastError();  // no device: clear the sticky error, the identity has no GPU
  }
#endif
  return id;
}

bool same_machine(const MachineIdentity& a, const MachineIdentity& b, std::string* why) {
  std::string diff;
  auto add = [&diff](std::string s) { diff += (diff.empty() ? "" : "; ") + s; };
  if (normalized(a.cpu_model) != normalized(b.cpu_model))
    add(fmt::format("CPU '{}' vs '{}'", a.cpu_model, b.cpu_model));
  if (a.cpu_threads != b.cpu_threads)
    add(fmt::format("{} vs {} hardware threads", a.cpu_threads, b.cpu_threads));
  if (normalized(a.gpu_name) != normalized(b.gpu_name))
    add(fmt::format("GPU '{}' vs '{}'", a.gpu_name.empty() ? "none" : a.gpu_name,
                    b.gpu_name.empty() ? "none" : b.gpu_name));
  if (why) *why = diff;
  return diff.empty();
}

std::string describe(const MachineIdentity& id) {
  std::string s = fmt::format("{} ({} threads)", id.cpu_model.empty() ? "unknown CPU" : id.cpu_model,
                              id.cpu_threads);
  if (!id.gpu_name.empty()) s += " + " + id.gpu_name;
  if (!id.hostname.empty()) s += " on host " + id.hostname;
  return s;
}

}  // namespace dtflop::calib
