// Workloads of `dtflop predict` from the DCT reference workload: one frame's counts from an
// estimated shape (dots of a given radius, points, dots per support), before any image exists.
#include <memory>
#include <string>

#include <fmt/format.h>

#include "cli/command.hpp"
#include "model/errors.hpp"
#include "model/units.hpp"
#include "workloads/dct/counts.hpp"

namespace dtflop::cli {
namespace {

struct DctShapeOptions {
  std::string size = "6000x4000";
  std::int64_t dots = 1600;
  double radius = 24;
  std::string points = "64x32";
  std::int64_t support = 60;
  std::string interp = "mls";
  int bits = 8;
  int threads = 1;
  bool pageable = false;
};

std::shared_ptr<DctShapeOptions> add_options(CLI::App& app, bool gpu) {
  auto o = std::make_shared<DctShapeOptions>();
  app.add_option("--size", o->size, "Frame size, e.g. 6000x4000 (24 MP)")->capture_default_str();
  app.add_option("--dots", o->dots, "Dots on the specimen")->capture_default_str();
  app.add_option("--radius", o->radius, "Dot radius in the image, px")->capture_default_str();
  app.add_option("--points", o->points, "Interpolation grid, e.g. 64x32")->capture_default_str();
  app.add_option("--support", o->support, "Dots per MLS support domain")->capture_default_str();
  app.add_option("--interp", o->interp, "mls or fe")->capture_default_str();
  app.add_option("--bits", o->bits, "8 or 16-bit frames")->capture_default_str();
  if (gpu) app.add_flag("--pageable", o->pageable, "Frames in pageable host memory (default: pinned)");
  else app.add_option("--threads", o->threads, "CPU threads (cpu-par)")->capture_default_str();
  return o;
}

dct::FrameShape shape_of(const DctShapeOptions& o, nlohmann::json& params) {
  const Size2 sz = parse_size2(o.size, "--size", 16384);
  const Size2 pts = parse_size2(o.points, "--points", 4096);
  if (o.bits != 8 && o.bits != 16) throw InputError(fmt::format("--bits {} must be 8 or 16", o.bits));
  if (o.support < 6) throw InputError("--support needs at least 6 dots (the quadratic basis)");
  const auto interp = dct::interp_from_string(o.interp);
  params = {{"width", sz.x},      {"height", sz.y},      {"dots", o.dots},   {"radius", o.radius},
            {"points", pts.x * pts.y}, {"support", o.support}, {"interp", o.interp}, {"bits", o.bits}};
  return dct::estimate_shape(sz.x, sz.y, o.bits / 8, o.dots, o.radius, pts.x * pts.y, o.support, interp);
}

PredictRegistrar cuda_target({"dct-cuda",
                              "One DCT frame on the cuda backend: upload, threshold, labelling, centroids, "
                              "MLS/FE on the device, fields back (estimated image shape)",
                              [](CLI::App& app) -> CountsFn {
                                auto o = add_options(app, true);
                                return [o](const MachineProfile*) {
                                  nlohmann::json p;
                                  const auto s = shape_of(*o, p);
                                  return CountsResult{
                                      dct::cuda_counts(s, o->pageable ? HostMemory::pageable : HostMemory::pinned), p,
                                      fmt::format("dct-cuda: {} frame, {} dots of radius {} px, {} points, {} dots "
                                                  "per support ({})",
                                                  o->size, o->dots, o->radius, s.points, o->support, o->interp)};
                                };
                              }});

PredictRegistrar cpu_target({"dct-cpu",
                             "One DCT frame on cpu-seq (--threads 1) or cpu-par, float64 (estimated image shape)",
                             [](CLI::App& app) -> CountsFn {
                               auto o = add_options(app, false);
                               return [o](const MachineProfile*) {
                                 nlohmann::json p;
                                 const auto s = shape_of(*o, p);
                                 p["threads"] = o->threads;
                                 return CountsResult{dct::cpu_counts(s, o->threads), p,
                                                     fmt::format("dct-cpu: {} frame, {} dots, {} points, {} dots per "
                                                                 "support, {} thread(s)",
                                                                 o->size, o->dots, s.points, o->support, o->threads)};
                               };
                             }});

}  // namespace
}  // namespace dtflop::cli
