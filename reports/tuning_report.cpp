// The tuning report: what `dtflop tune -o` chose and why (docs/tune.md), and, where the tuning
// replayed its strategies, how each search approached the optimum, beside a peer's replay.
#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "model/units.hpp"
#include "reports/common.hpp"
#include "reports/reports.hpp"

namespace dtflop::reports {

namespace {

using nlohmann::json;

[[noreturn]] void bad(const std::string& what, const std::string& field, const std::string& expected) {
  throw InputError(fmt::format("{}: {} {}; give a file `dtflop tune -o` wrote", what, field, expected));
}

double number(const json& j, const char* field, const std::string& what) {
  if (!j.contains(field) || !j[field].is_number() || !std::isfinite(j[field].get<double>()))
    bad(what, field, "is missing or not a finite number");
  return j[field].get<double>();
}

std::string text(const json& j, const char* field, const std::string& what) {
  if (!j.contains(field) || !j[field].is_string()) bad(what, field, "is missing or not text");
  return j[field].get<std::string>();
}

struct Config {
  std::string label;
  double predicted = 0, lo = 0, hi = 0, error = 0;
  std::optional<double> measured;
};

Config config_of(const json& j, const std::string& what) {
  if (!j.is_object()) bad(what, "a configuration", "is not an object");
  Config c;
  c.label = text(j, "label", what);
  c.predicted = number(j, "predicted_seconds", what);
  c.error = number(j, "accuracy_error", what);
  if (!j.contains("interval90") || !j["interval90"].is_array() || j["interval90"].size() != 2 ||
      !j["interval90"][0].is_number() || !j["interval90"][1].is_number())
    bad(what, "interval90", "is not [lo, hi]");
  c.lo = j["interval90"][0].get<double>();
  c.hi = j["interval90"][1].get<double>();
  if (j.contains("measured_seconds")) c.measured = number(j, "measured_seconds", what);
  if (!(c.predicted > 0) || (c.measured && !(*c.measured > 0))) bad(what, c.label, "has a time that is not positive");
  return c;
}

}  // namespace

Document tuning_report(const json& r, const std::string& name, const std::vector<json>& peers, const Context& ctx) {
  const std::string what = fmt::format("tuning result '{}'", name);
  if (!r.is_object() || r.value("schema", "") != "dtflop.tuned") bad(what, "schema", "is not dtflop.tuned");
  const bool measured = text(r, "verdicts", what) == "measured";
  if (!r.contains("configurations") || !r["configurations"].is_array())
    bad(what, "configurations", "is missing (a result of an older dtflop: run the tuning again)");
  std::vector<Config> configs;
  for (const auto& j : r["configurations"]) configs.push_back(config_of(j, what));
  const std::optional<double> deadline =
      r.contains("deadline_seconds") ? std::optional<double>(number(r, "deadline_seconds", what)) : std::nullopt;
  const json& af = r.value("accuracy_figure", json::object());
  const std::string acc_name = af.value("name", "none"), acc_unit = af.value("unit", "");
  const auto time_of = [&](const Config& c) { return measured ? *c.measured : c.predicted; };

  Document doc;
  doc.kind = "tuning";
  doc.title = fmt::format("Tuning: scenario {} ({})", text(r, "scenario", what), text(r, "workload", what));
  doc.stamp = make_stamp(ctx, text(r, "machine", what), "");
  const json& space = r.value("space", json::object());
  doc.summary.push_back(fmt::format("{} configurations enumerated, {} valid after the constraints; {}",
                                    space.value("enumerated", 0), space.value("valid", 0),
                                    measured ? fmt::format("{} measured ({}: {})", r.value("measured", 0),
                                                           r.value("strategy", ""), r.value("stop_reason", ""))
                                             : "none measured: every verdict is a prediction"));
  if (r.contains("chosen")) {
    const Config chosen = config_of(
        json{{"label", r["chosen"].value("label", "")},
             {"predicted_seconds", r["chosen"]["predicted"].value("seconds", 0.0)},
             {"interval90", r["chosen"]["predicted"].value("interval90", json::array({0, 0}))},
             {"accuracy_error", r["chosen"]["accuracy"].value("error", 0.0)},
             {"measured_seconds", r["chosen"].value("measured_seconds", r["chosen"]["predicted"].value("seconds", 0.0))}},
        what);
    doc.summary.push_back(fmt::format("Chosen: {}: {} {} (predicted {}, 90% interval {} .. {}, {} basis){}",
                                      chosen.label, measured ? "measured" : "predicted",
                                      format_duration(time_of(chosen)), format_duration(chosen.predicted),
                                      format_duration(chosen.lo), format_duration(chosen.hi),
                                      r["chosen"]["predicted"].value("basis", "?"),
                                      deadline ? fmt::format("; deadline {}: {}", format_duration(*deadline),
                                                             r.value("meets_deadline", false) ? "met" : "NOT met")
                                               : std::string()));
  } else {
    doc.summary.push_back("Nothing was chosen: no configuration was measured");
  }

  // ---- Time against accuracy ----
  Section acc{"Time against accuracy", {}};
  if (acc_name != "none" && !configs.empty()) {
    Chart c;
    c.id = "time-accuracy";
    c.title = fmt::format("{} time per step against {}", measured ? "Measured" : "Predicted", acc_name);
    c.x = {fmt::format("{} time per step [s]", measured ? "measured" : "predicted"), true};
    c.y = {fmt::format("{} [{}]", acc_name, acc_unit), false};
    Series all{"configurations", SeriesKind::points, 0, {}};
    for (const auto& x : configs) all.points.push_back({time_of(x), x.error, x.label});
    c.series.push_back(std::move(all));
    Series front{"Pareto front", SeriesKind::line, 1, {}};
    if (r.contains("pareto_front") && r["pareto_front"].is_array())
      for (const auto& j : r["pareto_front"])
        front.points.push_back({j.value("measured_seconds", j["predicted"].value("seconds", 0.0)),
                                j["accuracy"].value("error", 0.0), j.value("label", "")});
    if (!front.points.empty()) c.series.push_back(std::move(front));
    if (deadline) {
      double lo = INFINITY, hi = -INFINITY;
      for (const auto& x : configs) lo = std::min(lo, x.error), hi = std::max(hi, x.error);
      Series d{"deadline", SeriesKind::line, 3, {{*deadline, lo, ""}, {*deadline, hi, ""}}};
      d.dashed = true;
      c.series.push_back(std::move(d));
    }
    c.note = "Down and to the left is better; the front holds the configurations nothing beats on both.";
    acc.blocks.emplace_back(std::move(c));
  } else {
    acc.blocks.emplace_back(Paragraph{"The scenario needs no accuracy: the fastest configuration is the answer."});
  }
  Table front_table{{"Pareto front: configuration", measured ? "measured" : "predicted", acc_name, "deadline"}, {}, "lrrl"};
  if (r.contains("pareto_front"))
    for (const auto& j : r["pareto_front"]) {
      const double t = j.value("measured_seconds", j["predicted"].value("seconds", 0.0));
      front_table.rows.push_back({j.value("label", ""), format_duration(t),
                                  fmt::format("{:.3g} {}", j["accuracy"].value("error", 0.0), acc_unit),
                                  deadline ? (t <= *deadline ? "met" : "missed") : "-"});
    }
  acc.blocks.emplace_back(std::move(front_table));
  doc.sections.push_back(std::move(acc));

  // ---- Predicted against measured ----
  if (measured) {
    Section pm{"Predicted against measured", {}};
    Chart c;
    c.id = "predicted-measured";
    c.title = "Each measured configuration: predicted against measured time per step";
    c.x = {"measured [s]", true};
    c.y = {"predicted [s]", true};
    c.diagonal = true;
    Series s{"configurations", SeriesKind::points, 0, {}};
    double err = 0;
    for (const auto& x : configs) {
      s.points.push_back({*x.measured, x.predicted, x.label});
      err += std::abs(x.predicted - *x.measured) / *x.measured;
    }
    c.series.push_back(std::move(s));
    c.note = fmt::format("Mean |predicted - measured| / measured: {:.1f}% over {} configurations; the search ranks "
                         "by prediction, so what matters is the order, not the level.",
                         configs.empty() ? 0.0 : 100 * err / static_cast<double>(configs.size()), configs.size());
    pm.blocks.emplace_back(std::move(c));
    doc.sections.push_back(std::move(pm));
  }

  // ---- The search ----
  std::vector<std::tuple<std::string, double, double>> rows;  // strategy, budget, median fraction
  if (r.contains("replay") && r["replay"].contains("rows"))
    for (const auto& j : r["replay"]["rows"])
      rows.emplace_back(j.value("strategy", ""), j.value("budget", 0.0), j.value("median_fraction_of_optimum", 0.0));
  for (std::size_t k = 0; k < peers.size(); ++k) {
    if (!peers[k].contains("rows") || !peers[k]["rows"].is_array())
      bad(fmt::format("peer replay #{}", k + 1), "rows", "is missing");
    for (const auto& j : peers[k]["rows"])
      rows.emplace_back(j.value("strategy", "peer"), j.value("budget", 0.0), j.value("median_fraction_of_optimum", 0.0));
  }
  if (!rows.empty()) {
    Section se{"How each search approached the optimum", {}};
    Chart c;
    c.id = "search";
    c.title = "Fraction of the optimum reached against measurements (median over seeds)";
    c.x = {"measurements", true};
    c.y = {"optimum / best measured", false};
    std::map<std::string, Series> by;
    int colour = 0;
    for (const auto& [s, b, f] : rows) {
      auto it = by.find(s);
      if (it == by.end()) it = by.emplace(s, Series{s, SeriesKind::line, colour++, {}}).first;
      it->second.points.push_back({b, f, s});
    }
    Table t{{"strategy", "measurements", "median fraction of the optimum"}, {}, "lrr"};
    for (auto& [s, series] : by) {
      std::sort(series.points.begin(), series.points.end(), [](const Point& a, const Point& b) { return a.x < b.x; });
      for (const auto& p : series.points) t.rows.push_back({s, fmt::format("{:.0f}", p.x), fmt::format("{:.3f}", p.y)});
      c.series.push_back(series);
    }
    c.note = "Each strategy replayed on the stored times of the whole measured space (the same measure step).";
    se.blocks.emplace_back(std::move(c));
    se.blocks.emplace_back(std::move(t));
    doc.sections.push_back(std::move(se));
  }

  // ---- The space ----
  Section sp{"The space and its constraints", {}};
  Table removed{{"constraint", "configurations removed", "for example"}, {}, "lrl"};
  if (space.contains("removed") && space["removed"].is_object())
    for (const auto& [k, v] : space["removed"].items())
      removed.rows.push_back({k, v.dump(), space.value("removed_example", json::object()).value(k, "")});
  if (removed.rows.empty()) sp.blocks.emplace_back(Paragraph{"No configuration was removed."});
  else sp.blocks.emplace_back(std::move(removed));
  if (r.contains("failures") && r["failures"].is_array() && !r["failures"].empty()) {
    Table f{{"failed to measure", "why"}, {}, "ll"};
    for (const auto& j : r["failures"]) f.rows.push_back({j.value("label", ""), j.value("failure", "")});
    sp.blocks.emplace_back(std::move(f));
  }
  doc.sections.push_back(std::move(sp));
  return doc;
}

}  // namespace dtflop::reports
