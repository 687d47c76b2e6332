// Field estimation (seed 6.2, 7.2, 7.3): displacement and strain at interpolation points from
// the tracked dots' displacements, by moving least squares (eqs. 7.2-7.6) or by linear finite
// elements on a Delaunay triangulation of the reference dots (cv::Subdiv2D). Both work in the
// reference configuration. The dot-to-point look-up table (seed 7.3) is built once per
// reference frame; each deformed frame then only reads it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "workloads/dct/kernels.hpp"
#include "workloads/dct/specimen.hpp"

namespace dtflop::dct {

// nx x ny interpolation points spread evenly over [x0, x1] x [y0, y1] (row-major, x fastest).
std::vector<Vec2> grid_points(double x0, double y0, double x1, double y1, int nx, int ny);
// The same over the bounding box of `dots`, inset by `inset` px.
std::vector<Vec2> grid_points_over(const std::vector<Vec2>& dots, int nx, int ny, double inset);

struct Support {
  enum class Kind { radius, dots } kind = Kind::dots;
  double radius = 0;  // px, for Kind::radius
  int dots = 200;     // for Kind::dots: the radius at each point is set so that exactly this
                      // many dots lie inside (midway between the n-th and (n+1)-th nearest)
  std::string str() const;  // "60dots" or "12.5px"
};
// "60dots", "60", "12.5px". Throws InputError.
Support parse_support(const std::string& text);

enum class Interp { mls, fe };
std::string to_string(Interp i);
Interp interp_from_string(const std::string& s);
std::string to_string(Weight w);
Weight weight_from_string(const std::string& s);
std::string to_string(PointStatus s);

struct MlsOptions {
  Weight weight = Weight::cubic_spline;
  Support support;
  // A support in dots larger than the reference holds: true (the default support) takes every
  // dot; false (a support the user gave) is refused with what to do.
  bool support_at_most_found = true;
  int min_dots = 6;                // the quadratic basis has 6 terms
  double min_pivot_ratio = 1e-5;   // smallest / largest LDL' pivot of A
  double max_gap = 2.5;            // nearest dot farther than this x median spacing: invalid
};

// MLS look-up table: for each point, the reference dots of its support (nearest first), its
// support radius, and the point's status when already known from geometry alone.
struct MlsTable {
  std::vector<Vec2> points;
  std::vector<std::int32_t> offsets;  // size points + 1 (CSR)
  std::vector<std::int32_t> dots;     // dot indices
  std::vector<double> rho;            // per point
  std::vector<PointStatus> geometry;  // ok or far_from_dots
  std::int64_t entries() const { return static_cast<std::int64_t>(dots.size()); }
};
MlsTable build_mls_table(const std::vector<Vec2>& reference, const std::vector<Vec2>& points, const MlsOptions& o);

// FE look-up table. The triangulation: per triangle its three dots and the constant
// shape-function gradients dN_i/dx, dN_i/dy. Per point: its triangle (-1 when outside) and
// shape functions N_i (the displacement), and the support's triangles with their recovery
// coefficients (CSR; the strain, kernels.hpp FePoint).
struct FeTable {
  std::vector<Vec2> points;
  std::vector<std::int32_t> tri;       // 3 per point (-1 when outside)
  std::vector<double> N;               // 3 per point
  std::vector<std::int32_t> tri_dots;  // 3 per triangle
  std::vector<double> tri_gx, tri_gy;  // 3 per triangle
  std::vector<std::int32_t> offsets;   // size points + 1
  std::vector<std::int32_t> support;   // triangle indices
  std::vector<double> coef;            // recovery coefficient per entry
  std::vector<PointStatus> geometry;   // ok, outside_mesh, far_from_dots, too_few_dots or ill_conditioned
  std::int64_t triangles = 0;          // in the triangulation
  std::int64_t entries() const { return static_cast<std::int64_t>(support.size()); }
};
// `max_gap`: a point whose nearest dot is farther than max_gap x the median spacing is
// far_from_dots, and a triangle with an edge longer than twice that (one spanning a hole, or
// a sliver along the pattern's hull) gives no gradient to the recovery (it still interpolates
// the displacement of a point inside it). `recovery` gives the support and weight of the
// gradient recovery (the same support as MLS: `200dots` by default).
FeTable build_fe_table(const std::vector<Vec2>& reference, const std::vector<Vec2>& points, double max_gap,
                       const MlsOptions& recovery = {});

// Evaluation in float64 on the CPU. `disp` holds one displacement per reference dot and
// `tracked` says which are valid. `threads` > 1 spreads points over threads.
std::vector<FieldValue<double>> evaluate_mls(const MlsTable& t, const std::vector<Vec2>& reference,
                                             const std::vector<Vec2>& disp, const std::vector<std::uint8_t>& tracked,
                                             const MlsOptions& o, int threads = 1);
std::vector<FieldValue<double>> evaluate_fe(const FeTable& t, const std::vector<Vec2>& disp,
                                            const std::vector<std::uint8_t>& tracked, int threads = 1);

}  // namespace dtflop::dct
