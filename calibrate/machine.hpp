// Identity of the machine dtflop runs on, recorded in every sample (the rule by which a sample
// and a machine profile are judged to come from the same machine is model/profile.hpp's same_machine).
#pragma once

#include <string>

#include "model/profile.hpp"

namespace dtflop::calib {

// Hostname, CPU model, physical cores and hardware threads, and - when dtflop was built with
// CUDA and a device is usable - device 0's name, the driver and runtime versions, read by the
// same functions as `dtflop probe` (probes/identity.hpp, probes/gpu.hpp). `measured_at` is left
// empty.
MachineIdentity this_machine();

}  // namespace dtflop::calib
