// The measurement protocol every workload's backends go through, and plans as sweep items.
//
// A configuration is measured in repetitions of `steps` steps (frames): `warmup` untimed
// repetitions, then, for a GPU backend with a CUPTI profiler, `repetitions` traced ones (CUPTI's
// device-side durations of copies and kernels, and a check of the declared counts against what
// CUPTI saw: copies, bytes, kernels), then `repetitions` untraced ones for the total and the host
// clocks of each phase. A phase the backend brackets with host clocks (issue .. completion) is
// what a step pays for it and is the component; a phase it does not bracket comes from CUPTI.
// CPU backends are timed by host clocks alone, with the process's CPU time beside the wall time
// (a utilization under ~0.9 says another process shared the machine).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "calibrate/profiler.hpp"
#include "calibrate/sample.hpp"
#include "calibrate/sweep.hpp"
#include "workloads/workload.hpp"

namespace dtflop::calib {

struct MeasureSettings {
  std::int64_t steps = 0;  // steps (frames) per repetition; 0: the workload's default for the backend
  int repetitions = 0;     // timed repetitions; 0: default
  int warmup = -1;         // untimed repetitions first; -1: default
};
// Throws InputError for values no protocol can use (fewer than 2 repetitions, negative counts).
void check(const MeasureSettings& s);
// `s` with its defaults filled from the workload's defaults for `backend`.
MeasureSettings with_defaults(MeasureSettings s, const workload::Workload& w, const workload::Backend& backend);

// The protocol of one sweep or run: its settings and, for a GPU backend, the CUPTI profiler.
struct Protocol {
  MeasureSettings settings;
  ActivityProfiler* profiler = nullptr;       // null: host clocks only
  std::string no_profiler;                     // why there is no profiler (GPU backends)
  std::shared_ptr<ActivityProfiler> owned;     // the profiler open_protocol opened
};
// Opens the protocol for `backend`: defaults filled, CUPTI opened for a GPU backend unless
// `no_cupti`. Throws DeviceUnavailable (an InputError) when the backend cannot run here.
Protocol open_protocol(const workload::Workload& w, const workload::Backend& backend, MeasureSettings settings,
                       bool no_cupti);

// Measures `config` on `backend` by the protocol. `key` and `plan` are stored in the sample;
// with `timeline`, the last CUPTI-traced repetition's timeline goes there (calibrate/timeline.hpp;
// left empty without a profiler). Throws std::runtime_error when the computation fails.
Sample measure(const workload::Workload& w, const workload::Backend& backend, const workload::Config& config,
               Protocol& protocol, const MachineIdentity& machine, const std::string& key, const std::string& plan,
               nlohmann::json* timeline = nullptr);

// The workload's plan `spec` for `backend` as sweep items (key, label, configuration), with the
// parameters in `fixed` (e.g. {"threads": 2}) set in every configuration. Throws InputError when
// `fixed` sets a parameter the plan varies, or the plan holds no configuration.
Plan sweep_plan(const workload::Workload& w, const workload::Backend& backend, const std::string& spec,
                std::uint64_t seed, const nlohmann::json& fixed = nlohmann::json::object());

}  // namespace dtflop::calib
