// The comparison report: two profiles (two machines, or two runs of one machine), parameter by
// parameter, with the ratio of the second to the first.
#include <cmath>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <map>

#include "model/profile.hpp"
#include "calibrate/rounds.hpp"
#include "calibrate/store.hpp"
#include "model/errors.hpp"
#include "model/units.hpp"
#include "reports/common.hpp"
#include "reports/reports.hpp"

namespace dtflop::reports {

Document compare_report(const MachineProfile& a, const std::string& name_a, const MachineProfile& b,
                        const std::string& name_b, const Context& ctx) {
  Document doc;
  doc.kind = "compare";
  doc.title = fmt::format("Comparison: {} against {}", name_b, name_a);
  const std::string ma = dtflop::describe(a.identity), mb = dtflop::describe(b.identity);
  doc.stamp = make_stamp(ctx, ma == mb ? ma : fmt::format("A: {}; B: {}", ma, mb),
                                   fmt::format("A: {}; B: {}", a.identity.measured_at, b.identity.measured_at));
  std::string why;
  const bool same = dtflop::same_machine(a.identity, b.identity, &why);
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

Document compare_runs_report(const std::vector<std::string>& stores_a, const std::string& name_a,
                             const std::vector<std::string>& stores_b, const std::string& name_b, const Context& ctx) {
  auto side = [](const std::vector<std::string>& stores) {
    calib::MergedRounds m = calib::merge_rounds(calib::load_samples(stores, {}).samples, calib::kDefaultRoundCombine);
    std::map<std::string, calib::Sample> by_key;
    for (auto& s : m.samples) by_key.emplace(s.key, std::move(s));
    return by_key;
  };
  const auto a = side(stores_a), b = side(stores_b);
  struct Row {
    const calib::Sample* a;
    const calib::Sample* b;
    double ta, tb;
  };
  std::vector<Row> rows;
  for (const auto& [key, sa] : a) {
    auto it = b.find(key);
    if (it == b.end()) continue;
    const Stats* xa = sa.find(calib::Component::total);
    const Stats* xb = it->second.find(calib::Component::total);
    if (!xa || !xb || sa.steps <= 0 || it->second.steps <= 0) continue;
    rows.push_back({&sa, &it->second, xa->median / static_cast<double>(sa.steps),
                    xb->median / static_cast<double>(it->second.steps)});
  }
  if (rows.empty())
    throw InputError(fmt::format("the runs share no configuration ({} in A, {} in B): compare stores of the same plan",
                                 a.size(), b.size()));
  const calib::Sample& fa = *rows.front().a;
  const calib::Sample& fb = *rows.front().b;
  Document doc;
  doc.kind = "compare";
  doc.title = fmt::format("Comparison of two runs: {} against {}", name_b, name_a);
  const std::string ma = dtflop::describe(fa.machine), mb = dtflop::describe(fb.machine);
  doc.stamp = make_stamp(ctx, ma == mb ? ma : fmt::format("A: {}; B: {}", ma, mb),
                         fmt::format("A: {}; B: {}", fa.measured_at, fb.measured_at));
  std::string why;
  doc.summary.push_back(dtflop::same_machine(fa.machine, fb.machine, &why)
                            ? fmt::format("One machine: A = {}, B = {}", name_a, name_b)
                            : fmt::format("Two machines ({}): A = {} ({}), B = {} ({})", why, name_a, ma, name_b, mb));
  double log_sum = 0, lo = INFINITY, hi = 0;
  for (const auto& r : rows) {
    const double q = r.tb / r.ta;
    log_sum += std::log(q);
    lo = std::min(lo, q);
    hi = std::max(hi, q);
  }
  doc.summary.push_back(fmt::format(
      "{} configurations in both ({} only in A, {} only in B); time per step B / A: geometric mean {:.3g}, from {:.3g} to "
      "{:.3g} (below 1: B is faster)",
      rows.size(), a.size() - rows.size(), b.size() - rows.size(), std::exp(log_sum / static_cast<double>(rows.size())),
      lo, hi));
  Section sec{"Configurations side by side", {}};
  Chart c;
  c.id = "runs";
  c.title = "Measured time per step, B against A";
  c.x = {fmt::format("A: {} [s per step]", name_a), true};
  c.y = {fmt::format("B: {} [s per step]", name_b), true};
  c.diagonal = true;
  std::map<std::string, int> colour_of;
  for (const auto& r : rows) {
    const std::string group = r.a->backend == r.b->backend ? r.a->backend : r.a->backend + " / " + r.b->backend;
    if (!colour_of.count(group)) {
      colour_of[group] = static_cast<int>(c.series.size());
      c.series.push_back({group, SeriesKind::points, static_cast<int>(c.series.size()), {}});
    }
    c.series[static_cast<std::size_t>(colour_of[group])].points.push_back({r.ta, r.tb, config_text(*r.a)});
  }
  c.note = "One point per configuration, rounds combined by the fastest; below the dashed line B is faster.";
  sec.blocks.emplace_back(std::move(c));
  std::sort(rows.begin(), rows.end(), [](const Row& x, const Row& y) { return x.tb / x.ta < y.tb / y.ta; });
  Table t{{"configuration", "A per step", "B per step", "B / A"}, {}, "lrrr"};
  for (const auto& r : rows)
    t.rows.push_back({r.a->backend + " " + config_text(*r.a), format_duration(r.ta), format_duration(r.tb), fmt::format("{:.3g}", r.tb / r.ta)});
  sec.blocks.emplace_back(std::move(t));
  doc.sections.push_back(std::move(sec));
  return doc;
}

}  // namespace dtflop::reports
