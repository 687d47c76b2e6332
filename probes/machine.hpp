// Runs the probes and turns their measurements into a MachineProfile.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "model/profile.hpp"
#include "probes/gpu.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes {

struct MachineReport {
  MachineIdentity identity;
  gpu::DeviceInfo gpu;
  Effort effort = Effort::full;
  std::vector<ProbeReport> reports;
  double seconds = 0;
  // True when a probe failed: its parameters are absent and `dtflop probe` exits non-zero.
  bool failed() const;
};

// Runs the probes named in `only` (every probe when empty), in order. A probe that throws is
// recorded with its error and the others still run. Throws InputError naming the known
// probes when `only` holds an unknown name.
MachineReport probe_machine(const ProbeOptions& options, std::span<const std::string> only = {});

// The profile: identity, every measurement that is a model parameter (value, spread,
// uncertainty, note; provenance "probed"), and metadata on how it was probed. Parameters
// whose probe was skipped or failed are absent.
MachineProfile make_profile(const MachineReport& report);

}  // namespace dtflop::probes
