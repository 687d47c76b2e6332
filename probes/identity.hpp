// Who the machine is: CPU model, cores, threads, clock, caches, host name, time of
// measurement (the GPU part comes from probes/gpu.hpp).
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "model/profile.hpp"

namespace dtflop::probes {

struct CpuInfo {
  std::string model;        // "AMD EPYC 7763 64-Core Processor"; "unknown CPU" when unreadable
  int cores = 0;            // physical cores (distinct physical id + core id), >= 1
  int threads = 0;          // hardware threads this process may use, >= 1
  std::optional<double> clock_ghz;  // nominal clock when the system says it
  std::string clock_source;         // where clock_ghz came from, e.g. "/proc/cpuinfo 'cpu MHz'"
  std::optional<std::int64_t> llc_bytes;  // last-level cache size the system reports (sysfs), when known
  // The largest cache of a level below the last (a core's L2), when known: cpu-memory's cache
  // ladder starts above it.
  std::optional<std::int64_t> private_cache_bytes;
};

// Reads /proc/cpuinfo and /sys (Linux); elsewhere fills what the standard library knows.
CpuInfo cpu_info();

// Host name, CPU part and the current time (ISO 8601 UTC); GPU fields left empty.
MachineIdentity host_identity();

// The NVIDIA kernel module's version ("580.159.04") from the first line of
// /proc/driver/nvidia/version, which reads "NVRM version: NVIDIA UNIX x86_64 Kernel Module
// 580.159.04 ..." or, for the open modules, "... Open Kernel Module for x86_64  580.159.04
// ...": the first word after "Kernel Module" that starts with a digit and holds a dot.
// Empty when the line has none.
std::string nvidia_driver_version(const std::string& first_line);

// The current UTC time as "2026-11-21T03:11:00Z".
std::string utc_now_iso8601();

}  // namespace dtflop::probes
