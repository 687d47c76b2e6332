// Ground truth for the DCT workload: dot patterns, deformations with closed-form
// displacement and strain, and a renderer with exact area coverage.
//
// Coordinates are image pixels: x along columns, y along rows, the centre of pixel (row i,
// column j) at (j, i); pixel (i, j) covers [j - 1/2, j + 1/2] x [i - 1/2, i + 1/2]. A
// deformation maps a reference (undeformed) point X to x = X + u(X). Strain is the
// Green-Lagrange strain of u, E = (F'F - I) / 2 with F = I + grad u (tensor shear), which the
// fields compute too (kernels.hpp, strain_from_gradient): zero under a rigid rotation, and
// eq. 6.5's small strain e_xx = du_x/dx, e_yy = du_y/dy, e_xy = (du_x/dy + du_y/dx) / 2 to
// first order (small_strain_of).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace dtflop::dct {

struct Vec2 {
  // Constructors (not an aggregate): nvcc 13 with libstdc++ 12 in C++20 cannot copy vectors
  // of aggregates with default member initializers (std::construct_at).
  constexpr Vec2() = default;
  constexpr Vec2(double x_, double y_) : x(x_), y(y_) {}
  double x = 0;
  double y = 0;
};

// Displacement gradient du_i/dX_j: [[ux_x, ux_y], [uy_x, uy_y]].
struct Gradient {
  double ux_x = 0, ux_y = 0, uy_x = 0, uy_y = 0;
};

struct Strain {
  double xx = 0, yy = 0, xy = 0;
};

inline Strain small_strain_of(const Gradient& g) { return {g.ux_x, g.uy_y, 0.5 * (g.ux_y + g.uy_x)}; }
inline Strain strain_of(const Gradient& g) {
  return {g.ux_x + 0.5 * (g.ux_x * g.ux_x + g.uy_x * g.uy_x), g.uy_y + 0.5 * (g.ux_y * g.ux_y + g.uy_y * g.uy_y),
          0.5 * (g.ux_y + g.uy_x + g.ux_x * g.ux_y + g.uy_x * g.uy_y)};
}

// A deformation with closed-form displacement u(X) and gradient, X in reference pixels.
class Deformation {
 public:
  virtual ~Deformation() = default;
  virtual Vec2 displacement(Vec2 X) const = 0;
  virtual Gradient gradient(Vec2 X) const = 0;
  // False where the material is absent (inside a hole).
  virtual bool in_material(Vec2 X) const { (void)X; return true; }
  virtual std::string describe() const = 0;
  Strain strain(Vec2 X) const { return strain_of(gradient(X)); }
  Vec2 map(Vec2 X) const {
    const Vec2 u = displacement(X);
    return {X.x + u.x, X.y + u.y};
  }
  // The reference point X with map(X) = x (Newton on the closed-form gradient, started at
  // x - u(x)). Returns nothing when it does not converge or lands outside the material.
  std::optional<Vec2> inverse(Vec2 x) const;
};

// None: the reference configuration.
std::unique_ptr<Deformation> make_identity();
// Rigid translation by (dx, dy) pixels.
std::unique_ptr<Deformation> make_translation(double dx, double dy);
// Rigid rotation by `radians` about `centre`. Its small strain is not zero
// (cos(theta) - 1 on the diagonal): the truth reports that, as MLS estimates it.
std::unique_ptr<Deformation> make_rotation(Vec2 centre, double radians);
// Uniform strain about `centre`: u_x = e_xx (X - cx), u_y = e_yy (Y - cy), plus e_xy shear
// split symmetrically.
std::unique_ptr<Deformation> make_uniform(Vec2 centre, double e_xx, double e_yy, double e_xy = 0);
// Pure bending about the neutral axis y = centre.y with curvature k (1/px), Poisson nu:
// u_x = -k x y, u_y = (k / 2)(x^2 + nu y^2), x and y relative to `centre`.
std::unique_ptr<Deformation> make_bending(Vec2 centre, double curvature, double nu);
// Kirsch's infinite plate with a circular hole of radius `a` px at `centre`, plane stress,
// uniaxial tension along x (or y when `load_along_y`) of far-field strain e0 = T / E.
std::unique_ptr<Deformation> make_kirsch(Vec2 centre, double a, double e0, double nu,
                                         bool load_along_y = false);

