// `dtflop specimen`: renders a synthetic DCT specimen (reference and deformed images) with
// its ground truth: the true dot centres and the true displacement and strain on a grid.
#include <cmath>
#include <filesystem>
#include <memory>
#include <string>

#include <fmt/format.h>

#include "cli/command.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/units.hpp"
#include "workloads/dct/fields.hpp"
#include "workloads/dct/io.hpp"
#include "workloads/dct/specimen.hpp"

namespace dtflop::cli {
namespace {

struct SpecimenOptions {
  std::string spec;
  std::string out;
  std::string format = "png";
  std::string truth_grid = "32x32";
};

void run(const SpecimenOptions& o) {
  using namespace dtflop::dct;
  if (o.format != "png" && o.format != "tiff")
    throw InputError(fmt::format("--format '{}' is unknown; use png or tiff", o.format));
  const Specimen s = parse_specimen(o.spec);
  const Size2 g = parse_size2(o.truth_grid, "--truth-grid", 4096);
  const std::filesystem::path dir(o.out);
  make_output_folder(dir, fmt::format("-o '{}'", o.out));
  const std::string ext = o.format == "png" ? ".png" : ".tiff";
  write_image(dir / ("reference" + ext), s.reference_image());
  write_image(dir / ("def_0001" + ext), s.deformed_image());
  {
    std::string f = "index,x_ref,y_ref,radius,x_def,y_def,u_x,u_y\n";
    const auto ref = s.reference_centres(), def = s.deformed_centres();
    for (std::size_t j = 0; j < ref.size(); ++j)
      f += fmt::format("{},{:.6f},{:.6f},{:.4f},{:.6f},{:.6f},{:.6f},{:.6f}\n", j, ref[j].x, ref[j].y, s.dots[j].radius,
                       def[j].x, def[j].y, def[j].x - ref[j].x, def[j].y - ref[j].y);
    write_file_atomically(dir / "dots.csv", f);
  }
  {
    std::string f = "x,y,in_material,u_x,u_y,e_xx,e_yy,e_xy\n";
    const auto pts = grid_points_over(s.reference_centres(), static_cast<int>(g.x), static_cast<int>(g.y), 0);
    for (const auto& p : pts) {
      const bool in = s.deformation->in_material(p);
      const Vec2 u = s.deformation->displacement(p);
      const Strain e = s.deformation->strain(p);
      f += fmt::format("{:.3f},{:.3f},{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n", p.x, p.y, in ? 1 : 0, u.x, u.y, e.xx,
                       e.yy, e.xy);
    }
    write_file_atomically(dir / "truth.csv", f);
  }
  fmt::print("{}\n{} dots, {}x{} {}-bit, {} dots on a {} ground\n", s.deformation->describe(), s.dots.size(),
             s.render.width, s.render.height, s.render.bit_depth,
             s.render.polarity == Polarity::dark_dots ? "dark" : "light",
             s.render.polarity == Polarity::dark_dots ? "light" : "dark");
  fmt::print("wrote {0}/reference{1}, {0}/def_0001{1}, {0}/dots.csv (true centres), {0}/truth.csv (true fields "
             "on a {2}x{3} grid)\n",
             dir.string(), ext, g.x, g.y);
  fmt::print("next: dtflop fields --reference {0}/reference{1} --frames '{0}/def_%04d{1}' -o {0}/out\n",
             dir.string(), ext);
}

}  // namespace

void add_specimen_command(CLI::App& root) {
  auto* app = root.add_subcommand(
      "specimen",
      "Render a synthetic dot-pattern specimen (reference and deformed images) with its ground truth: "
      "true dot centres and true displacement and strain (closed forms: translation, rotation, uniform, "
      "bending, Kirsch plate with a hole)");
  auto o = std::make_shared<SpecimenOptions>();
  app->add_option("spec", o->spec,
                  "KIND:key=value,... e.g. kirsch:size=2000x1500,a=150,strain=1e-3,pattern=random,radius=8,gap=8 "
                  "(kinds: reference, translation, rotation, uniform, bending, kirsch; keys: size, pattern "
                  "(grid|random|graded), pitch, radius, gap, count, seed, polarity (dark|light), blur, noise, "
                  "lighting, bits (8|16), ground, ink, margin, supersample, dx, dy, deg, strain, nu, k, a, load (x|y))")
      ->required();
  app->add_option("-o,--out", o->out, "Output folder")->required();
  app->add_option("--format", o->format, "Image format: png or tiff")->capture_default_str();
  app->add_option("--truth-grid", o->truth_grid, "Grid of the true fields in truth.csv")->capture_default_str();
  app->callback([o] { run(*o); });
}

}  // namespace dtflop::cli
