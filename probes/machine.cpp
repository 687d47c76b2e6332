#include "probes/machine.hpp"

#include <chrono>
#include <map>
#include <exception>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "probes/cpu_kernels.hpp"
#include "probes/identity.hpp"

namespace dtflop::probes {

bool MachineReport::failed() const {
  for (const auto& r : reports)
    if (r.error) return true;
  return false;
}

MachineReport probe_machine(const ProbeOptions& o, std::span<const std::string> only) {
  const auto& probes = all_probes();
  for (const auto& name : only) {
    bool known = false;
    for (const auto& p : probes) known = known || p.name == name;
    if (!known) {
      std::string names;
      for (const auto& p : probes) names += fmt::format("{}{}", names.empty() ? "" : ", ", p.name);
      throw InputError(fmt::format("there is no probe named '{}'; the probes are: {}", name, names));
    }
  }
  auto selected = [&only](const Probe& p) {
    if (only.empty()) return true;
    for (const auto& n : only)
      if (n == p.name) return true;
    return false;
  };

  MachineReport m;
  m.effort = o.effort;
  m.identity = host_identity();
  m.gpu = gpu::device_info();
  if (m.gpu.usable) {
    m.identity.gpu_name = m.gpu.name;
    m.identity.gpu_sms = m.gpu.sm_count;
    m.identity.gpu_l2_bytes = m.gpu.l2_bytes;
    m.identity.gpu_driver = m.gpu.driver_version;
    m.identity.cuda_version = m.gpu.runtime_version;
  }
  const auto t0 = std::chrono::steady_clock::now();
  std::size_t count = 0, index = 0;
  for (const auto& p : probes) count += selected(p);
  bool told_no_gpu = false;
  for (const auto& p : probes) {
    if (!selected(p)) continue;
    ++index;
    ProbeReport r;
    if (p.needs_gpu && !m.gpu.usable) {
      r.probe = p.name;
      r.skipped = m.gpu.reason;
      if (!told_no_gpu) {
        o.say(fmt::format("GPU probes skipped: {}. The GPU parameters stay out of the profile.",
                          m.gpu.reason));
        told_no_gpu = true;
      }
      m.reports.push_back(std::move(r));
      continue;
    }
    o.say(fmt::format("[{}/{}] {}: {}", index, count, p.name, p.description));
    const auto s0 = std::chrono::steady_clock::now();
    try {
      r = p.run(o);
    } catch (const std::exception& e) {
      r = ProbeReport{};
      r.error = e.what();
      o.say(fmt::format("  {} FAILED: {}", p.name, e.what()));
    }
    r.probe = p.name;
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - s0).count();
    if (r.skipped) o.say(fmt::format("  skipped: {}", *r.skipped));
    else o.say(fmt::format("  {}: {:.1f} s", p.name, r.seconds));
    m.reports.push_back(std::move(r));
  }
  m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return m;
}

MachineProfile make_profile(const MachineReport& report) {
  MachineProfile prof;
  prof.identity = report.identity;
  for (const auto& r : report.reports) {
    if (r.error || r.skipped) continue;
    for (const auto& m : r.measurements) {
      if (!m.param) continue;
      Parameter par;
      par.value = m.value;
      par.provenance = Provenance::probed;
      par.uncertainty = m.uncertainty;
      if (m.stats.n > 1) par.spread = m.stats.spread();
      par.note = fmt::format("dtflop probe {}: {}", r.probe, m.note);
      prof.set(*m.param, std::move(par));
    }
  }
  // Cost ratios rebased on the profile's own rates (Measurement::reference_param): the ratio was
  // taken against the probe's own rerun of the rate, and a prediction divides by the profile's.
  for (const auto& r : report.reports) {
    if (r.error || r.skipped) continue;
    for (const auto& m : r.measurements) {
      if (!m.param || !m.reference_param || !(m.reference > 0) || !prof.has(*m.reference_param)) continue;
      const double rate = prof.get(*m.reference_param).value;
      Parameter par = prof.get(*m.param);
      par.value = m.value * rate / m.reference;
      par.note += fmt::format("; rebased on {} ({:.4g}): {:.4g} x {:.4g} / {:.4g}", info(*m.reference_param).name, rate,
                              m.value, rate, m.reference);
      prof.set(*m.param, std::move(par));
    }
  }
  auto& md = prof.metadata;
  // What the probes add to the metadata themselves (ProbeReport::metadata).
  for (const auto& r : report.reports)
    if (!r.error && !r.skipped)
      for (const auto& [k, v] : r.metadata) md["probe." + k] = v;
  // The cache a process gets (cpu-memory's read ladder): its knee becomes the identity's
  // effective last-level cache. Without a knee the field stays 0 and the model uses the system's
  // figure; the metadata (probe.cpu_llc_effective) says which, and why.
  for (const auto& r : report.reports) {
    if (r.error || r.skipped || r.probe != "cpu-memory") continue;
    for (const auto& m : r.measurements)
      if (m.key == "llc_effective" && m.value >= 1) prof.identity.cpu_llc_effective_bytes = static_cast<std::int64_t>(m.value);
  }
  // Every point of the transfer sweeps, so a report can draw them against the fitted curve:
  // "probe.transfers.<series>" = "bytes:seconds ..." (seconds: the median of one copy's
  // repetitions; reports/reports.hpp reads it). The series is the point's key without its size.
  std::map<std::string, std::string> sweeps;
  for (const auto& r : report.reports) {
    if (r.error || r.skipped || r.probe != "gpu-transfers") continue;
    for (const auto& m : r.measurements) {
      if (!m.detail || m.unit != "B/s" || m.stats.n == 0 || !(m.stats.median > 0)) continue;
      const auto cut = m.key.rfind('_');
      if (cut == std::string::npos) continue;
      std::string& text = sweeps[m.key.substr(0, cut)];
      text += fmt::format("{}{:.0f}:{:.9g}", text.empty() ? "" : " ", m.value * m.stats.median, m.stats.median);
    }
  }
  for (const auto& [series, text] : sweeps) md["probe.transfers." + series] = text;
  md["probe.effort"] = to_string(report.effort);
  md["probe.seconds"] = fmt::format("{:.1f}", report.seconds);
  for (const auto& r : report.reports)  // each probe's own time (a slow one on a large host shows here)
    if (!r.skipped) md["probe.seconds." + r.probe] = fmt::format("{:.1f}", r.seconds);
  md["probe.cpu_isa"] = std::string(cpu::to_string(cpu::best_isa()));
  const CpuInfo ci = cpu_info();
  if (ci.clock_ghz) md["probe.cpu_clock_source"] = ci.clock_source;
  if (report.gpu.usable) {
    md["probe.gpu_compute_capability"] = fmt::format("{}.{}", report.gpu.cc_major, report.gpu.cc_minor);
    md["probe.gpu_sm_count"] = fmt::format("{}", report.gpu.sm_count);
    md["probe.gpu_memory_bytes"] = fmt::format("{}", report.gpu.total_bytes);
    md["probe.cuda_driver_supports"] = report.gpu.driver_cuda_version;
    if (report.gpu.sm_clock_ghz)
      md["probe.gpu_sm_clock_ghz"] = fmt::format("{:.3f}", *report.gpu.sm_clock_ghz);
  } else {
    md["probe.gpu"] = fmt::format("none: {}", report.gpu.reason);
  }
  std::string failed;
  for (const auto& r : report.reports)
    if (r.error) failed += fmt::format("{}{}: {}", failed.empty() ? "" : "; ", r.probe, *r.error);
  if (!failed.empty()) md["probe.failed"] = failed;
  return prof;
}

}  // namespace dtflop::probes
