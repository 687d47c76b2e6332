// An independent renderer of dot-pattern images for checking the DCT workload. It shares no
// code with workloads/dct (only the C++ standard library and OpenCV's core), so a convention
// or an error in dtflop's own renderer (workloads/dct/specimen.cpp) cannot hide here.
//
// Pixel convention (the one docs/dct.md states): pixel (column c, row r) is the unit square
// [c - 1/2, c + 1/2] x [r - 1/2, r + 1/2]; its centre has the integer coordinates (c, r).
//
// Each pixel's value is background - (background - dot) * coverage, where coverage is the
// area of the pixel covered by the deformed dot. The coverage is computed by adaptive
// subdivision of the pixel: a square cell whose reference-space distance to the dot's edge
// exceeds its half-diagonal (times the map's Lipschitz bound) is wholly inside or outside;
// other cells are split into four down to a side `leaf`, where the edge is replaced by its
// tangent line and the square is clipped against that half-plane exactly. The coverage error
// of one pixel is then at most about sqrt(2) leaf^2 / (4 radius) (coverage_error_bound()).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace dct_indep {

struct P2 {
  double x = 0, y = 0;
};

// du/dX of the forward map x = X + u(X), in the reference configuration.
struct Grad {
  double xx = 0, xy = 0, yx = 0, yy = 0;  // d u_x/dX, d u_x/dY, d u_y/dX, d u_y/dY
};

// A displacement field with a closed form.
class Field {
 public:
  virtual ~Field() = default;
  virtual P2 u(P2 X) const = 0;
  virtual Grad grad(P2 X) const = 0;
  // False inside a hole (no material there).
  virtual bool material(P2 X) const { (void)X; return true; }
  virtual std::string describe() const = 0;
};

struct Params {
  int width = 1600, height = 1200;
  int dots = 500;
  double radius = 7;         // px
  double min_gap = 7;        // px between dot edges
  double background = 200;  // grey levels (8-bit)
  double ink = 40;           // the dots' grey level
  double noise = 1;          // Gaussian noise, standard deviation in grey levels
  double blur = 0;           // Gaussian blur sigma, px (0: none), applied before the noise
  std::uint64_t seed = 1;    // dot positions
  std::string deformation = "tension";  // none, tension, bending, rotation, kirsch
  double strain = 1e-3;      // tension and Kirsch: far-field strain along the load
  double nu = 0.3;           // Poisson's ratio
  double curvature = 2e-6;   // bending: 1/px
  double angle_deg = 0.5;    // rotation
  double hole = 150;         // Kirsch: hole radius, px (load along y)
  double leaf = 1.0 / 32;    // smallest subdivision cell, px
};

struct Scene {
  Params p;
  std::vector<P2> dots;            // reference centres
  std::unique_ptr<Field> field;    // about the image centre
  P2 centre;                       // ((W - 1) / 2, (H - 1) / 2)
  P2 deformed(P2 X) const;         // X + u(X)
};

// Throws std::invalid_argument for parameters out of range.
Scene make_scene(const Params& p);

// The noiseless image (CV_64F, grey levels) of the reference (deformed = false) or deformed
// configuration, blurred when p.blur > 0.
cv::Mat render_clean(const Scene& s, bool deformed);
// Adds Gaussian noise of p.noise grey levels (seeded) and rounds to 8 bits.
cv::Mat finish(const cv::Mat& clean, double noise, std::uint64_t seed);

double coverage_error_bound(const Params& p);

// Small-strain tensor of a gradient.
inline double exx(const Grad& g) { return g.xx; }
inline double eyy(const Grad& g) { return g.yy; }
inline double exy(const Grad& g) { return 0.5 * (g.xy + g.yx); }
// Green-Lagrange strain E = (F'F - I) / 2, F = I + grad u: zero under a rigid rotation.
inline double gl_xx(const Grad& g) { return g.xx + 0.5 * (g.xx * g.xx + g.yx * g.yx); }
inline double gl_yy(const Grad& g) { return g.yy + 0.5 * (g.xy * g.xy + g.yy * g.yy); }
inline double gl_xy(const Grad& g) { return 0.5 * (g.xy + g.yx + g.xx * g.xy + g.yx * g.yy); }

// Writes dots.csv (id, reference and deformed centres, px) and truth.csv (a grid of
// positions with u, the gradient and the small strains in microstrain) into `dir`.
void write_truth(const Scene& s, const std::string& dir, int nx = 64, int ny = 48);

}  // namespace dct_indep
