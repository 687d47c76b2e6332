// Per-point measurement uncertainty of the DCT workload: the image noise estimated from the
// images themselves, each centroid's standard deviation from it, and their propagation through
// the MLS or FE shape functions to a standard deviation of every displacement and strain value.
// Computed on the host in float64 from what every backend returns (the dots, the matches, the
// look-up tables), so cpu-seq, cpu-par and cuda state the same uncertainty.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "workloads/dct/backend.hpp"

namespace dtflop::dct {

// The grey-level noise of an image: the pooled standard deviation of background pixels about a
// plane fitted to each of a set of isolated dots' surrounding ring (native grey levels; 8-bit
// quantization included, as it is part of what the centroid sees).
struct NoiseEstimate {
  double sigma = std::numeric_limits<double>::quiet_NaN();
  int dots_used = 0;
  long pixels = 0;
  std::string why_not;  // empty when sigma is usable
  bool ok() const { return why_not.empty(); }
};
// Needs at least kMinNoiseDots isolated dots (ring clear of other dots and of the image edge).
inline constexpr int kMinNoiseDots = 10;
NoiseEstimate estimate_noise(const cv::Mat& image, const std::vector<DotObservation>& dots, const AnalysisOptions& o);

// Standard deviation (px, per axis) of one dot's centroid (eq. 7.1 with the background plane),
// linearised about this image: sigma^2 sum over contributing pixels of (x - c)^2 / W^2, plus
// the background plane's slope error, for pixels within the dot's equivalent radius + margin.
struct CentroidSigma {
  double x = std::numeric_limits<double>::quiet_NaN(), y = std::numeric_limits<double>::quiet_NaN();
};
CentroidSigma centroid_sigma(const cv::Mat& image, const DotObservation& d, double noise, const AnalysisOptions& o);

// Standard deviations of one point's values (px; strain dimensionless); NaN where unknown.
struct FieldSigma {
  double ux = std::numeric_limits<double>::quiet_NaN(), uy = ux, exx = ux, eyy = ux, exy = ux;
};

// Per reference dot, the variance (px^2, per axis) of its displacement: reference centroid plus
// matched deformed centroid; NaN where untracked.
// MLS: the shape functions phi_j of the full-derivative MLS (kernels.hpp) in float64; the
// values are linear in the dots' displacements, so var(u) = sum phi_j^2 var_j and likewise for
// the derivatives. FE: the triangle's N_i and their gradients.
std::vector<FieldSigma> propagate_mls(const MlsTable& t, const std::vector<Vec2>& reference,
                                      const std::vector<std::uint8_t>& tracked, const std::vector<Vec2>& dot_var,
                                      const MlsOptions& o, const std::vector<FieldValue<double>>& fields);
std::vector<FieldSigma> propagate_fe(const FeTable& t, const std::vector<std::uint8_t>& tracked,
                                     const std::vector<Vec2>& dot_var, const std::vector<FieldValue<double>>& fields);

struct FrameUncertainty {
  NoiseEstimate reference_noise, frame_noise;
  std::vector<CentroidSigma> reference_dots;  // per reference dot
  std::vector<CentroidSigma> frame_dots;      // per dot found in the frame
  std::vector<FieldSigma> points;             // per point
};
// Everything above for one processed frame of `b` (whose reference image is `reference`).
FrameUncertainty frame_uncertainty(const cv::Mat& reference, const cv::Mat& frame, const Backend& b,
                                   const FrameOutput& out);

}  // namespace dtflop::dct
