// Workloads of `dtflop predict` from the RBE reference workload (seed ch. 5).
#include <memory>
#include <string>

#include <fmt/format.h>

#include "cli/command.hpp"
#include "model/units.hpp"
#include "workloads/rbe/counts.hpp"

namespace dtflop::cli {
namespace {

struct ShapeOptions {
  std::string grid = "1000x1000";
  std::string kernel = "33x33";
  bool pinned = false;
};

std::shared_ptr<ShapeOptions> add_shape_options(CLI::App& app, bool memory_flag) {
  auto o = std::make_shared<ShapeOptions>();
  app.add_option("--grid", o->grid, "Grid size n_x x n_y, e.g. 1000x1000")->capture_default_str();
  app.add_option("--kernel", o->kernel, "Motion-model kernel size I_x x I_y, e.g. 33x33")
      ->capture_default_str();
  if (memory_flag) app.add_flag("--pinned", o->pinned, "Host buffers are pinned (default: pageable)");
  return o;
}

rbe::Shape parse_shape(const ShapeOptions& o) {
  const auto g = parse_size2(o.grid, "--grid", 1 << 20);
  const auto k = parse_size2(o.kernel, "--kernel", 1 << 20);
  rbe::Shape s{g.x, g.y, k.x, k.y};
  rbe::validate(s);
  return s;
}

nlohmann::json shape_json(const rbe::Shape& s) {
  return {{"nx", s.nx}, {"ny", s.ny}, {"Ix", s.Ix}, {"Iy", s.Iy}};
}

PredictRegistrar seed_gpu({"rbe-seed",
                           "The seed's GPU RBE pipeline (5.3.1): belief shipped to the GPU and "
                           "back every step, sum on the CPU (eqs. 5.10-5.16)",
                           [](CLI::App& app) -> CountsFn {
                             auto o = add_shape_options(app, true);
                             return [o](const MachineProfile*) {
                               const auto s = parse_shape(*o);
                               const auto mem = o->pinned ? HostMemory::pinned : HostMemory::pageable;
                               return CountsResult{
                                   rbe::seed_gpu_counts(s, mem), shape_json(s),
                                   fmt::format("rbe-seed: seed GPU RBE pipeline, grid {}x{}, kernel {}x{}, "
                                               "{} host memory",
                                               s.nx, s.ny, s.Ix, s.Iy, to_string(mem))};
                             };
                           }});

PredictRegistrar conventional({"rbe-conventional",
                               "The conventional sequential RBE step on the CPU: full 2D "
                               "convolution (4.10) and correction, float64",
                               [](CLI::App& app) -> CountsFn {
                                 auto o = add_shape_options(app, false);
                                 return [o](const MachineProfile*) {
                                   const auto s = parse_shape(*o);
                                   return CountsResult{
                                       rbe::conventional_cpu_counts(s), shape_json(s),
                                       fmt::format("rbe-conventional: sequential CPU RBE step, full 2D "
                                                   "convolution, grid {}x{}, kernel {}x{}",
                                                   s.nx, s.ny, s.Ix, s.Iy)};
                                 };
                               }});

}  // namespace
}  // namespace dtflop::cli

// The backends of workloads/rbe, each with its exact counts (backend_counts.hpp).
#include "workloads/rbe/backend.hpp"

namespace dtflop::cli {
namespace {

struct BackendShapeOptions {
  std::string grid = "1000x1000";
  std::string kernel = "33x33";
  std::string layout;
  int threads = 0;
  bool full = false;
};

CountsFn backend_target(CLI::App& app, const std::string& backend) {
  auto o = std::make_shared<BackendShapeOptions>();
  app.add_option("--grid", o->grid, "Grid size n_x x n_y, e.g. 1000x1000")->capture_default_str();
  app.add_option("--kernel", o->kernel, "Motion-model kernel size I_x x I_y, e.g. 33x33")->capture_default_str();
  if (backend == "cuda-resident")
    app.add_option("--layout", o->layout, "Block layout BXxBY[xCELLS][:fused|:split], e.g. 32x8x16");
  if (backend == "cpu-par") app.add_option("--threads", o->threads, "CPU threads (0: all)")->capture_default_str();
  if (backend != "cuda-resident") app.add_flag("--full", o->full, "The full 2D convolution (4.10) instead of the separable one");
  return [o, backend](const MachineProfile* machine) {
    const auto g = parse_size2(o->grid, "--grid", 1 << 20);
    const auto k = parse_size2(o->kernel, "--kernel", 1 << 20);
    const rbe::Shape s{g.x, g.y, k.x, k.y};
    rbe::validate(s);
    rbe::BackendOptions opts;
    opts.threads = o->threads;
    if (!o->layout.empty()) opts.layout = rbe::parse_layout(o->layout);
    if (o->full) opts.prediction = rbe::Prediction::full;
    // cuda-resident's waves are rounds of blocks on the profile's GPU; without one, this
    // machine's GPU, else kDefaultGpuSms (counted_gpu_sms).
    std::string sms_from;
    if (backend == "cuda-resident") {
      if (machine && machine->identity.gpu_sms > 0) {
        opts.gpu_sms = machine->identity.gpu_sms;
        sms_from = "the machine profile";
      } else {
        sms_from = rbe::cuda_device_sms() > 0 ? "this machine's GPU" : "the default, an H100/H200 SXM";
        if (machine) sms_from += "; the profile does not say";
        opts.gpu_sms = rbe::counted_gpu_sms(opts);
      }
    }
    const CostCounts c = rbe::step_counts(backend, s, opts);
    nlohmann::json params = {{"nx", s.nx}, {"ny", s.ny}, {"Ix", s.Ix}, {"Iy", s.Iy}, {"backend", backend}};
    std::string extra;
    if (backend == "cuda-resident") {
      params["layout"] = rbe::to_string(opts.layout);
      params["gpu_sms"] = opts.gpu_sms;
      extra = fmt::format(", layout {}, {} multiprocessors ({})", rbe::to_string(opts.layout), opts.gpu_sms, sms_from);
    }
    if (backend == "cpu-par") {
      params["threads"] = c.cpu_threads;
      extra = fmt::format(", {} threads", c.cpu_threads);
    }
    return CountsResult{c, params,
                        fmt::format("rbe-{}: one RBE step on {}, grid {}x{}, kernel {}x{}{}", backend, backend, s.nx,
                                    s.ny, s.Ix, s.Iy, extra)};
  };
}

PredictRegistrar cpu_seq_target({"rbe-cpu-seq", "One RBE step on cpu-seq (float64, one thread)",
                                 [](CLI::App& app) { return backend_target(app, "cpu-seq"); }});
PredictRegistrar cpu_par_target({"rbe-cpu-par", "One RBE step on cpu-par (float32, every CPU thread)",
                                 [](CLI::App& app) { return backend_target(app, "cpu-par"); }});
PredictRegistrar resident_target({"rbe-cuda-resident",
                                  "One RBE step on cuda-resident (belief resident on the GPU, fused kernel)",
                                  [](CLI::App& app) { return backend_target(app, "cuda-resident"); }});

}  // namespace
}  // namespace dtflop::cli
