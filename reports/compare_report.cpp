// The comparison report: two profiles (two machines, or two runs of one machine), parameter by
// parameter, with the ratio of the second to the first.
#include <cmath>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "calibrate/machine.hpp"
#include "reports/common.hpp"
#include "reports/reports.hpp"

namespace dtflop::reports {

Document compare_report(const MachineProfile& a, const std::string& name_a, const MachineProfile& b,
                        const std::string& name_b, const Context& ctx) {
  Document doc;
  doc.kind = "compare";
  doc.title = fmt::format("Comparison: {} against {}", name_b, name_a);
  const std::string ma = calib::describe(a.identity), mb = calib::describe(b.identity);
  doc.stamp = make_stamp(ctx, ma == mb ? ma : fmt::format("A: {}; B: {}", ma, mb),
                                   fmt::format("A: {}; B: {}", a.identity.measured_at, b.identity.measured_at));
  std::string why;
  const bool same = calib::same_machine(a.identity, b.identity, &why);
  doc.summary.push_back(same ? fmt::format("One machine, two runs: A = {} ({}), B = {} ({})", name_a,
                                           a.identity.measured_at, name_b, b.identity.measured_at)
                             : fmt::format("Two machines ({}): A = {} ({}), B = {} ({})", why, name_a, ma, name_b, mb));

  Section sec{"Parameters side by side", {}};
  Table t{{"parameter", "A", "B", "B / A", "what"}, {}, "lrrrl"};
  // Ratios as "how many times better B is", so every bar reads the same way: rates and
  // bandwidths B/A, times (latencies) A/B.
  Chart c;
  c.id = "ratios";
  c.title = "How many times faster B is than A, per parameter";
  c.x = {"parameter", false};
  c.y = {"speed-up of B over A [x]", true};
  Series speed{"B over A (above 1: B is faster)", SeriesKind::bars, 2, {}};
  std::vector<std::string> only_a, only_b;
  for (const auto& pi : all_params()) {
    const Parameter* va = a.find(pi.id);
    const Parameter* vb = b.find(pi.id);
    if (!va && !vb) continue;
    if (!va) {
      only_b.push_back(std::string(pi.name));
      continue;
    }
    if (!vb) {
      only_a.push_back(std::string(pi.name));
      continue;
    }
    const double ratio = va->value != 0 ? vb->value / va->value : NAN;
    t.rows.push_back({std::string(pi.name), format_value(va->value, pi.unit), format_value(vb->value, pi.unit),
                      std::isfinite(ratio) ? fmt::format("{:.3g}", ratio) : "-", std::string(pi.what)});
    if (!(ratio > 0) || !std::isfinite(ratio) || pi.unit == "x" || pi.unit == "B") continue;
    const double speedup = pi.unit == "s" ? 1 / ratio : ratio;
    const double x = static_cast<double>(c.categories.size());
    c.categories.push_back(std::string(pi.name));
    speed.points.push_back({x, speedup, std::string(pi.name)});
  }
  sec.blocks.emplace_back(std::move(t));
  if (!only_a.empty()) sec.blocks.emplace_back(Paragraph{"Only in A: " + fmt::format("{}", fmt::join(only_a, ", ")) + "."});
  if (!only_b.empty()) sec.blocks.emplace_back(Paragraph{"Only in B: " + fmt::format("{}", fmt::join(only_b, ", ")) + "."});
  if (!speed.points.empty()) c.series.push_back(std::move(speed));
  if (!c.series.empty()) {
    c.note = "Rates and bandwidths: B / A; fixed costs (seconds): A / B. Above 1, B is faster.";
    sec.blocks.emplace_back(std::move(c));
  }
  doc.sections.push_back(std::move(sec));
  return doc;
}

}  // namespace dtflop::reports
