#include "reports/common.hpp"

#include <fmt/format.h>

#include "calibrate/sample.hpp"
#include "model/units.hpp"
#include "workloads/workload.hpp"

namespace dtflop::reports {

Stamp make_stamp(const Context& ctx, const std::string& machine, const std::string& date) {
  Stamp p;
  p.machine = machine;
  p.data_date = date;
  p.made_at = calib::utc_now();
  p.version = version();
  p.command = ctx.command;
  p.inputs = ctx.inputs;
  return p;
}

std::string format_value(double v, std::string_view unit) {
  if (unit == "x") return fmt::format("{:.3g}x", v);
  return format_quantity(v, unit);
}

std::string config_text(const calib::Sample& s) {
  try {
    const workload::Workload& w = workload::find(s.workload);
    return w.label(w.validate(s.parameters, w.backend(s.backend)));
  } catch (const std::exception&) {
    return s.key;
  }
}

Table parameter_table(const MachineProfile& p, bool only_fitted) {
  Table t{{"parameter", "value", "+-95%", "spread", "provenance", "what"}, {}, "lrrrll"};
  for (const auto& [id, v] : p.params()) {
    if (only_fitted && v.provenance != Provenance::fitted) continue;
    const auto& i = info(id);
    t.rows.push_back({std::string(i.name), format_value(v.value, i.unit),
                      v.uncertainty ? format_value(*v.uncertainty, i.unit) : "-",
                      v.spread ? fmt::format("{:.1f}%", 100 * *v.spread) : "-", std::string(to_string(v.provenance)),
                      std::string(i.what)});
  }
  return t;
}

}  // namespace dtflop::reports
