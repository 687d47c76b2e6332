#include "calibrate/machine.hpp"

#include <fmt/format.h>

#include "probes/gpu.hpp"
#include "probes/identity.hpp"

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

std::string normalized(const std::string& s) { return trim(s); }

}  // namespace

MachineIdentity this_machine() {
  // The same functions `dtflop probe` uses, so a sample and a profile of one machine agree.
  MachineIdentity id = probes::host_identity();
  id.measured_at.clear();  // a sample has its own time
  const probes::gpu::DeviceInfo d = probes::gpu::device_info();
  if (d.usable) {
    id.gpu_name = d.name;
    id.gpu_sms = d.sm_count;
    id.gpu_driver = d.driver_version;
    id.cuda_version = d.runtime_version;
  }
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
