// Identity of the machine dtflop runs on, recorded in every sample, and the rule by which a
// sample and a machine profile are judged to come from the same machine.
#pragma once

#include <string>

#include "model/profile.hpp"

namespace dtflop::calib {

// Hostname, CPU model, physical cores and hardware threads, and - when dtflop was built with
// CUDA and a device is usable - device 0's name, the driver and runtime versions, read by the
// same functions as `dtflop probe` (probes/identity.hpp, probes/gpu.hpp). `measured_at` is left
// empty.
MachineIdentity this_machine();

// Same machine: the same CPU model and hardware thread count, and the same GPU (or none on
// both). The hostname is not compared: lent machines of one kind get a new name each time.
// When they differ, `why` (if given) says what differs, in words.
bool same_machine(const MachineIdentity& a, const MachineIdentity& b, std::string* why = nullptr);

// One line for people: "AMD EPYC 7B13 (2 threads) + NVIDIA H200 on host x".
std::string describe(const MachineIdentity& id);

}  // namespace dtflop::calib
