// Pieces the reports share (not part of the library's interface).
#pragma once

#include <string>

#include "calibrate/sample.hpp"
#include "model/profile.hpp"
#include "reports/document.hpp"
#include "reports/reports.hpp"

namespace dtflop::reports {

// The stamp of a report on data measured on `machine` at `date`, made now by ctx.command.
Stamp make_stamp(const Context& ctx, const std::string& machine, const std::string& date);

// A parameter's value in its unit, for people ("54.7 GB/s", "3.85 us", "2.46x").
std::string format_value(double v, std::string_view unit);

// A sample's configuration in its workload's own words ("1000x1000 k33x33"); its key when it is
// not (or no longer) a configuration of a known workload.
std::string config_text(const calib::Sample& s);

// Every parameter of the profile: name, value, +-95%, spread, provenance, what it is
// (only_fitted: the fitted ones alone).
Table parameter_table(const MachineProfile& p, bool only_fitted);

}  // namespace dtflop::reports
