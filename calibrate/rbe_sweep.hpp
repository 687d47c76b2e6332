// Sweeps of the grid-based RBE workload: the seed's Test 1 and Test 2 (5.3.5), random
// configurations for held-out validation, or a plan file; and the measurement of one
// configuration on one backend as a sample.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "calibrate/profiler.hpp"
#include "calibrate/sample.hpp"
#include "calibrate/sweep.hpp"
#include "workloads/rbe/backend.hpp"

namespace dtflop::calib {

struct RbeSweepSettings {
  std::string backend;           // registered backend name
  rbe::BackendOptions options;   // memory, threads, layout, graph
  std::int64_t steps = 0;        // steps per repetition (0: the plan's default for the backend)
  int repetitions = 0;           // timed repetitions (0: default)
  int warmup = -1;               // discarded runs first (-1: default)
  std::uint64_t seed = 20261121; // random plans and synthetic problems
};

// Fills steps / repetitions / warmup left at their "default" values: device backends run 10
// steps per repetition, 7 repetitions traced by CUPTI then 7 untraced (the total and the host
// clocks), after 2 warm-up runs; host backends 1 step, 5 repetitions, 1 warm-up (their steps
// take up to a second).
RbeSweepSettings with_defaults(RbeSweepSettings s, bool device_backend);

// Builds a plan:
//   seed-test1   grid 1000x1000, kernel I x I for I = 1..200 (host backends: I = 1, 10, 20, ...,
//                200, since a float64 step at I = 200 takes about a second there)
//   seed-test2   kernel 16x16 and 32x32, grid n x n for n = 100, 150, ..., 1000 (host: every 100)
//   random:N     N configurations drawn from `seed`: n_x, n_y uniform in [100, 1000],
//                I_x, I_y uniform in [1, min(200, n)], for held-out validation
//   FILE.json    {"description": "...", "configs": [{"nx":..,"ny":..,"Ix":..,"Iy":..}, ...]}
// Throws InputError naming what is wrong with the spec or the file.
Plan rbe_plan(const std::string& spec, const RbeSweepSettings& settings, bool device_backend);

// The store key of a configuration: workload, backend, shape and every backend option.
std::string rbe_key(const std::string& backend, const rbe::Shape& shape, const rbe::BackendOptions& options);

// Measures one plan item: builds the backend and a synthetic problem, runs the warm-up, then
// the timed repetitions. With a profiler (device backends), copies and kernels are timed by
// CUPTI in a first set of repetitions and the total by the host clock in a second, untraced
// set; without one, every component comes from the backend's host timing and `no_profiler`
// (why CUPTI is unavailable) is written into the sample.
Sample measure_rbe(const PlanItem& item, const RbeSweepSettings& settings, const Plan& plan,
                   const MachineIdentity& machine, ActivityProfiler* profiler,
                   const std::string& no_profiler);

}  // namespace dtflop::calib
