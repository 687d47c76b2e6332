// `dtflop sweep WORKLOAD`: measure a workload over a plan (its named plans, random held-out
// configurations, or a plan file) on one backend, appending one sample per configuration to a
// resumable JSON-lines store. The same path for every workload.
#include <cstdio>
#include <memory>
#include <string>

#include <fmt/format.h>

#include "calibrate/machine.hpp"
#include "calibrate/profiler.hpp"
#include "calibrate/measure.hpp"
#include "calibrate/sweep.hpp"
#include "cli/command.hpp"
#include "cli/workload_cli.hpp"
#include "model/errors.hpp"

namespace dtflop::cli {
namespace {

using namespace dtflop::calib;

struct SweepOptions {
  std::string plan;
  std::string store;
  MeasureSettings measure;
  int rounds = 1;
  std::uint64_t seed = 20261121;
  bool no_cupti = false;
  bool quiet = false;
  bool json = false;
};

void run(const SweepOptions& o, const WorkloadArgs& a) {
  const workload::Workload& w = *a.workload;
  if (!a.tuned.empty())
    throw InputError("--tuned names one configuration; a sweep measures a plan (--plan), so drop --tuned");
  if (a.backend.empty()) throw InputError(fmt::format("name the backend to sweep with --backend ({})", w.backend_names()));
  const workload::Backend& b = w.backend(a.backend);
  nlohmann::json fixed = nlohmann::json::object();
  for (const auto& [k, v] : a.values) fixed[k] = v;
  if (o.rounds < 1 || o.rounds > 1000)
    throw InputError(fmt::format("--rounds must be between 1 and 1000 (each round measures every configuration of "
                                 "the plan once; 3 is a good choice), got {}",
                                 o.rounds));
  // Fails here, before anything is measured: bad settings, a GPU backend without a device, a bad plan.
  Protocol protocol = open_protocol(w, b, o.measure, o.no_cupti);
  const Plan plan = sweep_plan(w, b, o.plan, o.seed, fixed);
  if (b.needs_gpu() && !protocol.profiler && !o.quiet)
    fmt::print(stderr, "dtflop: warning: CUPTI unavailable ({}); timing copies and kernels with host clocks and "
                       "saying so in every sample\n",
               protocol.no_profiler);
  const MachineIdentity here = this_machine();
  const MeasureSettings& st = protocol.settings;
  if (!o.quiet) {
    fmt::print(stderr, "{}\n", plan.description);
    fmt::print(stderr, "{} backend {} on {}: {} {}s per repetition, {} repetitions{}, {} warm-up{}\n", w.name(),
               b.name(), describe(here), st.steps, w.step_name(), st.repetitions,
               protocol.profiler ? " traced by CUPTI + the same untraced for the total" : "", st.warmup,
               o.rounds > 1 ? fmt::format(", {} rounds over the plan", o.rounds) : std::string());
  }
  // The first configuration a process measures runs slower (clocks ramping up, first
  // allocations, lazy loading of the device's modules): measure it once, unrecorded, first.
  bool warmed = false;
  const SweepReport r = run_sweep(
      plan, o.store, here,
      [&](const PlanItem& item) {
        if (!warmed) {
          measure(w, b, item.parameters, protocol, here, item.key, plan.name);
          warmed = true;
        }
        return measure(w, b, item.parameters, protocol, here, item.key, plan.name);
      },
      o.quiet ? nullptr : stderr, o.rounds);
  if (o.quiet)
    for (const auto& warning : r.warnings) fmt::print(stderr, "dtflop: warning: {}\n", warning);
  if (o.json) {
    const nlohmann::json out = {{"workload", std::string(w.name())}, {"backend", b.name()},
                                {"plan", plan.name},                 {"description", plan.description},
                                {"store", o.store},                  {"configurations", r.configurations},
                                {"rounds", r.rounds},                {"planned", r.planned},
                                {"measured", r.measured},            {"already", r.already},
                                {"warnings", r.warnings}};
    fmt::print("{}\n", out.dump(2));
    return;
  }
  if (r.rounds == 1)
    fmt::print("{}: {} configurations, {} measured now, {} already in {}\n", plan.name, r.planned, r.measured,
               r.already, o.store);
  else
    fmt::print("{}: {} configurations x {} rounds = {} samples, {} measured now, {} already in {}\n", plan.name,
               r.configurations, r.rounds, r.planned, r.measured, r.already, o.store);
}

}  // namespace

void add_sweep_command(CLI::App& root) {
  auto* app = root.add_subcommand(
      "sweep", "Measure a workload over a plan of configurations on one backend, one sample per configuration (and "
               "round, with --rounds), into a resumable sample store (JSON lines): rerunning the same command "
               "measures only what is missing.");
  auto o = std::make_shared<SweepOptions>();
  app->add_option("--plan,-p", o->plan, "A plan of the workload (see its --help), random:N, or a plan file (JSON)")
      ->required();
  app->add_option("--store,-s", o->store, "Sample store to append to (JSON lines; created if missing)")->required();
  add_measure_options(*app, o->measure, o->no_cupti);
  app->add_option("--rounds", o->rounds,
                  "Measure the whole plan this many times, round after round: a sample's repetitions run back "
                  "to back, so a slow spell of the machine (seconds to a minute) moves a whole sample; rounds "
                  "spread each configuration over the sweep, and calibrate/validate combine its rounds "
                  "(--rounds-combine). Round r >= 2 is stored under the key <key>/round=r; resuming measures only "
                  "the missing rounds")
      ->capture_default_str();
  app->add_option("--seed", o->seed, "Seed of random plans")->capture_default_str()->check(number_in(0, std::numeric_limits<std::uint64_t>::max(), true));
  app->add_flag("--quiet,-q", o->quiet, "No progress on stderr (warnings still)");
  app->add_flag("--json", o->json, "Print the sweep's report as JSON");
  add_workload_subcommands(
      *app, [o](const WorkloadArgs& a) { run(*o, a); },
      [](const workload::Workload& w) {
        std::string plans;
        for (const auto& [name, what] : w.plan_names()) plans += fmt::format("\n  {}: {}", name, what);
        return fmt::format("Sweep {} ({}). Plans:{}\n  FILE.json: {{\"description\": ..., \"configs\": [{{parameter: "
                           "value, ...}}, ...]}}",
                           w.name(), w.description(), plans);
      });
}

}  // namespace dtflop::cli
