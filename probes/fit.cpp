#include "probes/fit.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Dense>
#include <fmt/format.h>

namespace dtflop::probes {

double student_t95(std::size_t dof) {
  // t_{0.975, dof}, dof = 1..30.
  static constexpr double table[] = {12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306,
                                     2.262,  2.228, 2.201, 2.179, 2.160, 2.145, 2.131, 2.120,
                                     2.110,  2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064,
                                     2.060,  2.056, 2.052, 2.048, 2.045, 2.042};
  if (dof < 1) throw std::invalid_argument("Student's t needs at least one degree of freedom");
  if (dof <= 30) return table[dof - 1];
  return 1.96;
}

LatencyBandwidthFit fit_latency_bandwidth(std::span<const TransferPoint> points) {
  const std::size_t n = points.size();
  if (n < 3)
    throw std::invalid_argument(fmt::format(
        "a latency + bandwidth fit needs at least 3 sizes, got {}", n));
  double smin = points[0].bytes, smax = points[0].bytes;
  for (const auto& p : points) {
    if (!(std::isfinite(p.bytes) && p.bytes > 0 && std::isfinite(p.seconds) && p.seconds > 0))
      throw std::invalid_argument(fmt::format(
          "fit point ({} bytes, {} s) is not a positive finite pair", p.bytes, p.seconds));
    smin = std::min(smin, p.bytes);
    smax = std::max(smax, p.bytes);
  }
  if (smax <= smin)
    throw std::invalid_argument("a latency + bandwidth fit needs at least 2 distinct sizes");

  // Relative residual of point i: (L + s_i x - t_i) / t_i, linear in (L, x = 1/B):
  // rows [1/t_i, s_i/t_i], target 1. Columns are scaled to unit norm so that the solve is
  // well conditioned although s_i spans six orders of magnitude.
  Eigen::MatrixXd A(n, 2);
  Eigen::VectorXd y = Eigen::VectorXd::Ones(static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i) {
    const auto r = static_cast<Eigen::Index>(i);
    A(r, 0) = 1.0 / points[i].seconds;
    A(r, 1) = points[i].bytes / points[i].seconds;
  }
  const Eigen::Vector2d scale(A.col(0).norm(), A.col(1).norm());
  const Eigen::MatrixXd As = A * scale.cwiseInverse().asDiagonal();
  const Eigen::Vector2d zs = As.colPivHouseholderQr().solve(y);
  Eigen::Vector2d z = zs.cwiseQuotient(scale);  // (L, x)

  LatencyBandwidthFit f;
  f.points = n;
  const std::size_t dof = n - 2;
  if (z(0) < 0) {
    // The data ask for a negative latency: refit the one-parameter model t = s x.
    f.latency_clamped = true;
    const Eigen::VectorXd c = A.col(1);
    z(0) = 0;
    z(1) = c.dot(y) / c.squaredNorm();
  }
  if (!(z(1) > 0) || !std::isfinite(z(1)))
    throw std::invalid_argument(
        "the sizes and times give no positive bandwidth (time does not grow with size)");

  const Eigen::VectorXd res = A * z - y;  // relative residuals
  f.rms_rel_residual = std::sqrt(res.squaredNorm() / static_cast<double>(n));
  f.max_rel_residual = res.cwiseAbs().maxCoeff();
  f.latency = z(0);
  f.bandwidth = 1.0 / z(1);

  // Covariance of (L, x): sigma^2 (A^T A)^-1 with sigma^2 = RSS / (n - p).
  const double t = student_t95(f.latency_clamped ? n - 1 : std::max<std::size_t>(dof, 1));
  if (f.latency_clamped) {
    const double var_x = res.squaredNorm() / static_cast<double>(n - 1) / A.col(1).squaredNorm();
    f.bandwidth_hw95 = t * std::sqrt(var_x) / (z(1) * z(1));
  } else {
    const Eigen::Matrix2d AtA = As.transpose() * As;
    const Eigen::Matrix2d cov_s = AtA.inverse() * (res.squaredNorm() / static_cast<double>(dof));
    const double var_L = cov_s(0, 0) / (scale(0) * scale(0));
    const double var_x = cov_s(1, 1) / (scale(1) * scale(1));
    f.latency_hw95 = t * std::sqrt(std::max(var_L, 0.0));
    f.bandwidth_hw95 = t * std::sqrt(std::max(var_x, 0.0)) / (z(1) * z(1));
  }
  return f;
}

PerEventFit fit_per_event(std::span<const TransferPoint> points) {
  const LatencyBandwidthFit f = fit_latency_bandwidth(points);
  PerEventFit e;
  e.fixed = f.latency;
  e.fixed_hw95 = f.latency_hw95;
  e.per_event = 1.0 / f.bandwidth;
  e.per_event_hw95 = f.bandwidth_hw95 / (f.bandwidth * f.bandwidth);
  e.rms_rel_residual = f.rms_rel_residual;
  e.fixed_clamped = f.latency_clamped;
  return e;
}

KindsFit fit_kinds(std::span<const std::vector<TransferPoint>> kinds) {
  KindsFit out;
  double variance = 0;
  for (const auto& points : kinds) {
    out.kinds.push_back(fit_per_event(points));
    out.fixed += out.kinds.back().fixed;
    variance += out.kinds.back().fixed_hw95 * out.kinds.back().fixed_hw95;
  }
  out.fixed_hw95 = std::sqrt(variance);
  return out;
}

}  // namespace dtflop::probes
