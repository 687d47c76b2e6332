// Choosing the MLS support from the measured noise and the dot density (issue 15): a larger
// support averages more centroid noise away but smooths real strain gradients. Both halves are
// measured tables (results/dct-quality/support.md, with how they were made), not assumed:
//
// - noise: uniform tension on the independent renders (the quadratic basis reproduces it, so
//   the whole strain error is noise), per dots per support n the noise factor
//   k(n) = strain RMS error per component x median dot spacing / displacement sd per dot and
//   axis, averaged over three patterns of two densities (they agree within ~25%);
// - smoothing: Kirsch's plate on the independent renders, the bias of e_yy at the hole edge
//   (mean over noise draws minus the closed form) against the support radius rho over the
//   feature's length L = amplitude / steepest strain gradient (L = 2a/7 there: e_yy falls from
//   3 e0 to e0 with slope 7 e0 / a), relative to the amplitude (2 e0).
//
// The suggestion minimizes sqrt(noise^2 + bias^2) over the supports of the table, with noise =
// k(n) sd / spacing and bias = amplitude x beta (rho / L)^p (beta, p: a least-squares fit of
// the smoothing table in logarithms).
#pragma once

#include <vector>

#include "workloads/dct/fields.hpp"
#include "workloads/dct/kernels.hpp"
#include "workloads/dct/uncertainty.hpp"

namespace dtflop::dct {

struct SupportNoiseRow {
  int dots;                // dots per support
  double radius_spacings;  // mean support radius over the median dot spacing
  double noise_factor;     // strain RMS error x spacing / displacement sd
};
struct SupportBiasRow {
  double radius_over_length;  // support radius / feature length
  double relative_bias;       // |bias| / feature amplitude
};
const std::vector<SupportNoiseRow>& support_noise_table();
const std::vector<SupportBiasRow>& support_bias_table();

// The real strain gradient a support would smooth: the strain's largest deviation from its
// median (dimensionless) and the length over which it changes (px: that amplitude over the
// steepest strain gradient). length_px <= 0: none known (a field the basis reproduces).
struct StrainFeature {
  double amplitude = 0;
  double length_px = 0;
};

struct SupportSuggestion {
  int dots = 0;          // suggested dots per support
  double radius_px = 0;  // its radius at this density (the table's radius / spacing x spacing)
  double noise = 0;      // predicted strain noise per component (RMS)
  double bias = 0;       // predicted smoothing bias at the feature
  double total = 0;      // sqrt(noise^2 + bias^2)
};

// The predicted error at `dots` per support (the table interpolated in logarithms, its ends
// extended by their last segment's power law).
SupportSuggestion support_error(int dots, double displacement_sd_px, double spacing_px, const StrainFeature& feature);

// displacement_sd_px: a dot's displacement standard deviation per axis (reference and deformed
// centroid together); spacing_px: the dots' median nearest-neighbour distance; dots_available:
// the reference's dots. Candidates are 6 .. min(dots_available, the table's largest support).
// Throws InputError for sd or spacing not finite and positive, or fewer than 6 dots.
SupportSuggestion suggest_support(double displacement_sd_px, double spacing_px, int dots_available,
                                  const StrainFeature& feature = {});

// A frame's dot displacement standard deviation per axis, RMS over the tracked dots
// (reference and deformed centroids' stated deviations together); NaN without a noise estimate.
double displacement_sd(const FrameOutput& out, const FrameUncertainty& u);

// The feature of a measured strain field on an nx x ny grid of points (row-major, x fastest):
// per component, the amplitude is the largest deviation from the median over valid points and
// the gradient comes from central differences between valid neighbours, less their own noise
// from the stated deviations `sd` (in quadrature). The component with the shortest length among
// those whose amplitude stands 5 stated deviations clear of the noise; none (length 0) when no
// component does. The field measured at a large support is itself smoothed: the gradient is
// then underestimated and the length overestimated (a suggestion on the large side).
StrainFeature estimate_feature(const std::vector<Vec2>& points, const std::vector<FieldValue<double>>& fields,
                               const std::vector<FieldSigma>& sd, int nx, int ny);

// The suggestion for a measured frame (what `dtflop fields` prints and, without --support,
// applies): the dots' displacement sd, the reference's median spacing and dot count, and the
// strain feature of the frame's nx x ny grid of points (none when the points are not that grid).
// ok() is false when no suggestion can be made (no noise estimate, fewer than 6 dots). The
// displacement sd is taken as at least kCentroidFloorPx, the centroid error noiseless images
// still show (partial pixel coverage).
constexpr double kCentroidFloorPx = 0.001;
struct FrameSuggestion {
  SupportSuggestion suggestion;
  StrainFeature feature;
  double displacement_sd_px = 0, spacing_px = 0;
  int dots = 0;  // reference dots
  bool ok() const { return suggestion.dots > 0; }
};
FrameSuggestion suggest_for_frame(const Backend& b, const FrameOutput& out, const FrameUncertainty& u, int nx, int ny);

}  // namespace dtflop::dct
