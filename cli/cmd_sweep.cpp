// `dtflop sweep rbe`: measure the RBE workload over a plan (the seed's Test 1 / Test 2, random
// held-out configurations, or a plan file) on one backend, appending one sample per
// configuration to a resumable JSON-lines store.
#include <cstdio>
#include <memory>
#include <string>

#include <fmt/format.h>

#include "calibrate/machine.hpp"
#include "calibrate/profiler.hpp"
#include "calibrate/rbe_sweep.hpp"
#include "calibrate/sweep.hpp"
#include "cli/command.hpp"
#include "model/errors.hpp"

namespace dtflop::cli {
namespace {

using namespace dtflop::calib;

struct SweepOptions {
  std::string plan;
  std::string backend;
  std::string store;
  std::string memory = "pageable";
  int threads = 0;
  std::string layout;
  bool no_graph = false;
  std::int64_t steps = 0;
  int reps = 0;
  int rounds = 1;
  int warmup = -1;
  std::uint64_t seed = 20261121;
  bool no_cupti = false;
  bool quiet = false;
};

void run(const SweepOptions& o) {
  RbeSweepSettings st;
  st.backend = o.backend;
  if (o.memory == "pinned") st.options.host_memory = HostMemory::pinned;
  else if (o.memory != "pageable")
    throw InputError(fmt::format("--memory '{}' is unknown; use pageable or pinned", o.memory));
  if (o.threads < 0) throw InputError(fmt::format("--threads must be >= 0 (0: every hardware thread), got {}", o.threads));
  st.options.threads = o.threads;
  if (!o.layout.empty()) st.options.layout = rbe::parse_layout(o.layout);
  st.options.graph = !o.no_graph;
  if (o.steps < 0 || o.reps < 0) throw InputError("--steps and --reps must be positive");
  if (o.reps == 1) throw InputError("--reps must be at least 2, so a sample has a spread");
  if (o.rounds < 1 || o.rounds > 1000)
    throw InputError(fmt::format("--rounds must be between 1 and 1000 (each round measures every configuration of "
                                 "the plan once; 3 is a good choice), got {}",
                                 o.rounds));
  st.steps = o.steps;
  st.repetitions = o.reps;
  st.warmup = o.warmup;
  st.seed = o.seed;

  // Fails here, before anything is measured, for an unknown backend or a GPU backend without a device.
  const bool device = rbe::make_backend(st.backend, st.options)->needs_gpu();
  if (device) {
    const std::string why = rbe::cuda_unavailable_reason();
    if (!why.empty()) throw rbe::DeviceUnavailable(fmt::format("backend {}: {}", st.backend, why));
  }
  st = with_defaults(st, device);
  const Plan plan = rbe_plan(o.plan, st, device);

  ProfilerOpen prof;
  if (device) {
    if (o.no_cupti) prof.why_not = "--no-cupti was given";
    else prof = open_cupti_profiler();
    if (!prof.profiler && !o.quiet)
      fmt::print(stderr, "dtflop: warning: CUPTI unavailable ({}); timing copies and kernels with host clocks and "
                         "saying so in every sample\n",
                 prof.why_not);
  }
  const MachineIdentity here = this_machine();
  if (!o.quiet) {
    fmt::print(stderr, "{}\n", plan.description);
    fmt::print(stderr, "backend {} on {}: {} steps per repetition, {} repetitions{}, {} warm-up{}\n", st.backend,
               describe(here), st.steps, st.repetitions,
               prof.profiler ? " traced by CUPTI + the same untraced for the total" : "", st.warmup,
               o.rounds > 1 ? fmt::format(", {} rounds over the plan", o.rounds) : std::string());
  }
  // The first configuration a process measures runs slower (clocks ramping up, first
  // allocations, lazy loading of the device's modules): measure it once, unrecorded, first.
  bool warmed = false;
  const SweepReport r = run_sweep(
      plan, o.store, here,
      [&](const PlanItem& item) {
        if (!warmed) {
          measure_rbe(item, st, plan, here, prof.profiler.get(), prof.why_not);
          warmed = true;
        }
        return measure_rbe(item, st, plan, here, prof.profiler.get(), prof.why_not);
      },
      o.quiet ? nullptr : stderr, o.rounds);
  if (o.quiet)
    for (const auto& w : r.warnings) fmt::print(stderr, "dtflop: warning: {}\n", w);
  if (r.rounds == 1)
    fmt::print("{}: {} configurations, {} measured now, {} already in {}\n", plan.name, r.planned, r.measured,
               r.already, o.store);
  else
    fmt::print("{}: {} configurations x {} rounds = {} samples, {} measured now, {} already in {}\n", plan.name,
               r.configurations, r.rounds, r.planned, r.measured, r.already, o.store);
}

Registrar reg(30, [](CLI::App& root) {
  auto& sweep = group(root, "sweep",
                      "Measure a workload over a plan of configurations, one sample per configuration (and round, "
                      "with --rounds), into a resumable sample store (JSON lines): rerunning the same command "
                      "measures only what is missing.");
  auto* app = sweep.add_subcommand(
      "rbe", "Sweep the grid-based RBE: the seed's Test 1 and Test 2 (5.3.5), random held-out configurations, or "
             "a plan file, on one backend");
  auto o = std::make_shared<SweepOptions>();
  app->add_option("--plan,-p", o->plan, "seed-test1, seed-test2, random:N or a plan file (JSON)")->required();
  app->add_option("--backend,-b", o->backend, "cpu-seq, cpu-par, cuda-seed or cuda-resident")->required();
  app->add_option("--store,-s", o->store, "Sample store to append to (JSON lines; created if missing)")
      ->required();
  app->add_option("--memory", o->memory, "cuda-seed host buffers: pageable or pinned")->capture_default_str();
  app->add_option("--threads", o->threads, "cpu-par threads (0: every hardware thread)")->capture_default_str();
  app->add_option("--layout", o->layout, "cuda-resident block layout, e.g. 32x8x4 or 32x8x4:split");
  app->add_flag("--no-graph", o->no_graph, "cuda-resident: launch kernel by kernel instead of a CUDA graph");
  app->add_option("--steps", o->steps, "Steps per repetition (default: 10 on a GPU, 1 on the CPU)");
  app->add_option("--reps", o->reps, "Timed repetitions per configuration (default 5)");
  app->add_option("--warmup", o->warmup, "Untimed runs first (default 1)");
  app->add_option("--rounds", o->rounds,
                  "Measure the whole plan this many times, round after round: a sample's repetitions run back "
                  "to back, so a slow spell of the machine (seconds to a minute) moves a whole sample; rounds "
                  "spread each configuration over the sweep, and calibrate/validate combine its rounds (the "
                  "median, or the fastest: --rounds-combine). Round r >= 2 is stored under the key "
                  "<key>/round=r; resuming measures only the missing rounds, so --rounds r on a store holding "
                  "r - 1 rounds adds one round (interleave sweeps round by round that way)")
      ->capture_default_str();
  app->add_option("--seed", o->seed, "Seed of random plans and of the synthetic problems")->capture_default_str();
  app->add_flag("--no-cupti", o->no_cupti, "Time device work with host clocks only");
  app->add_flag("--quiet,-q", o->quiet, "No progress on stderr (warnings still)");
  app->callback([o] { run(*o); });
});

}  // namespace
}  // namespace dtflop::cli
