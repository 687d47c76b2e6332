// Helpers that turn timed repetitions into Measurements.
#pragma once

#include <optional>
#include <span>
#include <string>

#include "probes/fit.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes {

// A rate: `amount` (bytes, FLOPs) per repetition over the median time of the repetitions.
// stats describe the times. Throws std::invalid_argument on an empty sample or a
// non-positive median.
Measurement rate_measurement(std::string key, std::string label, std::string unit, double amount,
                             std::span<const double> seconds, std::optional<Param> param,
                             std::string note);

// A duration: the median of `seconds`.
Measurement time_measurement(std::string key, std::string label, std::span<const double> seconds,
                             std::optional<Param> param, std::string note);

// A cost per event: the slope of a fit t = L + events x C (fit_per_event()), its 95% half-width
// the uncertainty, in seconds; stats describe `seconds` (the repetitions of one point of the fit).
Measurement per_event_measurement(std::string key, std::string label, const PerEventFit& fit,
                                  std::span<const double> seconds, std::optional<Param> param, std::string note);

// "4 KiB", "16 MiB", "1 GiB" for whole binary sizes; used in keys and labels.
std::string size_label(std::int64_t bytes);
// "4KiB", "16MiB": the same without the space, for keys.
std::string size_key(std::int64_t bytes);

}  // namespace dtflop::probes
