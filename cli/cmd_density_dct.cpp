// `dtflop density`: the seed's dot-density study (7.5.3.2, Figure 7.16) as a table:
// strain error against the number of dots per support domain, on a specimen under 0.1%
// uniform tension whose closed form is known.
#include <cmath>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "cli/command.hpp"
#include "workloads/workload.hpp"
#include "cli/table.hpp"
#include "model/errors.hpp"
#include "model/units.hpp"
#include "workloads/dct/backend.hpp"
#include "workloads/dct/specimen.hpp"

namespace dtflop::cli {
namespace {

struct DensityOptions {
  std::string backend = "cpu-par";
  std::string specimen = "uniform:size=1600x1200,strain=1e-3,nu=0.3,pattern=random,radius=5,gap=5,seed=5";
  std::string supports = "13,25,37,49,61,73,85,97,109,121,133,145,157,169,181,193";
  std::string points = "64x32";
  std::string weight = "cubic";
};

void run(const DensityOptions& o) {
  using namespace dtflop::dct;
  const Specimen s = parse_specimen(o.specimen);
  const cv::Mat ref = s.reference_image(), def = s.deformed_image();
  const Size2 g = parse_size2(o.points, "--points", 4096);
  std::vector<int> supports;
  {
    std::stringstream in(o.supports);
    std::string item;
    while (std::getline(in, item, ',')) supports.push_back(parse_support(item).dots);
  }
  if (supports.empty()) throw InputError("--supports lists no support size");
  fmt::print("{}; {} dots; {} points; backend {}, MLS {} weight\n", s.deformation->describe(), s.dots.size(),
             g.x * g.y, o.backend, o.weight);
  Table t({"dots per support", "valid points", "e_xx RMS err [ue]", "e_yy RMS err [ue]", "e_xy RMS err [ue]",
           "mean e_xx [ue]", "u RMS err [px]", "fields time"});
  for (int n : supports) {
    PipelineOptions p;
    p.mls.support.kind = Support::Kind::dots;
    p.mls.support.dots = n;
    p.mls.weight = weight_from_string(o.weight);
    p.points_x = static_cast<int>(g.x);
    p.points_y = static_cast<int>(g.y);
    auto b = make_backend(o.backend, p);
    b->set_reference(ref);
    const FrameOutput out = b->process(def);
    double sxx = 0, syy = 0, sxy = 0, su = 0, mean = 0;
    int k = 0;
    for (std::size_t m = 0; m < out.fields.size(); ++m) {
      const auto& f = out.fields[m];
      if (f.status != PointStatus::ok) continue;
      const Vec2 P = b->points()[m];
      const Strain e = s.deformation->strain(P);
      const Vec2 u = s.deformation->displacement(P);
      sxx += std::pow(f.exx - e.xx, 2);
      syy += std::pow(f.eyy - e.yy, 2);
      sxy += std::pow(f.exy - e.xy, 2);
      su += std::pow(f.ux - u.x, 2) + std::pow(f.uy - u.y, 2);
      mean += f.exx;
      ++k;
    }
    if (k == 0) {
      t.row({fmt::format("{}", n), "0", "-", "-", "-", "-", "-", "-"});
      continue;
    }
    t.row({fmt::format("{}", n), fmt::format("{}", k), fmt::format("{:.1f}", 1e6 * std::sqrt(sxx / k)),
           fmt::format("{:.1f}", 1e6 * std::sqrt(syy / k)), fmt::format("{:.1f}", 1e6 * std::sqrt(sxy / k)),
           fmt::format("{:.1f}", 1e6 * mean / k), fmt::format("{:.4f}", std::sqrt(su / (2 * k))),
           format_duration(out.seconds.at("fields"))});
  }
  fmt::print("{}", t.str());
  fmt::print("(errors against the closed form at every valid point; points near the specimen's edge have one-sided "
             "supports, as in the seed's study)\n");
}

}  // namespace

void add_density_command(CLI::App& root) {
  auto* app = root.add_subcommand(
      "density",
      "The seed's dot-density study: strain error vs dots per MLS support domain (13..193) on a rendered "
      "specimen under 0.1% tension");
  auto o = std::make_shared<DensityOptions>();
  app->add_option("--backend", o->backend, "DCT backend: " + workload::find("dct").backend_names())->capture_default_str();
  app->add_option("--specimen", o->specimen, "Specimen (see `dtflop specimen --help`)")->capture_default_str();
  app->add_option("--supports", o->supports, "Dots per support, comma-separated")->capture_default_str();
  app->add_option("--points", o->points, "Interpolation grid")->capture_default_str();
  app->add_option("--weight", o->weight, "MLS weight: cubic, quartic or gaussian")->capture_default_str();
  app->callback([o] { run(*o); });
}

}  // namespace dtflop::cli
