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
                             return [o] {
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
                                 return [o] {
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
