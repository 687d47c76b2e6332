// dct_render_independent: writes reference.png, deformed.png, dots.csv and truth.csv of a
// dot-pattern specimen drawn by the independent renderer (render.hpp), for checking the DCT
// workload against images dtflop did not make.
//   dct_render_independent OUT_DIR [key=value ...]
// keys: width height dots radius gap noise blur seed deformation (none, tension, bending,
// rotation, kirsch) strain nu curvature angle hole leaf
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "render.hpp"

int main(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "--help") {
    std::fprintf(stderr,
                 "usage: dct_render_independent OUT_DIR [width=1600 height=1200 dots=500 radius=7 gap=7 noise=1 "
                 "blur=0 seed=1 deformation=tension|bending|rotation|kirsch|none strain=1e-3 nu=0.3 curvature=2e-6 "
                 "angle=0.5 hole=150 leaf=0.03125]\n");
    return 2;
  }
  try {
    dct_indep::Params p;
    for (int i = 2; i < argc; ++i) {
      const std::string a = argv[i];
      const auto eq = a.find('=');
      if (eq == std::string::npos) throw std::invalid_argument("'" + a + "' is not key=value");
      const std::string k = a.substr(0, eq), v = a.substr(eq + 1);
      if (k == "deformation") p.deformation = v;
      else if (k == "width") p.width = std::stoi(v);
      else if (k == "height") p.height = std::stoi(v);
      else if (k == "dots") p.dots = std::stoi(v);
      else if (k == "seed") p.seed = std::stoull(v);
      else if (k == "radius") p.radius = std::stod(v);
      else if (k == "gap") p.min_gap = std::stod(v);
      else if (k == "noise") p.noise = std::stod(v);
      else if (k == "blur") p.blur = std::stod(v);
      else if (k == "strain") p.strain = std::stod(v);
      else if (k == "nu") p.nu = std::stod(v);
      else if (k == "curvature") p.curvature = std::stod(v);
      else if (k == "angle") p.angle_deg = std::stod(v);
      else if (k == "hole") p.hole = std::stod(v);
      else if (k == "leaf") p.leaf = std::stod(v);
      else throw std::invalid_argument("unknown key '" + k + "'");
    }
    const dct_indep::Scene s = dct_indep::make_scene(p);
    const std::filesystem::path dir(argv[1]);
    std::filesystem::create_directories(dir);
    cv::imwrite((dir / "reference.png").string(), dct_indep::finish(dct_indep::render_clean(s, false), p.noise, p.seed * 2));
    cv::imwrite((dir / "deformed.png").string(), dct_indep::finish(dct_indep::render_clean(s, true), p.noise, p.seed * 2 + 1));
    dct_indep::write_truth(s, dir.string());
    std::printf("wrote %s/{reference,deformed}.png, dots.csv, truth.csv (%zu dots; coverage error <= %.2g per pixel)\n",
                dir.string().c_str(), s.dots.size(), dct_indep::coverage_error_bound(p));
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dct_render_independent: %s\n", e.what());
    return 2;
  }
}
