// `dtflop run rbe`: runs grid-RBE steps on one backend and prints the measured time per step
// and its components (host clocks; CUDA events inside cuda-resident's graph), the backend's
// exact cost counts and, with --machine, the DTFLOP model's prediction beside the measurement.
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include <fmt/format.h>

#include "cli/command.hpp"
#include "cli/model_tables.hpp"
#include "cli/table.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/predict.hpp"
#include "model/units.hpp"
#include "workloads/rbe/backend.hpp"

namespace dtflop::cli {
namespace {

struct RunRbeOptions {
  std::string backend = "cuda-resident";
  std::string grid = "1000x1000";
  std::string kernel = "33x33";
  std::int64_t steps = 1000;
  std::string layout;
  int threads = 0;
  bool pinned = false;
  bool no_graph = false;
  std::uint64_t seed = 42;
  std::string machine;
  std::string variant = "extended";
  bool json = false;
};

std::string us(double s) { return format_duration(s); }

void merge(rbe::RunResult& into, const rbe::RunResult& part) {
  into.steps += part.steps;
  into.samples.insert(into.samples.end(), part.samples.begin(), part.samples.end());
  into.sums.insert(into.sums.end(), part.sums.begin(), part.sums.end());
  into.wall_seconds += part.wall_seconds;
  into.setup_seconds += part.setup_seconds;
  into.steps_per_sample = part.steps_per_sample;
}

void run(const RunRbeOptions& o) {
  const auto variant = variant_from_string(o.variant);
  if (!variant) throw InputError(fmt::format("--variant '{}' is unknown; use {}", o.variant, variant_names()));
  if (o.steps < 1) throw InputError(fmt::format("--steps {} must be at least 1", o.steps));
  const auto g = parse_size2(o.grid, "--grid", 65536);
  const auto k = parse_size2(o.kernel, "--kernel", 65536);
  const rbe::Shape shape{g.x, g.y, k.x, k.y};
  rbe::validate(shape);

  rbe::BackendOptions opts;
  opts.host_memory = o.pinned ? HostMemory::pinned : HostMemory::pageable;
  opts.threads = o.threads;
  opts.graph = !o.no_graph;
  if (!o.layout.empty()) opts.layout = rbe::parse_layout(o.layout);
  auto backend = rbe::make_backend(o.backend, opts);
  if (o.layout.size() && o.backend != "cuda-resident")
    throw InputError(fmt::format("--layout applies to cuda-resident only, not {}", o.backend));
  if (o.pinned && o.backend != "cuda-seed")
    throw InputError(fmt::format("--pinned applies to cuda-seed only, not {}", o.backend));

  std::optional<MachineProfile> profile;
  if (!o.machine.empty()) profile = load_profile(o.machine);  // before the run: fail early

  backend->init(rbe::synthetic_problem(shape, o.seed));
  // Warm-up (module load, graph capture), then the measured run in pieces with progress.
  backend->run(std::min<std::int64_t>(o.steps, 50));
  rbe::RunResult r;
  const std::int64_t piece = std::max<std::int64_t>(1000, (o.steps + 9) / 10);
  for (std::int64_t done = 0; done < o.steps;) {
    const std::int64_t n = std::min(piece, o.steps - done);
    merge(r, backend->run(n));
    done += n;
    if (r.wall_seconds > 1 && done < o.steps)
      fmt::print(stderr, "dtflop run rbe: {}/{} steps ({:.0f}%)\n", done, o.steps, 100.0 * double(done) / double(o.steps));
  }
  const rbe::StepTimes m = r.median();
  const CostCounts counts = backend->step_counts(shape, opts);
  std::optional<Prediction> pred;
  if (profile) pred = predict(*profile, counts, *variant);

  nlohmann::json parts = nlohmann::json::object();
  for (auto c : r.components()) parts[std::string(rbe::to_string(c))] = m.part(c);
  nlohmann::json out = {
      {"workload", "rbe"},
      {"backend", o.backend},
      {"grid", {{"nx", shape.nx}, {"ny", shape.ny}}},
      {"kernel", {{"Ix", shape.Ix}, {"Iy", shape.Iy}}},
      {"steps", o.steps},
      {"options",
       {{"layout", rbe::to_string(opts.layout)},
        {"threads", opts.threads},
        {"host_memory", std::string(to_string(opts.host_memory))},
        {"graph", opts.graph}}},
      {"device", backend->needs_gpu() ? rbe::cuda_device_name() : std::string()},
      {"measured",
       {{"step_median", m.total},
        {"components_median", parts},
        {"wall_per_step", r.wall_seconds / double(r.steps)},
        {"samples", r.samples.size()},
        {"steps_per_sample", r.steps_per_sample},
        {"setup", r.setup_seconds}}},
      {"counts", to_json(counts)},
      {"kernels", backend->kernel_names()}};
  if (pred) {
    out["prediction"] = to_json(*pred);
    out["predicted_over_measured"] = pred->total / m.total;
  }
  if (o.json) {
    fmt::print("{}\n", out.dump(2));
    return;
  }
  fmt::print("rbe on {}{}: grid {}x{}, kernel {}x{}, {} steps{}\n", o.backend,
             backend->needs_gpu() ? " (" + rbe::cuda_device_name() + ")" : "", shape.nx, shape.ny, shape.Ix, shape.Iy,
             o.steps, o.backend == "cuda-resident" ? ", layout " + rbe::to_string(opts.layout) : "");
  fmt::print("\nMeasured per step (median of {} samples of {} step{}):\n", r.samples.size(), r.steps_per_sample,
             r.steps_per_sample == 1 ? "" : "s");
  Table t({"component", "time", "share"});
  for (auto c : r.components())
    t.row({std::string(rbe::to_string(c)), us(m.part(c)), fmt::format("{:.1f}%", 100 * m.part(c) / m.total)});
  t.row({"step", us(m.total), ""});
  t.row({"wall / step", us(r.wall_seconds / double(r.steps)), "(whole run, host clock)"});
  fmt::print("{}", t.str());
  fmt::print("\nCost counts per step:\n");
  print_counts(counts);
  if (!pred) {
    fmt::print("\n(add --machine machine.json for the model's prediction)\n");
    return;
  }
  fmt::print("\nPredicted by the DTFLOP model ({} variant) on {}:\n", to_string(*variant),
             profile->identity.gpu_name.empty() ? profile->identity.cpu_model : profile->identity.gpu_name);
  print_prediction(*pred);
  fmt::print("predicted / measured: {:.2f}\n", pred->total / m.total);
}

Registrar reg(40, [](CLI::App& root) {
  auto& run_group = group(root, "run", "Run a reference workload and measure it");
  auto* app = run_group.add_subcommand(
      "rbe", "Run grid-based RBE steps (predict, correct, normalize) on one backend; print the measured "
             "time per step and its components, the cost counts and, with --machine, the prediction.");
  auto o = std::make_shared<RunRbeOptions>();
  std::string names;
  for (const auto& b : rbe::backends()) names += (names.empty() ? "" : "|") + b.name;
  app->add_option("--backend,-b", o->backend, names)->capture_default_str();
  app->add_option("--grid", o->grid, "Grid n_x x n_y, e.g. 1000x1000")->capture_default_str();
  app->add_option("--kernel", o->kernel, "Motion kernel I_x x I_y, e.g. 33x33")->capture_default_str();
  app->add_option("--steps", o->steps, "Steps to run and time")->capture_default_str();
  app->add_option("--layout", o->layout, "cuda-resident block layout BXxBY[xCELLS][:fused|:split], e.g. 32x8x8");
  app->add_option("--threads", o->threads, "cpu-par threads (0: all)")->capture_default_str();
  app->add_flag("--pinned", o->pinned, "cuda-seed: pinned host buffers (default pageable)");
  app->add_flag("--no-graph", o->no_graph, "cuda-resident: launch kernel by kernel instead of a CUDA graph");
  app->add_option("--seed", o->seed, "Seed of the synthetic problem")->capture_default_str();
  app->add_option("--machine,-m", o->machine, "Machine profile (JSON) for the model's prediction")
      ->check(CLI::ExistingFile);
  app->add_option("--variant", o->variant, "Model variant: " + variant_names(", "))->capture_default_str();
  app->add_flag("--json", o->json, "Print JSON instead of tables");
  app->callback([o] { run(*o); });
});

}  // namespace
}  // namespace dtflop::cli