enum class Polarity { dark_dots, light_dots };

struct Dot {
  Vec2 centre;    // reference position, px
  double radius;  // px
};

// Dot patterns inside the rectangle [x0, x1] x [y0, y1] (px); `keep_out` (radius, centre)
// removes dots that would touch a hole. Every generator throws InputError on bad input.
struct PatternArea {
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  std::optional<Vec2> keep_out_centre;
  double keep_out_radius = 0;
};
// A regular grid with the given pitch; dots centred in the area.
std::vector<Dot> grid_pattern(const PatternArea& area, double pitch, double radius);
// Random dots, none closer than 2 r + min_gap (edge to edge >= min_gap), up to `count`
// (throws if fewer than count could be placed in 200 count tries; count <= 0: as many as fit).
std::vector<Dot> random_pattern(const PatternArea& area, double radius, double min_gap, int count,
                                std::uint64_t seed);
// Graded density: near `focus` the pitch is `pitch_near` and the radius `radius_near`; they
// grow linearly to the `_far` values at distance `grade_length` and stay there.
struct Graded {
  Vec2 focus;
  double pitch_near = 0, pitch_far = 0, radius_near = 0, radius_far = 0, grade_length = 0;
};
std::vector<Dot> graded_pattern(const PatternArea& area, const Graded& g, std::uint64_t seed);

struct RenderOptions {
  int width = 0, height = 0;
  Polarity polarity = Polarity::dark_dots;
  double ground = 200;       // grey level of the surface (8-bit scale)
  double ink = 40;           // grey level of the dots (8-bit scale)
  double hole_level = 20;    // grey level seen through a hole
  int supersample = 16;      // samples per pixel side on dot edges (exact area coverage)
  double blur_sigma = 0;     // px, Gaussian optics blur; 0 = none
  double noise_sigma = 0;    // grey levels (8-bit scale) of additive Gaussian sensor noise
  double lighting = 0;       // relative brightness change from left to right edge (0.2 = 20%)
  int bit_depth = 8;         // 8 or 16 (16-bit values are 257x the 8-bit scale)
  std::uint64_t seed = 1;    // noise seed
};
// Throws InputError for sizes outside 1..24 MP (and sides up to 16384), bad bit depth, etc.
void validate(const RenderOptions& o);

// Renders the dots, deformed by `def`, into a CV_8UC1 or CV_16UC1 image. Uses the dot's
// exact pre-image at each sample (Deformation::inverse), so sub-pixel truth is honest.
cv::Mat render(const std::vector<Dot>& dots, const Deformation& def, const RenderOptions& o,
               const std::optional<std::pair<Vec2, double>>& hole = std::nullopt);

// Everything about one synthetic specimen: the dots, the deformation, and the truth.
struct Specimen {
  std::vector<Dot> dots;
  std::shared_ptr<const Deformation> deformation;
  std::optional<std::pair<Vec2, double>> hole;  // centre, radius (Kirsch)
  RenderOptions render;
  // True centres in the reference and deformed frames, in `dots` order.
  std::vector<Vec2> reference_centres() const;
  std::vector<Vec2> deformed_centres() const;
  cv::Mat reference_image() const;
  cv::Mat deformed_image() const;
};

// Parses a specimen description, e.g.
//   "uniform:size=800x600,strain=1e-3,nu=0.3,pattern=grid,pitch=24,radius=6"
//   "kirsch:size=1200x1200,a=120,strain=1e-3,nu=0.3,pattern=random,radius=5,gap=6"
//   "translation:dx=0.3,dy=-1.2" "rotation:deg=0.5" "bending:k=1e-6,nu=0.3"
// Keys (all optional): size, pattern (grid|random|graded), pitch, radius, gap, count, seed,
// polarity (dark|light), blur, noise, lighting, bits, ground, ink, margin; per deformation:
// dx, dy, deg, strain, nu, k, a, load (x|y). Throws InputError naming the bad key.
Specimen parse_specimen(const std::string& text);

}  // namespace dtflop::dct
