// The transfer model dtflop fits to a size sweep: time = L + bytes / B (a latency per copy
// plus bytes over a bandwidth), by weighted linear least squares.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

namespace dtflop::probes {

struct TransferPoint {
  double bytes = 0;    // bytes moved by one copy (> 0)
  double seconds = 0;  // typical (median) time of one copy (> 0)
};

struct LatencyBandwidthFit {
  double latency = 0;          // L [s]; 0 when the data put it below zero (see latency_clamped)
  double bandwidth = 0;        // B [B/s]
  double latency_hw95 = 0;     // half-width of a 95% confidence interval of L [s]
  double bandwidth_hw95 = 0;   // half-width of a 95% confidence interval of B [B/s]
  double rms_rel_residual = 0; // root mean square of (fitted - measured) / measured
  double max_rel_residual = 0; // largest |fitted - measured| / measured
  std::size_t points = 0;
  // True when the unconstrained fit gave L < 0: the model was refitted with L = 0, and L
  // must not be reported as a measured latency.
  bool latency_clamped = false;
};

// Fits time = L + bytes / B minimising the sum of squared *relative* residuals
// ((L + bytes/B - t) / t)^2, so a 4 KiB copy of 10 us weighs as much as a 1 GiB copy of
// 20 ms; an unweighted fit would let the large copies decide L alone. Confidence intervals
// come from the covariance of the linear fit in (L, 1/B), with Student's t for n - 2 degrees
// of freedom (the delta method maps 1/B to B).
// Throws std::invalid_argument with fewer than 3 points, a non-positive or non-finite
// value, fewer than 2 distinct sizes, or data that give no positive bandwidth.
LatencyBandwidthFit fit_latency_bandwidth(std::span<const TransferPoint> points);

// The same model counted in events instead of bytes: time = L + events x C (a fixed cost plus a
// cost per event, e.g. per serialized atomic update), fitted by fit_latency_bandwidth() with
// `bytes` holding the event counts. C = 1 / B; its 95% half-width comes from B's by the delta
// method (C_hw95 = B_hw95 / B^2). Throws as fit_latency_bandwidth() does.
struct PerEventFit {
  double fixed = 0;              // L [s]
  double per_event = 0;          // C [s]
  double fixed_hw95 = 0;
  double per_event_hw95 = 0;
  double rms_rel_residual = 0;
  bool fixed_clamped = false;    // as LatencyBandwidthFit::latency_clamped
};
PerEventFit fit_per_event(std::span<const TransferPoint> points);

// Several kinds of event timed apart within the same runs (a pass over a frame: its pixels
// labelled, counted, its window steps), runs of two or more sizes: each kind's line fitted alone
// (fit_per_event, its events against its seconds), and the runs' fixed cost, the kinds' fixed
// costs added, with the half-widths added in quadrature. Throws as fit_per_event() does.
struct KindsFit {
  std::vector<PerEventFit> kinds;  // in the order given
  double fixed = 0;                // the runs' time at no events, every kind's [s]
  double fixed_hw95 = 0;
};
KindsFit fit_kinds(std::span<const std::vector<TransferPoint>> kinds);

// Two-sided 95% quantile of Student's t distribution with `dof` degrees of freedom
// (tabulated up to 30, 1.96 beyond). Throws std::invalid_argument for dof < 1.
double student_t95(std::size_t dof);

}  // namespace dtflop::probes
