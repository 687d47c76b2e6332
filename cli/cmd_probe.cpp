// `dtflop probe`: measures this machine (CPU always, the GPU when there is one) and writes a
// machine profile for `dtflop predict`, with a readable table of what was measured.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cli/command.hpp"
#include "cli/table.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/stats.hpp"
#include "model/units.hpp"
#include "probes/machine.hpp"

namespace dtflop::cli {
namespace {

struct ProbeCliOptions {
  bool quick = false;
  std::string output;
  bool json = false;
  bool details = false;
  bool list = false;
  std::vector<std::string> only;
};

std::string value_str(double v, const std::string& unit) {
  if (unit == "x") return fmt::format("{:.3f}x", v);
  return format_quantity(v, unit);
}

std::string spread_str(const Stats& s) {
  return s.n > 1 ? fmt::format("{:.1f}%", 100 * s.spread()) : "-";
}

void print_identity(const probes::MachineReport& r, const MachineProfile& prof) {
  const auto& id = prof.identity;
  fmt::print("Machine {}: {} ({} cores, {} threads{})\n", id.hostname, id.cpu_model, id.cpu_cores,
             id.cpu_threads,
             id.cpu_clock_ghz ? fmt::format(", {:.3g} GHz nominal", *id.cpu_clock_ghz) : "");
  // The cache the model prices working sets against, and where its size came from.
  if (id.cpu_llc_effective_bytes > 0)
    fmt::print("Last-level cache: {} effective, measured (the system reports {})\n",
               format_bytes(static_cast<double>(id.cpu_llc_effective_bytes)),
               id.cpu_llc_bytes > 0 ? format_bytes(static_cast<double>(id.cpu_llc_bytes)) : std::string("no size"));
  else if (const auto it = prof.metadata.find("probe.cpu_llc_effective"); it != prof.metadata.end()) {
    // "none: <ladder>: no knee (<why>); the model uses ..."
    std::string why = it->second;
    if (const auto a = why.find("no knee ("), b = why.rfind("); the model"); a != std::string::npos && b != std::string::npos && b > a)
      why = why.substr(a + 9, b - a - 9);
    fmt::print("Last-level cache: {} as the system reports it; the cache ladder showed no knee: {}\n",
               id.cpu_llc_bytes > 0 ? format_bytes(static_cast<double>(id.cpu_llc_bytes)) : std::string("no size"), why);
  }
  else if (id.cpu_llc_bytes > 0)
    fmt::print("Last-level cache: {} as the system reports it (not measured)\n",
               format_bytes(static_cast<double>(id.cpu_llc_bytes)));
  if (r.gpu.usable)
    fmt::print("GPU: {} ({} SMs, compute capability {}.{}, {}), driver {}, CUDA runtime {}\n",
               r.gpu.name, r.gpu.sm_count, r.gpu.cc_major, r.gpu.cc_minor,
               format_bytes(static_cast<double>(r.gpu.total_bytes)), r.gpu.driver_version,
               r.gpu.runtime_version);
  else
    fmt::print("GPU: none ({})\n", r.gpu.reason);
  fmt::print("Measured {} ({} probe, {:.1f} s)\n", id.measured_at, probes::to_string(r.effort),
             r.seconds);
}

void print_tables(const probes::MachineReport& r, const MachineProfile& prof, bool details) {
  Table params({"parameter", "value", "+-95%", "spread", "how"}, "lrrrl");
  for (const auto& [p, v] : prof.params()) {
    const auto& i = info(p);
    const std::string unit(i.unit);
    std::string how = v.note;
    if (const auto colon = how.find(": "); how.rfind("dtflop probe ", 0) == 0 && colon != std::string::npos)
      how = how.substr(colon + 2);
    params.row({std::string(i.name), value_str(v.value, unit),
                v.uncertainty ? value_str(*v.uncertainty, unit) : "-",
                v.spread ? fmt::format("{:.1f}%", 100 * *v.spread) : "-", how});
  }
  fmt::print("\nModel parameters (spread: interquartile range / median of the repetitions):\n{}",
             params.str());
  std::vector<std::string> absent;
  for (const auto& i : all_params())
    if (!prof.has(i.id)) absent.push_back(std::string(i.name));
  if (!absent.empty())
    fmt::print("Not measured, so absent from the profile: {}\n", fmt::join(absent, ", "));

  Table other({"probe", "measurement", "value", "spread"}, "llrr");
  bool any = false;
  for (const auto& rep : r.reports)
    for (const auto& m : rep.measurements) {
      if (m.param || (m.detail && !details)) continue;
      other.row({rep.probe, m.label, value_str(m.value, m.unit), spread_str(m.stats)});
      any = true;
    }
  if (any)
    fmt::print("\nOther measurements{}:\n{}",
               details ? "" : " (--details adds every transfer size and every size of the cache ladder)",
               other.str());
  // Probes skipped for one reason (typically: no GPU) on one line.
  std::vector<std::pair<std::string, std::vector<std::string>>> skipped;
  for (const auto& rep : r.reports) {
    if (!rep.skipped) continue;
    auto it = std::find_if(skipped.begin(), skipped.end(),
                           [&rep](const auto& s) { return s.first == *rep.skipped; });
    if (it == skipped.end()) it = skipped.insert(skipped.end(), {*rep.skipped, {}});
    it->second.push_back(rep.probe);
  }
  for (const auto& [reason, names] : skipped)
    fmt::print("\nSkipped {}: {}\n", fmt::join(names, ", "), reason);
  for (const auto& rep : r.reports)
    if (rep.error) fmt::print("\nFAILED {}: {}\n", rep.probe, *rep.error);
}

void run(const ProbeCliOptions& o) {
  if (o.list) {
    Table t({"probe", "device", "what it measures"}, "lll");
    for (const auto& p : probes::all_probes())
      t.row({p.name, p.needs_gpu ? "GPU" : "CPU", p.description});
    fmt::print("{}", t.str());
    return;
  }
  probes::ProbeOptions po;
  po.effort = o.quick ? probes::Effort::quick : probes::Effort::full;
  po.progress = [](const std::string& line) {
    fmt::print(stderr, "{}\n", line);
    std::fflush(stderr);
  };
  const probes::MachineReport report = probes::probe_machine(po, o.only);
  const MachineProfile prof = probes::make_profile(report);
  if (!o.output.empty()) {
    save_profile(prof, o.output);
    fmt::print(stderr, "dtflop probe: wrote {}\n", o.output);
  }
  if (o.json)
    fmt::print("{}\n", to_json(prof).dump(2));
  else {
    print_identity(report, prof);
    print_tables(report, prof, o.details);
  }
  if (report.failed()) {
    std::string which;
    for (const auto& r : report.reports)
      if (r.error) which += fmt::format("{}{} ({})", which.empty() ? "" : "; ", r.probe, *r.error);
    throw std::runtime_error(fmt::format(
        "probe failed: {}; its parameters are absent from the profile{}", which,
        o.output.empty() ? "" : " that was written"));
  }
}

}  // namespace

void add_probe_command(CLI::App& root) {
  auto* app = root.add_subcommand(
      "probe",
      "Measure this machine: host and device memory bandwidths, host<->device transfers "
      "(latency + bandwidth), CPU and GPU FLOP rates, kernel launch overhead. Writes a machine "
      "profile for `dtflop predict`.");
  auto o = std::make_shared<ProbeCliOptions>();
  app->add_flag("--quick", o->quick,
                "Fewer sizes and repetitions: under 30 s on a 2-core machine without GPU");
  app->add_option("-o,--output", o->output, "Write the machine profile (JSON) to this file");
  app->add_flag("--json", o->json, "Print the profile as JSON on stdout instead of tables");
  app->add_flag("--details", o->details,
                "Also print every point of the transfer sweeps and of the cache ladder");
  app->add_option("--only", o->only, "Run only these probes (comma-separated; see --list)")
      ->delimiter(',');
  app->add_flag("--list", o->list, "List the probes and exit");
  app->callback([o] { run(*o); });
}

}  // namespace dtflop::cli
